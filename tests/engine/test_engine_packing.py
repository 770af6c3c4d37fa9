"""The jamming protocol, packing files and the physics a scene switches on."""
import numpy as np
import pytest

from forcespace import config

from forcespace.engine.protocol import build_packing, compress, make_bodies, static_solve
from forcespace.model.walls import BOTTOM, LEFT, RIGHT
from forcespace.io.packing_file import read_packing, write_packing
from forcespace.model.scene import load_scene, validate
from forcespace.model.setup import Setup
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
    setup = Setup.from_scene(scene)
    bodies = make_bodies(setup, x, y, np.ones(3), 5.0)
    compress(setup, bodies, 1, show_progress=False)
    return static_solve(setup, bodies, 1, show_progress=False)


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


def jam_and_interrupt(tmp_path):
    """A 14-disk quick jam straight through, and the same jam stopped after 600 steps
    (NumericalError) leaving its checkpoint: (scene, fresh packing, checkpoint path)."""
    from forcespace.errors import NumericalError
    scene = load_scene(QUICK).with_overrides(**{"disks.n": 14})
    fresh = build_packing(scene, show_progress=False)
    ck = tmp_path / "p.h5.checkpoint.h5"
    with pytest.raises(NumericalError, match="resumes from"):
        build_packing(scene.with_overrides(**{"jamming.max_steps": 600}), show_progress=False,
                      checkpoint=ck)
    return scene, fresh, ck


def test_interrupted_compression_resumes_bit_identically(tmp_path):
    scene, fresh, ck = jam_and_interrupt(tmp_path)
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


def test_checkpoint_written_before_a_scene_key_was_added_resumes(tmp_path):
    """A checkpoint whose scene text lacks a key added to the language since (written by
    an older version; here solver.contact_margin, at its default, stands for such a key)
    still resumes, bit for bit; a real difference is still refused (test above). Keys
    marked quiet_default (the compaction step's) are not even written at their default."""
    import h5py

    scene, fresh, ck = jam_and_interrupt(tmp_path)
    with h5py.File(ck, "r+") as f:
        text = f.attrs["scene"]
        assert "dt_compacting" not in text and "compacting_speed" not in text
        older = "\n".join(ln for ln in text.split("\n") if not ln.startswith("contact_margin"))
        assert older != text
        f.attrs["scene"] = older
    resumed = build_packing(scene, show_progress=False, checkpoint=ck)
    np.testing.assert_array_equal(resumed.x, fresh.x)
    np.testing.assert_array_equal(resumed.fn, fresh.fn)
    assert resumed.meta["steps"] == fresh.meta["steps"]


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


class _InterruptAfter:
    """An interrupt flag that turns on after ``calls`` checks of ``requested``."""

    def __init__(self, calls):
        self.calls = calls

    @property
    def requested(self):
        self.calls -= 1
        return self.calls < 0

    def check(self, message=""):
        from forcespace.engine.interrupts import Interrupted
        if self.requested:
            raise Interrupted(message)


def test_an_interrupt_saves_a_checkpoint_the_next_run_resumes_bit_identically(tmp_path):
    from forcespace.engine import compress as compress_module
    from forcespace.engine.interrupts import Interrupted
    from forcespace.engine.protocol import start_bodies
    scene = load_scene(QUICK).with_overrides(**{"disks.n": 14})
    fresh = build_packing(scene, show_progress=False)
    ck = tmp_path / "p.h5.checkpoint.h5"
    setup = Setup.from_scene(scene)
    bodies = start_bodies(setup)
    with pytest.raises(Interrupted, match="resumes from"):
        compress_module.compress(setup, bodies, setup.seed, show_progress=False,
                                 checkpoint=ck, interrupt=_InterruptAfter(8))
    assert ck.exists()
    resumed = build_packing(scene, show_progress=False, checkpoint=ck)
    assert not ck.exists()
    np.testing.assert_array_equal(resumed.x, fresh.x)
    np.testing.assert_array_equal(resumed.fn, fresh.fn)
    np.testing.assert_array_equal(resumed.ft, fresh.ft)
    assert resumed.meta["steps"] == fresh.meta["steps"]
    assert resumed.meta["sweeps_total"] == fresh.meta["sweeps_total"]


def test_a_jammed_checkpoint_resumes_at_the_static_solve(tmp_path):
    from forcespace.engine import compress as compress_module
    from forcespace.engine.protocol import start_bodies
    from forcespace.io.checkpoint import read_checkpoint
    scene = load_scene(QUICK).with_overrides(**{"disks.n": 14})
    fresh = build_packing(scene, show_progress=False)
    ck = tmp_path / "c.h5"
    setup = Setup.from_scene(scene)
    compress_module.compress(setup, start_bodies(setup), setup.seed,
                             show_progress=False, checkpoint=ck)
    state = read_checkpoint(ck, setup.identity)
    assert state["phase"] == "jammed" and state["steps"] == fresh.meta["steps"]
    resumed = build_packing(scene, show_progress=False, checkpoint=ck)
    np.testing.assert_array_equal(resumed.fn, fresh.fn)
    assert not ck.exists()


def test_a_failed_static_solve_sends_the_packing_back_to_compress(monkeypatch):
    # a configuration that only looked at rest (the static solve ends above tolerance)
    # is compressed further, the rest test suspended for UNSETTLE_WINDOWS windows, and
    # solved again; the result is a true static packing, the retry counted
    from forcespace.engine import protocol
    scene = load_scene(QUICK).with_overrides(**{"disks.n": 14})
    fresh = build_packing(scene, show_progress=False)
    assert fresh.meta["static_retries"] == 0
    real, residuals = protocol.static_solve, []

    def fails_once(*args, **kw):
        packing, stats = real(*args, **kw)
        residuals.append(stats["static_residual"])
        return packing, (dict(stats, static_residual=1.0) if len(residuals) == 1 else stats)

    monkeypatch.setattr(protocol, "static_solve", fails_once)
    p = build_packing(scene, show_progress=False)
    assert len(residuals) == 2 and p.meta["static_retries"] == 1
    window = scene["jamming.window"]
    assert p.meta["steps"] >= fresh.meta["steps"] + config.UNSETTLE_WINDOWS * window
    assert p.meta["steps"] == len(p.solver_log) * window     # one log row per window
    assert p.equilibrium_residual() <= scene["jamming.static_tolerance"]


def test_a_static_solve_that_keeps_failing_is_refused_after_the_retries():
    from forcespace.config import STATIC_RETRIES
    from forcespace.errors import NumericalError
    scene = load_scene(QUICK).with_overrides(**{"disks.n": 14,     # nothing meets it
                                                "jamming.static_tolerance": 1e-300,
                                                "jamming.static_max_sweeps": 1000})
    with pytest.raises(NumericalError, match=f"also after {STATIC_RETRIES} further "
                                             "compressions"):
        build_packing(scene, show_progress=False)


def reports_a_stall(real):
    """``real`` (a static solve) with its residual reported as 1: a stall."""
    def stalls(*args, **kw):
        packing, stats = real(*args, **kw)
        return packing, dict(stats, static_residual=1.0)
    return stalls


def test_a_resumed_jam_keeps_its_static_retries_and_its_earlier_time(tmp_path, monkeypatch):
    # size study, n = 5000, mu = 1, seed 4 was jammed across two sessions: the resumed
    # run started its retry count afresh (it could have had 3 more) and its recorded time
    # was the last session's only. A checkpoint now carries both: here one that has used
    # 2 of the 3 retries and 100 s of compression, with every static solve stalling, gets
    # exactly one more retry before the exact-point restart, and counts the 100 s
    from forcespace.engine import compress as compress_module, protocol
    from forcespace.engine.protocol import start_bodies
    from forcespace.io.checkpoint import read_checkpoint, write_checkpoint
    scene = load_scene(QUICK).with_overrides(**{"disks.n": 14, "physics.mu": 1.0})
    ck = tmp_path / "c.h5"
    setup = Setup.from_scene(scene)
    compress_module.compress(setup, start_bodies(setup), setup.seed,
                             show_progress=False, checkpoint=ck)
    ident = setup.identity
    state = read_checkpoint(ck, ident)
    assert state["retries"] == 0 and 0 < state["seconds"] < 100
    write_checkpoint(ck, ident, dict(state, retries=2, seconds=100.0))
    solves = []

    def stalls(*args, **kw):
        solves.append(1)
        return reports_a_stall(real)(*args, **kw)
    real = protocol.static_solve
    monkeypatch.setattr(protocol, "static_solve", stalls)
    p = build_packing(scene, show_progress=False, checkpoint=ck)
    assert len(solves) == 2                       # the stalled one and one retry
    assert p.meta["static_retries"] == config.STATIC_RETRIES
    assert p.meta["static_restart"] == "exact point"
    assert p.meta["compress_seconds"] >= 100 and p.meta["wall_seconds"] >= 100


def test_a_static_solve_that_stalls_restarts_from_an_exact_point_of_S(monkeypatch):
    # NLGS from the dynamics' forces can stall on a configuration that is static (seen
    # at mu = 1, n = 800): after the retries the configuration's certificate (interior
    # point) gives a static network and NLGS restarts from it. Here the protocol's own
    # solves always report a stall; the restart (the engine's real solve) starts from the
    # certificate's network (one solve, recorded) and the result is an exact static packing
    from forcespace.engine import protocol, static
    from forcespace.model.problem import plate_problem
    scene = load_scene(QUICK).with_overrides(**{"disks.n": 14, "physics.mu": 1.0})
    real, solver = protocol.static_solve, static.least_change_network
    points = []

    def network(*args, **kw):
        points.append(solver(*args, **kw))
        return points[-1]

    monkeypatch.setattr(protocol, "static_solve", reports_a_stall(real))
    monkeypatch.setattr(static, "least_change_network", network)
    p = build_packing(scene, show_progress=False)
    assert len(points) == 1 and points[0].status == "static"    # one solve, S not empty
    assert p.meta["static_retries"] == config.STATIC_RETRIES
    assert p.meta["static_restart"] == "exact point"
    assert p.meta["static_residual"] <= scene["jamming.static_tolerance"]
    assert p.equilibrium_residual() <= scene["jamming.static_tolerance"]
    prob = plate_problem(p)                     # a point of S: equilibrium and Coulomb
    assert prob.violation(prob.forces_from_packing(p.fn, p.ft)) < 1e-9


def test_a_configuration_without_a_static_network_is_refused_after_the_restart(monkeypatch):
    from forcespace.engine import protocol, static
    from forcespace.engine.certificate import Certificate
    from forcespace.errors import NumericalError
    scene = load_scene(QUICK).with_overrides(**{"disks.n": 14})
    real = protocol.static_solve

    monkeypatch.setattr(protocol, "static_solve", reports_a_stall(real))
    monkeypatch.setattr(static, "least_change_network",
                        lambda *a, **k: Certificate("not static", None, None, np.inf, 5, 0.0))
    with pytest.raises(NumericalError, match="finds no static network"):
        build_packing(scene, show_progress=False)


def test_the_suspended_rest_test_survives_a_checkpoint(tmp_path):
    import h5py
    from forcespace.engine import compress as C
    from forcespace.engine.protocol import start_bodies
    from forcespace.io.checkpoint import write_checkpoint
    scene = load_scene(QUICK).with_overrides(**{"disks.n": 14})
    setup = Setup.from_scene(scene)
    bodies = start_bodies(setup)
    run = C.Run(steps=400, phase="jammed")
    C.unsettle(setup, run, 10)
    assert run.phase == "compressing" and run.rest_after == 400 + 10 * scene["jamming.window"]
    ck = tmp_path / "c.h5"
    write_checkpoint(ck, setup.identity, C.snapshot(bodies, run))
    back = C.start_run(setup, start_bodies(setup), ck)
    assert (back.phase, back.steps, back.rest_after) == ("compressing", 400, run.rest_after)
    with h5py.File(ck, "a") as f:                  # written before the field existed
        del f.attrs["rest_after"]
    assert C.start_run(setup, start_bodies(setup), ck).rest_after == 0


@pytest.mark.parametrize("content", [b"garbage, not HDF5", b""])
def test_a_garbage_checkpoint_is_one_line_naming_the_file(tmp_path, capsys, content):
    from forcespace.cli import main
    scene = tmp_path / "s.toml"
    scene.write_text("[disks]\nn = 12\n[box]\nwidth = 20.0\n")
    out = tmp_path / "p.h5"
    ck = tmp_path / "p.h5.checkpoint.h5"
    ck.write_bytes(content)
    assert main(["pack", str(scene), "-o", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(ck) in err[0] and "Traceback" not in err[0]
    assert not out.exists()


def test_a_foreign_hdf5_file_as_checkpoint_is_refused(tmp_path):
    from forcespace.errors import InputError
    scene = load_scene(QUICK).with_overrides(**{"disks.n": 12})
    p = build_packing(scene.with_overrides(**{"disks.n": 10}), show_progress=False)
    ck = tmp_path / "c.h5"
    write_packing(p, ck)                  # a packing file is not a checkpoint
    with pytest.raises(InputError, match="file_kind"):
        build_packing(scene, show_progress=False, checkpoint=ck)


def test_sigint_during_pack_exits_130_with_one_line_and_a_checkpoint(tmp_path):
    import signal
    import subprocess
    import sys
    import time
    scene = tmp_path / "s.toml"     # never at rest: the run goes on until interrupted
    scene.write_text("[disks]\nn = 30\n[box]\nwidth = 20.0\n[jamming]\nvelocity_tol = 1e-30\n")
    out = tmp_path / "p.h5"
    proc = subprocess.Popen([sys.executable, "-c", "import sys; from forcespace.cli import "
                             f"main; sys.exit(main(['pack', {str(scene)!r}, '-o', "
                             f"{str(out)!r}]))"], stderr=subprocess.PIPE, text=True)
    seen = ""
    while "compressing" not in seen:                # the compression has started
        seen += proc.stderr.read(1)
        assert proc.poll() is None, seen
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    err = seen + proc.stderr.read()
    assert proc.wait(timeout=60) == 130
    lines = [ln for ln in err.replace("\r", "\n").splitlines() if ln.strip()
             and not ln.startswith(("compressing", "forcespace: compiling"))]
    assert len(lines) == 1 and lines[0].startswith("interrupted"), err[-2000:]
    ck = tmp_path / "p.h5.checkpoint.h5"
    assert "resumes from" in lines[0] and str(ck) in lines[0]
    assert ck.exists() and not out.exists()


def test_a_plate_too_light_for_the_step_is_refused_before_any_work(tmp_path, capsys):
    # top_mass = 1e-6: the plate overruns the contact margin between steps and the
    # packing kept overlaps of 4.5e-3 R (22 000 x the slop) with exit 0
    from forcespace.cli import main
    scene = tmp_path / "s.toml"
    scene.write_text(QUICK.read_text().replace("top_mass = 10.0", "top_mass = 1e-6"))
    assert "top_mass = 1e-6" in scene.read_text()
    assert main(["pack", str(scene), "-o", str(tmp_path / "p.h5"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "plates.top_mass" in err[0] and str(scene) in err[0]
    # dt^2 / top_mass: the bound sits at the contact margin (0.05^2 / 0.1 = 0.025)
    ok = load_scene(QUICK).with_overrides(**{"plates.top_mass": 0.026, "disks.n": 12})
    from forcespace.engine.bodies import check_setup
    check_setup(Setup.from_scene(ok))
    with pytest.raises(Exception, match="plates.top_mass"):
        check_setup(Setup.from_scene(ok.with_overrides(**{"plates.top_mass": 0.024})))


def test_a_packing_that_keeps_overlaps_above_the_bound_is_a_non_convergence(quick):
    from forcespace.engine.protocol import check_overlap
    from forcespace.errors import NumericalError
    scene = load_scene(QUICK)
    check_overlap(Setup.from_scene(scene), quick)    # 1.9e-7 R: within the default 1e-4 R
    worst = quick.max_overlap()
    assert 0 < worst < scene["jamming.max_overlap"]
    tight = scene.with_overrides(**{"jamming.max_overlap": 0.5 * worst})
    with pytest.raises(NumericalError, match="overlap of"):
        check_overlap(Setup.from_scene(tight), quick)


def test_the_jam_progress_is_the_log_of_the_mean_speed_against_its_tolerance():
    # issue 25: the bar counted to the 400 000-step cap (a 21-hour ETA for a 6 400-step
    # jam); it now measures log(v_ref / v_mean) / log(v_ref / v_tol)
    from forcespace.engine.compress import JamProgress, Run
    run = Run(v_ref=1.0)
    bar = JamProgress(1e-6, False, run, 400_000)
    for steps, v, want in ((200, 1.0, 0.0), (400, 1e-3, 50.0), (600, 1e-2, 50.0),
                           (800, 1e-5, 5 / 6 * 100), (1000, 1e-7, 100.0)):
        run.steps = steps
        run.log.append((steps, v, v, 10.0, 1e-7))
        bar.update(run)
        assert bar.done == pytest.approx(want)     # never moves back (v = 1e-2 after 1e-3)
    bar.close()
