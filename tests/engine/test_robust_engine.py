"""Engine and scenes off the seed-1 path: never jammed without load, never a traceback."""
import numpy as np
import pytest
from paths import QUICK

from ensemble_cases import groove
from forcespace.cli import main
from forcespace.engine.protocol import build_packing
from forcespace.space.force_space import ForceSpace
from forcespace.model.scene import validate
from forcespace.model.problem import build_problem, full_problem
from forcespace.model.walls import BOTTOM


@pytest.mark.parametrize("kw", [
    {"disks.n": 20, "box.width": 20.0, "box.initial_packing_fraction": 0.1, "scene.seed": 1},
    {"disks.n": 20, "box.width": 20.0, "box.initial_packing_fraction": 0.05, "scene.seed": 3},
])
def test_a_plate_that_has_not_reached_the_disks_is_not_jammed(kw):
    # the rest test once saw no loaded disk in the first window and declared the loose
    # start jammed with 0 contacts
    p = build_packing(validate(kw, "loose"), show_progress=False)
    top = p.b == -2
    assert top.any() and p.fn[top].sum() == pytest.approx(p.top_force, rel=1e-9)
    live = p.force_bearing()
    rat = p.rattlers()
    assert p.equilibrium_residual() <= 1e-10
    # frictionless and isostatic: force-bearing contacts = 2 x non-rattlers
    assert live.sum() == 2 * (~rat).sum()


def test_a_loaded_disk_with_two_contacts_is_not_a_rattler():
    # frictionless disk in a groove under gravity: 2 contacts, each carrying W / (2 cos th);
    # the "< 3 contacts" rule called it a rattler and dropped its load from S
    th = np.pi / 6
    p, _ = groove(th, 0.0)
    assert not p.rattlers()[0]
    prob = build_problem(p, np.arange(3) == 0, (), "groove", support_mask=np.arange(3) > 0)
    an = ForceSpace(ranges=True).compute(prob)
    assert an.feasible and an.dim == 0
    W = p.mass[0] * p.gravity
    assert an.centre[0::2] == pytest.approx([W / (2 * np.cos(th))] * 2, rel=1e-9)
    # a disk touching others with no force at all is a rattler, whatever its contact count
    q = p.with_forces(np.zeros_like(p.fn), np.zeros_like(p.ft))
    assert q.rattlers().all()


def test_frictionless_gravity_layer_keeps_every_loaded_disk(tmp_path):
    sc = validate({"disks.n": 16, "box.width": 12.0, "box.periodic_x": False,
                   "physics.gravity": 1.0, "plates.top": "none", "solver.dt": 0.05,
                   "disks.radius_max": 1.5}, "layer")
    p = build_packing(sc, show_progress=False)
    rat = p.rattlers()
    assert not rat.any()                  # under gravity every disk bears its weight
    prob = full_problem(p)
    assert prob.n_interior == p.n_disks
    assert prob.violation(prob.x_jammed) <= 1e-8
    assert ForceSpace(ranges=False).compute(prob).feasible


def _study_layer(mu, seed, n=100):
    """A layer of n disks jammed by the bundled ``layer`` scene as the point-force study
    jams it (floor friction = mu, periodic width 42 R)."""
    from forcespace import jam
    return jam("layer", physics__mu=mu, physics__plate_mu=mu, scene__seed=seed,
               disks__n=n, box__width=42.0)


def test_a_layer_under_gravity_settles_instead_of_shearing_on_truncated_sweeps():
    # at solver.tolerance 1e-8 this 320-disk layer never came to rest: Gauss-Seidel
    # stopped each step with ~1e-6 R/T of velocity error and the whole layer sheared
    # steadily (vx growing with height) for 4e5 steps (NumericalError after ~50 CPU s);
    # the bundled scene solves to 1e-10 and it settles (~18 CPU s)
    p = _study_layer(0.3, 2, n=320)
    assert p.equilibrium_residual() <= 1e-10
    assert not p.rattlers().any()                 # every disk bears its weight


def test_a_lone_disk_rolling_on_the_floor_does_not_hold_up_rest():
    # one disk of this layer ends alone on the floor, rolling at 1.5e-5 R/T (no rolling
    # resistance: it never stops); it used to keep the jam from ending for 4e5 steps
    p = _study_layer(0.3, 9)
    live = p.force_bearing()
    ends = np.concatenate([p.a[live], p.b[live]])
    alone_on_floor = [k for k in range(p.n_disks)
                      if (ends == k).sum() == 1 and (p.b[live & (p.a == BOTTOM)] == k).any()]
    assert alone_on_floor                         # the case this test is about is here
    assert p.equilibrium_residual() <= 1e-10


def test_a_push_of_zero_force_leaves_a_settled_layer_where_it_was():
    # the point-force study's control run: the dynamics restart from the settled layer
    # with its own contact forces. Started cold (zero forces) Gauss-Seidel rebuilt the
    # network over many steps and this layer sagged 0.035 R meanwhile (a 320-disk layer
    # at mu = 1: 309 disks slipped > 0.1 R, up to 2.8 R)
    from forcespace.engine.push import push
    from forcespace.measures import surface_disk
    p = _study_layer(1.0, 2, n=40)
    control = push(p, surface_disk(p), 0.0)
    assert control.at_rest and control.stats["steps"] == 200      # one window: at rest
    assert control.displacement.max() < 1e-6
    assert control.stats["steps_at_sweep_cap"] == 0


def test_rerun_after_max_steps_reports_again_instead_of_crashing(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text("[disks]\nn = 20\n[box]\nwidth = 20.0\n[jamming]\nmax_steps = 200\n")
    out = tmp_path / "p.h5"
    for _ in range(2):      # the second run resumes from the checkpoint at max_steps
        assert main(["pack", str(scene), "-o", str(out), "--quiet"]) == 3
        err = capsys.readouterr().err
        assert "not jammed after jamming.max_steps = 200" in err and "Traceback" not in err
    assert not out.exists()


@pytest.mark.parametrize("text, field, allowed", [
    (b"\x88\x00\xff binary", "(file)", "not a UTF-8 text file"),
])
def test_binary_scene_is_one_clear_error(tmp_path, capsys, text, field, allowed):
    scene = tmp_path / "s.toml"
    scene.write_bytes(text)
    assert main(["pack", str(scene), "-o", str(tmp_path / "p.h5")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and field in err[0] and allowed in err[0] and str(scene) in err[0]


@pytest.mark.parametrize("args, field", [
    (["--seed", str(2**70)], "scene.seed"), (["--n", str(10**12)], "disks.n"),
])
def test_absurd_overrides_are_refused_before_any_work(tmp_path, capsys, args, field):
    quick = QUICK
    assert main(["pack", str(quick), "-o", str(tmp_path / "p.h5"), *args]) == 2
    err = capsys.readouterr().err
    assert field in err and "must be an integer in" in err


@pytest.mark.parametrize("section, line, field", [
    ("disks", "radius_max = 1e300", "disks.radius_max"),
    ("solver", "dt = 1e7", "solver.dt"),
    ("physics", "mu = nan", "physics.mu"),
    ("solver", "relaxation = 2.0", "solver.relaxation"),   # SOR diverges from omega = 2 on
    ("solver", "sweep_block = -1", "solver.sweep_block"),
])
def test_overflowing_scene_values_are_refused(tmp_path, capsys, section, line, field):
    scene = tmp_path / "s.toml"
    scene.write_text(f"[{section}]\n{line}\n")
    assert main(["pack", str(scene), "-o", str(tmp_path / "p.h5")]) == 2
    assert field in capsys.readouterr().err


def test_a_time_step_far_too_large_is_refused_or_a_clear_non_convergence(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    # under a plate: refused before any work (the plate would jump the contact margin)
    scene.write_text("[disks]\nn = 20\n[box]\nwidth = 20.0\n[solver]\ndt = 1e6\n")
    assert main(["pack", str(scene), "-o", str(tmp_path / "p.h5"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "solver.dt" in err and "plates.top_mass" in err and "Traceback" not in err
    # under gravity alone: the disks fall through the floor, a clear non-convergence
    scene.write_text("[disks]\nn = 20\n[box]\nwidth = 20.0\n[solver]\ndt = 1e6\n"
                     "[physics]\ngravity = 1.0\n[plates]\ntop = \"none\"\n")
    assert main(["pack", str(scene), "-o", str(tmp_path / "p.h5"), "--quiet"]) == 3
    err = capsys.readouterr().err
    assert "solver.dt" in err and "reduce" in err and "Traceback" not in err


def test_a_radius_ratio_20_jam_shows_its_progress_and_ends_with_a_diagnosis(capsys):
    # issue 21: a radius-ratio-1:20 scene gave no answer and no diagnosis within 90 s
    # (its slow jam took minutes, the bar counted to the step cap and stopped refreshing)
    from forcespace.errors import NumericalError
    sc = validate({"disks.n": 100, "disks.radius_max": 20.0, "box.width": 200.0,
                   "physics.mu": 0.1, "solver.dt": 0.05, "jamming.max_steps": 2000},
                  "ratio20")
    with pytest.raises(NumericalError) as err:
        build_packing(sc, show_progress=True)
    msg = str(err.value)
    assert "not jammed after jamming.max_steps = 2000" in msg and "tolerance" in msg
    shown = capsys.readouterr().err
    assert "/2000 steps, v_mean/v_tol" in shown        # the bar measures the jam itself
