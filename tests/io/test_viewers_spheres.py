"""Viewer files of a sphere packing read back by OVITO's and VTK's own readers: positions,
radii, rattlers, the contact topology with both periodic images, and the forces."""
import numpy as np
import pytest

from forcespace.cli import main
from forcespace.io.packing_file import read_packing
from forcespace.io.viewers import OVITO_CONTACT_PROPERTIES, write_viewer_files
from paths import DATA

PACK = DATA / "quick3d_mu0.3.h5"


@pytest.fixture(scope="module")
def packing():
    return read_packing(PACK)


def test_ovito_reads_back_spheres_plates_and_the_force_network(packing, tmp_path):
    pytest.importorskip("ovito")
    from ovito.io import import_file
    from ovito.modifiers import LoadTrajectoryModifier

    p = packing
    write_viewer_files(p, tmp_path / "v", ("ovito",))
    header = (tmp_path / "v" / "contacts.dump").read_text().splitlines()[8].split()[2:]
    pipe = import_file(str(tmp_path / "v" / "packing.dump"))
    mod = LoadTrajectoryModifier()
    pipe.modifiers.append(mod)
    mod.source.load(str(tmp_path / "v" / "contacts.dump"),
                    columns=[OVITO_CONTACT_PROPERTIES[c] for c in header])
    data = pipe.compute()
    parts = data.particles
    ids = np.asarray(parts.identifiers)
    pos = np.asarray(parts.positions)
    sphere = np.asarray(parts.particle_types) != 3
    order = np.argsort(ids[sphere])
    assert np.array_equal(ids[sphere][order], np.arange(1, p.n_spheres + 1))
    size = np.array(p.lateral)
    got = pos[sphere][order]
    assert np.allclose(np.mod(got[:, :2] - p.pos[:, :2] + 0.5 * size, size), 0.5 * size,
                       atol=1e-12)
    assert np.allclose(got[:, 2], p.z, atol=1e-13)
    assert np.allclose(np.asarray(parts["Radius"])[sphere][order], p.r, rtol=1e-7)
    assert np.array_equal(np.asarray(parts["rattler"])[sphere][order].astype(bool),
                          p.rattlers())
    cell = np.asarray(data.cell[...])
    assert tuple(data.cell.pbc) == (True, True, False)
    assert (cell[0, 0], cell[1, 1]) == p.lateral and cell[2, 3] == p.z_bottom
    bonds = parts.bonds
    assert np.array_equal(np.asarray(bonds["Contact Index"]), np.arange(p.n_contacts))
    assert np.allclose(np.asarray(bonds["Normal Force"]), p.fn, rtol=1e-15, atol=0)
    assert np.allclose(np.asarray(bonds["Tangential Force"]), np.linalg.norm(p.ft, axis=1),
                       rtol=1e-15, atol=0)
    vector = np.column_stack([bonds[f"Tangential Force {c}"] for c in "XYZ"])
    assert np.allclose(vector, p.ft, rtol=1e-15, atol=0)
    # topology + both periodic images give back every sphere-sphere branch vector
    topo = np.asarray(bonds.topology)
    img = np.asarray(bonds["Periodic Image"])
    both = (p.a >= 0) & (p.b >= 0)
    branch = pos[topo[:, 1]] - pos[topo[:, 0]] + img * np.array([*size, 0.0])
    ref = p.pos[p.b] + np.column_stack([p.image * size, np.zeros(p.n_contacts)]) - p.pos[p.a]
    assert np.allclose(branch[both], ref[both], atol=1e-12)
    ends = np.where(p.a[~both] < 0, topo[~both, 0], topo[~both, 1])
    assert np.allclose(pos[ends, 2], p.point[~both, 2], atol=1e-12)


def test_vtk_reads_back_spheres_contacts_and_plates(packing, tmp_path):
    vtk = pytest.importorskip("vtkmodules.vtkIOXML")
    from vtkmodules.util.numpy_support import vtk_to_numpy

    def read(name):
        reader = vtk.vtkXMLPolyDataReader()
        reader.SetFileName(str(tmp_path / "v" / name))
        reader.Update()
        out = reader.GetOutput()
        cells = out.GetCellData()
        return (out, vtk_to_numpy(out.GetPoints().GetData()),
                {cells.GetArrayName(i): vtk_to_numpy(cells.GetArray(i))
                 for i in range(cells.GetNumberOfArrays())})

    p = packing
    write_viewer_files(p, tmp_path / "v", ("vtk",))
    out, pts, _ = read("spheres.vtp")
    assert out.GetNumberOfVerts() == p.n_spheres and np.array_equal(pts, p.pos)
    out, pts, cdata = read("contacts.vtp")
    assert out.GetNumberOfLines() == p.n_contacts
    assert np.array_equal(cdata["fn"], p.fn)
    assert np.array_equal(np.column_stack([cdata["ftx"], cdata["fty"], cdata["ftz"]]), p.ft)
    seg = pts.reshape(-1, 2, 3)
    both = (p.a >= 0) & (p.b >= 0)
    assert np.allclose(np.linalg.norm(seg[both, 1] - seg[both, 0], axis=1),
                       p.r[p.a[both]] + p.r[p.b[both]] + p.gap[both], atol=1e-12)
    _, pts, cdata = read("walls.vtp")
    assert sorted(set(cdata["wall"])) == [-2, -1]
    assert sorted(set(pts[:, 2])) == [p.z_bottom, p.z_top]


def test_info_draw_and_view_commands_take_a_sphere_packing(tmp_path, capsys):
    assert main(["info", str(PACK), "--json"]) == 0
    out = capsys.readouterr().out
    assert '"n_spheres": 60' in out and '"dimension": 3' in out
    assert main(["draw", str(PACK), "-o", str(tmp_path / "s.png")]) == 0
    assert (tmp_path / "s.png").stat().st_size > 10_000 and (tmp_path / "s.pdf").is_file()
    assert main(["view", str(PACK), "-o", str(tmp_path / "v"), "--json"]) == 0
    assert '"n_spheres": 60' in capsys.readouterr().out
    # S of spheres is sampled by hit-and-run and the billiard (tests/sampling/test_conic_walk);
    # the paper's relax walk runs the disk engine: refused in one line, naming the choices
    assert main(["sample", str(PACK), "--full", "--sampler", "relax", "-n", "10",
                 "-o", str(tmp_path / "e.h5")]) == 2
    err = capsys.readouterr().err
    assert "--sampler" in err and "billiard" in err and "Traceback" not in err
    assert not (tmp_path / "e.h5").exists()
    assert main(["analyze", str(PACK), "--full", "--clusters"]) == 2
    err = capsys.readouterr().err
    assert "--clusters" in err and "Traceback" not in err
