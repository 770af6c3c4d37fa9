"""LIGGGHTS in 3-D with the real binary: a small engine sphere packing exported as a deck
(periodic x and y, plates as walls, the top one load-controlled), run, read back as a
sphere packing, and measured on the rigid geometry."""
import shutil

import numpy as np
import pytest

from forcespace.cli import main
from forcespace.errors import InputError
from forcespace_adapters import compare, export, import_run, make_problem, run
from paths import DATA

pytestmark = pytest.mark.skipif(shutil.which("liggghts") is None,
                                reason="LIGGGHTS binary missing (apt-get install liggghts)")


@pytest.fixture(scope="module")
def packing():
    from forcespace import jam
    return jam("quick3d", disks__n=24, physics__mu=0.3, scene__seed=2)


@pytest.fixture(scope="module")
def soft(packing, tmp_path_factory):
    d = tmp_path_factory.mktemp("deck3") / "deck"
    export("liggghts", packing, d, kn=1e4, tolerance=1e-5, max_steps=400_000)
    status = run("liggghts", d, timeout=600)
    return status, import_run("liggghts", d), d


@pytest.mark.slow     # one LIGGGHTS run of 24 spheres (~10 CPU s)
def test_the_deck_is_three_dimensional_and_periodic_in_x_and_y(packing, soft):
    _, _, d = soft
    script = (d / "in.liggghts").read_text()
    assert "boundary p p f" in script
    assert "dimension 2" not in script and "enforce2d" not in script
    assert "zplane" in script and "axis 0.0 0.0 -1.0" in script
    exported = packing.n_spheres - int(packing.rattlers().sum())
    assert f"{exported} atoms" in (d / "data.lmp").read_text()


@pytest.mark.slow     # one LIGGGHTS run of 24 spheres (~10 CPU s)
def test_the_soft_network_comes_back_as_spheres_in_equilibrium(packing, soft):
    status, net, _ = soft
    assert status["converged"]
    assert net.dim == 3 and net.n_spheres == packing.n_spheres
    # LIGGGHTS' own residual (velocities zeroed) meets its tolerance
    assert net.meta["max_residual_force"] <= net.meta["tolerance_abs"]
    # on its own geometry the network balances to the overlaps' lever arms, and LIGGGHTS
    # caps every tangential spring at its Coulomb limit
    scale = max(net.max_overlap() / net.r.min(), 1e-5)
    assert net.equilibrium_residual() <= 10 * scale
    assert net.coulomb_violation() <= 1e-9
    top = net.b == -2
    assert net.fn[top].sum() == pytest.approx(packing.top_force, rel=1e-4)


@pytest.mark.slow     # one LIGGGHTS run of 24 spheres (~10 CPU s)
def test_measured_on_the_rigid_geometry(packing, soft):
    _, net, _ = soft
    report = compare(packing, net, make_problem(packing))
    assert report["projection_method"] == "clarabel socp"
    for key in ("relative_distance", "rigid_equilibrium_residual", "coulomb_violation"):
        assert np.isfinite(report[key]) and report[key] >= 0
    # the rigid network itself is admissible: zero on both measures
    rigid = compare(packing, packing, make_problem(packing))
    assert rigid["rigid_equilibrium_residual"] <= 1e-9
    assert rigid["coulomb_violation"] <= 1e-12 and rigid["relative_distance"] <= 1e-8


def test_pymunk_refuses_a_sphere_packing_in_one_line(tmp_path, capsys):
    with pytest.raises(InputError, match="pymunk is a 2-D"):
        export("pymunk", DATA / "quick3d_mu0.3.h5", tmp_path / "p")
    assert main(["export", "pymunk", str(DATA / "quick3d_mu0.3.h5"), "-o",
                 str(tmp_path / "q")]) == 2
    err = capsys.readouterr().err
    assert "2-D" in err and "Traceback" not in err
