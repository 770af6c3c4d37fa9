"""The jamming protocol, packing files and the physics a scene switches on."""
import numpy as np
import pytest

from forcespace.engine.protocol import build_packing, compress, make_bodies, static_solve
from forcespace.model.walls import BOTTOM, LEFT, RIGHT
from forcespace.io.packing_file import read_packing, write_packing
from forcespace.model.scene import load_scene, validate
from paths import QUICK


@pytest.fixture(scope="module")
def quick():
    return build_packing(load_scene(QUICK), show_progress=False)


def test_quick_frictionless_packing_is_jammed_isostatic_and_in_equilibrium(quick):
    s = quick.summary()
    assert s["equilibrium_residual"] <= 1e-10
    assert s["max_overlap"] <= 1e-6  # in units of R
    assert abs(s["z"] - 4.0) <= 0.1
    # isostaticity, exactly: frictionless disks with frictionless plates have 2 force
    # equations per non-rattler, one for the top plate, minus the free horizontal shift
    live = quick.force_bearing()
    rat = quick.rattlers()
    assert live.sum() == 2 * (~rat).sum()
    assert (quick.fn >= 0).all() and (quick.ft == 0).all()
    # the plate load is carried through to the bottom plate
    F = quick.contact_forces()
    assert F[quick.a == BOTTOM, 1].sum() == pytest.approx(quick.top_force, rel=1e-9)


@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_fast_sweeps_jam_to_the_same_kind_of_static_state(quick, mu):
    # runs of 8 contacts in spatial order, over-relaxed: a jammed rest state in
    # equilibrium; frictionless it is isostatic like the paper sweep's packing
    scene = load_scene(QUICK).with_overrides(**{"solver.sweep_block": 8,
                                                "solver.relaxation": 1.6, "physics.mu": mu})
    p = build_packing(scene, show_progress=False)
    s = p.summary()
    assert s["equilibrium_residual"] <= 1e-10 and s["max_overlap"] <= 1e-6
    assert (np.abs(p.ft) <= mu * p.fn * (1 + 1e-12) + 1e-300).all()
    if mu == 0:
        assert p.force_bearing().sum() == 2 * (~p.rattlers()).sum()
        assert p.n_disks == quick.n_disks and not np.array_equal(p.x, quick.x)
    else:
        assert 3.0 < s["z"] < 4.0


def test_packing_file_round_trip_is_exact_and_self_describing(quick, tmp_path):
    import h5py
    path = tmp_path / "q.h5"
    write_packing(quick, path)
    assert [p.name for p in tmp_path.iterdir()] == ["q.h5"]  # no temp file left behind
    back = read_packing(path)
    for name in ("x", "y", "r", "a", "b", "normal", "point", "image", "gap", "fn", "ft"):
        np.testing.assert_array_equal(getattr(back, name), getattr(quick, name))
    assert back.summary()["z"] == quick.summary()["z"]
    with h5py.File(path) as f:
        assert f.attrs["file_kind"] == "packing" and f.attrs["forcespace_version"]
        assert "[physics]" in f.attrs["scene_text"]
        assert list(f["forces"].attrs["columns"]) == ["fn", "ft"]
        assert f["disks"].attrs["units"] == "R"
    from forcespace.model.scene import SCHEMA
    defaults = validate({}, "x").values        # an empty scene is the schema's defaults
    assert defaults == {k: (float(v.default) if v.type is float else v.default)
                        for k, v in SCHEMA.items()}
    assert load_scene(QUICK).to_toml() == back.scene_text


def test_same_seed_same_packing_other_seed_other_packing():
    scene = load_scene(QUICK).with_overrides(**{"disks.n": 14})
    p1 = build_packing(scene, show_progress=False)
    p2 = build_packing(scene, show_progress=False)
    np.testing.assert_array_equal(p1.x, p2.x)
    np.testing.assert_array_equal(p1.fn, p2.fn)
    p3 = build_packing(scene.with_overrides(**{"scene.seed": 2}), show_progress=False)
    assert not np.array_equal(p1.r, p3.r)


def _pyramid_scene(mu=0.0, rotation="auto"):
    # two disks on the floor touching the side walls, one on top; gravity
    return validate({"disks.n": 3, "box.periodic_x": False, "box.width": 4.1,
                     "plates.top": "none", "physics.gravity": 1.0, "physics.mu": mu,
                     "physics.rotation": rotation, "disks.radius_max": 1.0,
                     "solver.dt": 0.01, "solver.tolerance": 1e-10,
                     "jamming.window": 50}, "<pyramid>")


def _pyramid(scene):
    x = np.array([1.0, 3.1, 2.05])
    y = np.array([1.0, 1.0, 3.0])
    bodies = make_bodies(scene, x, y, np.ones(3), 5.0)
    compress(scene, bodies, 1, show_progress=False)
    return static_solve(scene, bodies, 1, show_progress=False)


def test_frictionless_pyramid_forces_solve_the_linear_statics():
    packing, _ = _pyramid(_pyramid_scene())
    # unknowns: the force-bearing contacts; equations: fx, fy of each disk
    live = packing.force_bearing()
    assert live.sum() == 6  # 2 floor, 2 side walls, 2 between top and bottom disks
    Amat = np.zeros((6, 6))
    for col, k in enumerate(np.flatnonzero(live)):
        n = packing.normal[k]
        if packing.b[k] >= 0:
            Amat[2 * packing.b[k]:2 * packing.b[k] + 2, col] += n
        if packing.a[k] >= 0:
            Amat[2 * packing.a[k]:2 * packing.a[k] + 2, col] -= n
    weight = np.pi * 1.0
    rhs = np.tile([0.0, weight], 3)
    expected = np.linalg.solve(Amat, rhs)
    assert packing.fn[live] == pytest.approx(expected, rel=1e-9)
    # hand check: the floor carries all three weights, the walls the same push
    F = packing.contact_forces()
    assert F[packing.a == BOTTOM, 1].sum() == pytest.approx(3 * weight, rel=1e-9)
    # the left wall pushes disk 0 to +x as hard as disk 1 pushes the right wall to +x
    assert F[packing.a == LEFT, 0].sum() == pytest.approx(F[packing.b == RIGHT, 0].sum())
    assert F[packing.a == LEFT, 0].sum() > 0


def test_frictionless_scene_never_runs_tangential_code_and_rotation_changes_nothing():
    scene = _pyramid_scene()
    assert not scene.frictional and not scene.rotation
    p_off, st = _pyramid(scene)
    assert st["static_tangential_updates"] == 0
    scene_on = _pyramid_scene(rotation="on")
    p_on, _ = _pyramid(scene_on)
    np.testing.assert_array_equal(p_on.fn, p_off.fn)
    np.testing.assert_array_equal(p_on.x, p_off.x)
    # the counter does count when friction is on
    _, st_mu = _pyramid(_pyramid_scene(mu=0.5))
    assert st_mu["static_tangential_updates"] > 0


def test_frictionless_packing_reports_zero_tangential_updates(quick):
    assert quick.meta["tangential_updates"] == 0
    assert quick.meta["static_tangential_updates"] == 0
    assert quick.meta["rotation"] is False


def test_interrupted_compression_resumes_bit_identically(tmp_path):
    from forcespace.errors import NumericalError
    scene = load_scene(QUICK).with_overrides(**{"disks.n": 14})
    fresh = build_packing(scene, show_progress=False)
    ck = tmp_path / "p.h5.checkpoint.h5"
    with pytest.raises(NumericalError, match="resumes from"):
        build_packing(scene.with_overrides(**{"jamming.max_steps": 600}), show_progress=False,
                      checkpoint=ck)
    assert ck.exists()
    resumed = build_packing(scene, show_progress=False, checkpoint=ck)
    assert not ck.exists()
    np.testing.assert_array_equal(resumed.x, fresh.x)
    np.testing.assert_array_equal(resumed.fn, fresh.fn)
    assert resumed.meta["steps"] == fresh.meta["steps"]
    np.testing.assert_array_equal(resumed.solver_log, fresh.solver_log)


def test_checkpoint_of_another_scene_is_refused(tmp_path):
    from forcespace.errors import InputError, NumericalError
    scene = load_scene(QUICK).with_overrides(**{"disks.n": 14})
    ck = tmp_path / "c.h5"
    with pytest.raises(NumericalError):
        build_packing(scene.with_overrides(**{"jamming.max_steps": 200}), show_progress=False,
                      checkpoint=ck)
    with pytest.raises(InputError, match="another scene"):
        build_packing(scene.with_overrides(**{"physics.mu": 0.3}), show_progress=False,
                      checkpoint=ck)


@pytest.mark.parametrize("overrides", [
    # wide size ratio, strong friction, gravity-settled layer without a top plate
    {"disks.n": 16, "disks.radius_max": 4.0, "box.width": 30.0, "physics.mu": 1.0,
     "physics.gravity": 1.0, "plates.top": "none", "physics.plate_mu": 0.5},
    # the same layer with the fast sweep: omega = 1.8 oscillates in this small, strongly
    # frictional system (it crept for ever before the solver fell back to omega = 1)
    {"disks.n": 16, "disks.radius_max": 4.0, "box.width": 30.0, "physics.mu": 1.0,
     "physics.gravity": 1.0, "plates.top": "none", "physics.plate_mu": 0.5,
     "solver.sweep_block": 8, "solver.relaxation": 1.8, "jamming.max_steps": 40000},
    # closed box (side walls) with frictional walls under a heavy plate load
    {"disks.n": 16, "box.periodic_x": False, "box.width": 14.0, "physics.mu": 0.3,
     "physics.plate_mu": 0.3, "plates.top_force": 1000.0},
])
def test_hard_cases_jam_to_a_finite_static_state(overrides):
    scene = load_scene(QUICK).with_overrides(**overrides)
    p = build_packing(scene, show_progress=False)
    s = p.summary()
    assert np.isfinite(p.fn).all() and np.isfinite(p.ft).all()
    assert s["equilibrium_residual"] <= 1e-10
    assert s["max_overlap"] <= 1e-6
    assert (np.abs(p.ft) <= np.where((p.a < 0) | (p.b < 0), p.plate_mu, p.mu) * p.fn
            * (1 + 1e-12) + 1e-300).all()
