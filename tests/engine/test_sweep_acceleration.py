"""The sweep-acceleration diagnostic (forcespace.engine.sweep_acceleration): its frozen contact
problems are the engine's own time steps, and the accelerated solvers keep the sweep's
fixed point (they end on the velocities plain Gauss-Seidel converges to)."""
import json

import numpy as np

from forcespace.engine.records import BodyArrays, Box, ContactForces, StepSettings, SweepSettings
from forcespace.engine.step import run_steps
from forcespace.engine import sweep_acceleration as sa


def captured(tmp_path):
    """States before the first 4 windows of a 40-disk paper_fast_compaction jam (mu 0.1)."""
    sa.capture(40, 0.1, tmp_path, windows=4)
    return sorted(sa.problem_dir(tmp_path, 40, 0.1).glob("w*.npz"))


def test_a_frozen_problem_is_the_engines_time_step(tmp_path):
    path = captured(tmp_path)[-1]
    z = np.load(path)
    meta = json.loads(str(z["meta"]))
    bodies = BodyArrays(*(z[f"body_{f}"].copy() for f in BodyArrays._fields))
    run_steps(bodies, Box(*meta["box"]), StepSettings(*meta["step"]),
              SweepSettings(*meta["sweep"]), ContactForces(z["keys"], z["rn"], z["rt"]), 1,
              meta["window_seed"])
    c, motion, rn, rt, settings, seed, moving = sa.step_problem(path)
    assert moving and settings.tol == meta["step"][4]    # the plate moves: tol_moving
    from forcespace.engine.nlgs import solve_kernel
    solve_kernel(c, motion, rn, rt, settings, seed)
    # the same velocities, bit for bit, as the engine's first step of that window
    for name in ("vx", "vy", "w"):
        assert np.array_equal(getattr(motion, name), getattr(bodies, name))


def test_the_accelerated_sweeps_keep_the_fixed_point(tmp_path):
    problem = sa.step_problem(captured(tmp_path)[-1])
    _, v_ref, _ = sa.run_method(sa.REFERENCE, problem, 100000, 1e-13)
    scale = np.linalg.norm(v_ref)
    for name in ("anderson m=5 on GS, restarts", "nncg on GS", "sor (today)"):
        st, v, _ = sa.run_method(sa.METHODS[name], problem, 100000, 1e-12)
        assert st.relative_change <= 1e-12, name
        assert np.linalg.norm(v - v_ref) <= 1e-8 * scale, name
    # a solve stopped early is measurably off: the comparison above can fail
    _, v, _ = sa.run_method(sa.METHODS["nncg on GS"], problem, 3, 0.0)
    assert np.linalg.norm(v - v_ref) > 1e-6 * scale
