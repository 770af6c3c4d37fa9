"""Viewer files read back by the viewers' own readers: OVITO (its Python module) for the
LAMMPS dump + dump local pair, VTK's XML PolyData reader (what ParaView uses) for the .vtp
files. Positions, radii, rattlers, contact topology, periodic images and forces must come
back equal to the packing's."""
import numpy as np
import pytest

from forcespace.cli import main
from forcespace.io.packing_file import read_packing
from forcespace.io.viewers import OVITO_CONTACT_PROPERTIES, write_viewer_files
from forcespace.model.walls import contact_mu_array
from paths import PACKINGS

PACK = PACKINGS / "paper_mu0.1.h5"


@pytest.fixture(scope="module")
def packing():
    return read_packing(PACK)


@pytest.fixture(scope="module")
def ensemble(packing):
    from forcespace.model.problem import slice_problem
    from forcespace.sampling.hit_and_run import HitAndRun
    return HitAndRun(n=8, seed=3, chains=2, burn_in=50, thin=5).compute(
        slice_problem(packing, 28.0)).ensemble


def _ovito_load(directory):
    pytest.importorskip("ovito")
    from ovito.io import import_file
    from ovito.modifiers import LoadTrajectoryModifier

    header = (directory / "contacts.dump").read_text().splitlines()[8].split()[2:]
    pipe = import_file(str(directory / "packing.dump"))
    mod = LoadTrajectoryModifier()
    pipe.modifiers.append(mod)
    mod.source.load(str(directory / "contacts.dump"),
                    columns=[OVITO_CONTACT_PROPERTIES[c] for c in header])
    return pipe.compute()


def test_ovito_reads_back_disks_walls_and_the_force_network(packing, ensemble, tmp_path):
    p = packing
    write_viewer_files(p, tmp_path / "v", ("ovito",), ensemble)
    data = _ovito_load(tmp_path / "v")
    parts = data.particles
    ids = np.asarray(parts.identifiers)
    pos = np.asarray(parts.positions)
    typ = np.asarray(parts.particle_types)
    disk = typ != 3
    order = np.argsort(ids[disk])
    # disks: ids 1..n, positions wrapped into the periodic cell, radii, rattler flags
    assert np.array_equal(ids[disk][order], np.arange(1, p.n_disks + 1))
    xw = pos[disk][order, 0]
    assert np.allclose(np.mod(xw - p.x + 0.5 * p.width, p.width), 0.5 * p.width, atol=1e-12)
    # OVITO's text parser is within 1 ulp; it keeps radii in single precision
    assert np.allclose(pos[disk][order, 1], p.y, rtol=0, atol=1e-13)
    assert np.allclose(np.asarray(parts["Radius"])[disk][order], p.r, rtol=1e-7, atol=0)
    assert np.array_equal(np.asarray(parts["rattler"])[disk][order].astype(bool), p.rattlers())
    # the disks' spheres are see-through in OVITO's default view: the bonds inside show
    assert np.allclose(np.asarray(parts["Transparency"])[disk], 0.6)
    # the cell is the box: x periodic over the width, y between the plates
    cell = np.asarray(data.cell[...])
    assert cell[0, 0] == p.width and tuple(data.cell.pbc[:2]) == (True, False)
    assert cell[1, 3] == p.y_bottom and cell[1, 1] == pytest.approx(p.y_top - p.y_bottom)
    # bonds: one per contact, in contact order, with its forces
    bonds = parts.bonds
    k = np.asarray(bonds["Contact Index"])
    assert np.array_equal(k, np.arange(p.n_contacts))
    assert np.allclose(np.asarray(bonds["Normal Force"]), p.fn, rtol=1e-15, atol=0)
    assert np.allclose(np.asarray(bonds["Tangential Force"]), p.ft, rtol=1e-15, atol=0)
    mu = contact_mu_array(p.a, p.b, p.mu, p.plate_mu)
    mob = np.asarray(bonds["Mobilisation"])
    live = (p.fn > 0) & (mu > 0)
    assert np.allclose(mob[live], np.abs(p.ft[live]) / (mu[live] * p.fn[live]), rtol=1e-14)
    assert np.all(mob[mu == 0] == 0) and (mu == 0).sum() > 0   # frictionless plates
    assert mob.max() <= 1 + 1e-9                     # an admissible network: in every cone
    # topology + periodic image give back every disk-disk branch vector of the packing
    topo = np.asarray(bonds.topology)
    img = np.asarray(bonds["Periodic Image"])
    both = (p.a >= 0) & (p.b >= 0)
    branch = pos[topo[:, 1]] - pos[topo[:, 0]] + img[:, :1] * np.array([p.width, 0, 0])
    ref = np.column_stack([p.x[p.b] + p.image * p.width - p.x[p.a], p.y[p.b] - p.y[p.a]])
    assert np.allclose(branch[both, :2], ref[both], atol=1e-12)
    # wall contacts end on the wall at the contact point
    wall = ~both
    assert wall.sum() == ((p.a < 0) | (p.b < 0)).sum() > 0
    ends = np.where(p.a[wall] < 0, topo[wall, 0], topo[wall, 1])
    assert np.allclose(pos[ends, 1], p.point[wall, 1], rtol=0, atol=1e-12)
    # the ensemble's per-contact mean and spread, on the contacts it sampled
    F = ensemble.forces
    c = ensemble.contacts
    assert np.array_equal(np.asarray(bonds["Sampled"]).nonzero()[0], np.sort(c))
    assert np.allclose(np.asarray(bonds["Mean Normal Force"])[c], F[:, :, 0].mean(0),
                       rtol=0, atol=1e-15)
    spread = np.sqrt(((F - F.mean(0)) ** 2).sum(2).mean(0))
    assert np.allclose(np.asarray(bonds["Force Spread"])[c], spread, rtol=0, atol=1e-15)
    assert spread.max() > 0                          # dim S > 0: the samples differ


def _vtp(path):
    vtk = pytest.importorskip("vtkmodules.vtkIOXML")
    from vtkmodules.util.numpy_support import vtk_to_numpy

    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(str(path))
    reader.Update()
    out = reader.GetOutput()
    assert out.GetNumberOfPoints() > 0, f"VTK could not read {path}"

    def arrays(data):
        return {data.GetArrayName(i): vtk_to_numpy(data.GetArray(i))
                for i in range(data.GetNumberOfArrays())}
    pts = vtk_to_numpy(out.GetPoints().GetData())
    return out, pts, arrays(out.GetPointData()), arrays(out.GetCellData())


def test_vtk_reads_back_disks_contacts_and_walls(packing, ensemble, tmp_path):
    p = packing
    write_viewer_files(p, tmp_path / "v", ("vtk",), ensemble)
    out, pts, pdata, _ = _vtp(tmp_path / "v" / "disks.vtp")
    assert out.GetNumberOfVerts() == p.n_disks
    assert np.array_equal(pts[:, 0], p.x) and np.array_equal(pts[:, 1], p.y)
    assert np.array_equal(pdata["radius"], p.r)
    assert np.array_equal(pdata["rattler"].astype(bool), p.rattlers())
    out, pts, _, cdata = _vtp(tmp_path / "v" / "contacts.vtp")
    assert out.GetNumberOfLines() == p.n_contacts
    assert np.array_equal(cdata["fn"], p.fn) and np.array_equal(cdata["ft"], p.ft)
    assert np.array_equal(cdata["a"], p.a) and np.array_equal(cdata["b"], p.b)
    seg = pts[:, :2].reshape(-1, 2, 2)
    both = (p.a >= 0) & (p.b >= 0)
    # each disk-disk line runs from a's centre to b's centre at its periodic image
    assert np.array_equal(seg[both, 0, 0], p.x[p.a[both]])
    assert np.allclose(seg[both, 1, 0], p.x[p.b[both]] + p.image[both] * p.width, atol=1e-12)
    assert np.allclose(np.hypot(*(seg[both, 1] - seg[both, 0]).T),
                       p.r[p.a[both]] + p.r[p.b[both]] + p.gap[both], atol=1e-12)
    c = ensemble.contacts
    assert np.allclose(cdata["fn_mean"][c], ensemble.forces[:, :, 0].mean(0), atol=1e-15)
    out, pts, _, cdata = _vtp(tmp_path / "v" / "walls.vtp")
    assert sorted(cdata["wall"]) == [-2, -1]           # periodic x: only the two plates
    assert sorted(set(pts[:, 1])) == [p.y_bottom, p.y_top]
    assert (tmp_path / "v" / "packing.vtm").is_file()


def test_view_command_and_its_refusals(packing, tmp_path, capsys):
    assert main(["view", str(PACK), "-o", str(tmp_path / "v"), "--format", "vtk"]) == 0
    assert sorted(f.name for f in (tmp_path / "v").glob("*.vtp")) == \
        ["contacts.vtp", "disks.vtp", "walls.vtp"]
    assert not (tmp_path / "v" / "packing.dump").exists()
    # rerun into the directory forcespace made: replaced
    assert main(["view", str(PACK), "-o", str(tmp_path / "v")]) == 0
    assert (tmp_path / "v" / "packing.dump").exists()
    capsys.readouterr()
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    assert main(["view", str(PACK), "-o", str(mine)]) == 2     # someone else's directory
    assert (mine / "notes.txt").read_text() == "keep"
    assert main(["view", str(PACK), "-o", str(tmp_path / "w"), "--format", "xyz"]) == 2
    err = capsys.readouterr().err
    assert "non-empty directory" in err and "--format" in err and "Traceback" not in err
