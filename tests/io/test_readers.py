"""Readers of measured frames (CSV pair, PeGS matrices, PeGS2 lists, LAMMPS dump): bad inputs, conventions, the
packing file's provenance, and the round trip on jammed packings (same S as the native
file)."""
import hashlib
from pathlib import Path

import numpy as np
import pytest

import forcespace as fs
from forcespace.errors import InputError
from forcespace.io.packing_file import read_packing, write_packing
from forcespace.io.readers import read_pegs, read_pegs2, write_pegs, write_pegs2
from forcespace_studies.measured import FORMATS, round_trip

from reader_cases import CASES, SCALE, read, small_frame, spoil_and_read, write_all


@pytest.mark.parametrize("fmt, case, spoil, fragment", CASES, ids=[f"{c[0]}: {c[1]}"
                                                                   for c in CASES])
def test_bad_input_is_one_line_naming_the_file(tmp_path, fmt, case, spoil, fragment):
    with pytest.raises(InputError) as info:
        spoil_and_read(tmp_path, fmt, spoil)
    msg = str(info.value)
    assert fragment in msg and "\n" not in msg
    if not isinstance(spoil, str):        # a file's fault: the message names the file
        assert str(tmp_path) in msg


@pytest.mark.parametrize("fmt", FORMATS)
def test_valid_frame_reads_back_exactly(tmp_path, fmt):
    """The small frame in each format: the same disks, contacts and forces (fn, ft in the
    contact's frame; PeGS in pixels, y flipped, so positions move by a translation)."""
    p = small_frame()
    q = read(fmt, write_all(tmp_path))
    assert q.n_disks == 4 and q.n_contacts == 4
    assert np.allclose(q.r, p.r)
    assert np.allclose(np.diff(q.x), np.diff(p.x)) and np.allclose(np.ptp(q.y), 0.0)
    pairs = {frozenset((int(a), int(b))): (fn, ft) for a, b, fn, ft in
             zip(q.a, q.b, q.fn, q.ft) if a >= 0 and b >= 0}
    for k in range(3):
        assert np.allclose(pairs[frozenset((k, k + 1))], (p.fn[k], p.ft[k]), atol=1e-12)
    wall = np.flatnonzero(q.a < 0)
    assert wall.size == 1 and np.allclose(q.normal[wall[0]], (0.0, 1.0))
    assert np.allclose((q.fn[wall[0]], q.ft[wall[0]]), (0.5, 0.0))
    assert q.measurement.known.all() and q.measurement.provenance["format"]


def test_pegs_tangential_sign(tmp_path):
    """PeGS' force on particle i at its contact with j points along beta + pi - alpha in
    pixel coordinates (y down; forceBalance.m), fNorm = f cos(alpha), fTan = f sin(alpha).
    Read with y flipped, the force on the lower id (body a) is -(fn n + ft t)."""
    f, alpha = 2.0, np.radians(30.0)
    d = Path(tmp_path)
    # particle 1 at (100, 100) px, particle 2 to its right: beta = 0 for particle 1
    np.savetxt(d / "f_ParticleData.dlm", [[1, 100, 100, 20], [2, 140, 100, 20]], delimiter=",")
    B = np.array([[0, 1], [1, 0]], float)
    np.savetxt(d / "f_BinaryAdjacencyMatrix.dlm", B, delimiter=",")
    np.savetxt(d / "f_NormWeightedAdjacencyMatrix.dlm", B * f * np.cos(alpha), delimiter=",")
    np.savetxt(d / "f_TanWeightedAdjacencyMatrix.dlm", B * f * np.sin(alpha), delimiter=",")
    q = read_pegs(d / "f_ParticleData.dlm", pixel_scale=0.01, mu=1.0)
    assert q.a[0] == 0 and np.allclose(q.normal[0], (1.0, 0.0))
    assert np.isclose(q.fn[0], f * np.cos(alpha)) and np.isclose(q.ft[0], f * np.sin(alpha))
    on_a = -q.contact_forces()[0]
    direction = np.pi - alpha                        # beta + pi - alpha, pixel frame
    assert np.allclose(on_a, f * np.array([np.cos(direction), -np.sin(direction)]))
    q2 = read_pegs(d / "f_ParticleData.dlm", pixel_scale=0.01, mu=1.0, y_down=False)
    assert np.isclose(q2.ft[0], -f * np.sin(alpha))  # y already up: the other sense


@pytest.mark.parametrize("layout", ("positions", "centers"))
def test_pegs2_tangential_sign(tmp_path, layout):
    """PeGS2's list (frame, id1, id2, fTan, fNorm), one row per particle's estimate, reads
    as the matrices do: the same fn, ft and sign as test_pegs_tangential_sign."""
    f, alpha = 2.0, np.radians(30.0)
    d = Path(tmp_path)
    fn, ft = float(f * np.cos(alpha)), float(f * np.sin(alpha))
    (d / "img_Adjacency.txt").write_text(f"3,1,2,{ft!r},{fn!r}\n3,2,1,{ft!r},{fn!r}\n")
    if layout == "positions":
        (d / "pos.txt").write_text("3,1,100,100,20,0\n3,2,140,100,20,0\n")
    else:
        (d / "pos.txt").write_text("100,100,20,0\n140,100,20,0\n")
    q = read_pegs2(d / "img_Adjacency.txt", d / "pos.txt", pixel_scale=0.01, mu=1.0)
    assert q.n_contacts == 1 and q.a[0] == 0 and np.allclose(q.normal[0], (1.0, 0.0))
    assert np.isclose(q.fn[0], fn) and np.isclose(q.ft[0], ft)
    assert np.allclose(-q.contact_forces()[0], f * np.array([np.cos(np.pi - alpha),
                                                              -np.sin(np.pi - alpha)]))
    assert q.measurement.provenance["two_estimates"] == 1


def test_pegs2_reads_as_the_matrix_layout(tmp_path):
    """One frame written as PeGS2's list and as the matrices, the second estimates noisy:
    both readers give the same contacts, forces, uncertainties and wall normals."""
    p = small_frame()
    noise = np.zeros((p.n_contacts, 2))
    noise[0], noise[2] = (0.2, -0.04), (-0.1, 0.3)
    m = write_pegs(p, tmp_path / "m", pixel_scale=SCALE, noise=noise)["paths"]
    lst = write_pegs2(p, tmp_path / "l", pixel_scale=SCALE, noise=noise, frame=4)["paths"]
    a = read_pegs(m["particles"], pixel_scale=SCALE, mu=0.5, edge_column=4)
    b = read_pegs2(lst["adjacency"], lst["positions"], pixel_scale=SCALE, mu=0.5, frame=4)
    for name in ("a", "b", "fn", "ft", "normal", "x", "y", "r"):
        assert np.allclose(getattr(a, name), getattr(b, name), rtol=0, atol=1e-12), name
    assert np.allclose(a.measurement.sigma, b.measurement.sigma)
    assert b.measurement.provenance["frame"] == 4.0


def test_pegs_two_estimates_averaged_with_uncertainty(tmp_path):
    """Each contact is fitted from both particles: the mean is read, |difference| / 2 is
    its uncertainty."""
    p = small_frame()
    noise = np.zeros((p.n_contacts, 2))
    noise[0] = (0.2, -0.04)
    files = write_pegs(p, tmp_path, pixel_scale=SCALE, noise=noise)["paths"]
    q = read_pegs(files["particles"], pixel_scale=SCALE, mu=0.5, edge_column=4)
    k = int(np.flatnonzero((q.a == 0) & (q.b == 1))[0])
    assert np.allclose((q.fn[k], q.ft[k]), (p.fn[0] + 0.1, p.ft[0] - 0.02))
    assert np.allclose(q.measurement.sigma[k], (0.1, 0.02))


def test_packing_file_keeps_measurement_and_provenance(tmp_path):
    f = write_all(tmp_path)
    q = read("csv", f, length_unit="mm", force_unit="N")
    write_packing(q, tmp_path / "q.h5")
    back = read_packing(tmp_path / "q.h5")
    prov = back.measurement.provenance
    assert prov["units"] == {"length": "mm", "force": "N"}
    for rec, path in zip(prov["files"], (f["particles"], f["contacts"])):
        assert rec["name"] == path.name
        assert rec["sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    assert str(tmp_path) not in str(prov)              # no path of this machine
    assert np.array_equal(back.measurement.known, q.measurement.known)
    assert np.array_equal(back.a, q.a) and np.allclose(back.normal, q.normal)


@pytest.fixture(scope="module")
def jammed():
    return {mu: fs.jam("quick", physics__mu=mu) for mu in (0.1, 0.5, 1.0)}


@pytest.mark.slow
@pytest.mark.parametrize("mu", (0.1, 0.5, 1.0))
@pytest.mark.parametrize("fmt", FORMATS)
def test_round_trip_keeps_S(tmp_path, jammed, mu, fmt):
    """Written in each format and read back, a jammed packing's S of the same region is the
    native file's: the same dim S and every contact's range within 1e-9 <Fn>."""
    r = round_trip(jammed[mu], fmt, tmp_path, height=10.0)
    assert r["region_disks"] > 5
    assert r["dim_native"] == r["dim_read"]
    assert r["matched"] == r["n_contacts_native"] == r["n_contacts_read"] > 0
    assert r["max_range_diff"] <= 1e-9
