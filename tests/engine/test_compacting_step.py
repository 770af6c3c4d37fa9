"""solver.dt_compacting (issue 42): a window steps by the larger dt while the packing
compacts (the first window, and after a window faster than solver.compacting_speed), by
solver.dt otherwise; the plumbing changes nothing else."""
import numpy as np
import pytest

from forcespace import jam, load_scene
from forcespace.engine.compress import Run, window_settings
from forcespace.engine.records import SweepSettings
from forcespace.errors import InputError
from forcespace.model.setup import Setup


def tiny(name="paper_certified", **over):
    scene, _ = load_scene(name).scaled_to(40)
    return scene.with_overrides(**{"physics.mu": 0.1, "scene.seed": 2, **over})


def test_a_compacting_dt_equal_to_dt_is_the_same_jam():
    base = tiny()
    same = tiny(**{"solver.dt_compacting": base["solver.dt"], "solver.compacting_speed": 0.03})
    p, q = jam(base), jam(same)
    assert p.meta["steps"] == q.meta["steps"]
    for k in ("x", "y", "fn", "ft"):
        assert np.array_equal(getattr(p, k), getattr(q, k)), k


def test_the_window_after_a_fast_window_steps_by_the_compacting_dt():
    sweep = SweepSettings(dt=0.1, tol=1e-6, max_sweeps=300, relaxation=1.8, block=64,
                          overlap_correction=0.2, overlap_slop=2e-7, relax_until=-1)
    settings = ("box", "step", sweep)
    fast = (sweep._replace(dt=0.2), 0.5)
    run = Run()
    assert window_settings(settings, fast, run)[2].dt == 0.2          # the first window
    run.log.append((200, 0.6, 1.0, 50.0, 1e-5))
    assert window_settings(settings, fast, run)[2].dt == 0.2          # after a fast one
    run.log.append((400, 0.5, 1.0, 50.0, 1e-5))
    assert window_settings(settings, fast, run) is settings           # at the speed: dt
    run.log.append((600, float("nan"), 1.0, 50.0, 1e-5))
    assert window_settings(settings, fast, run) is settings
    assert window_settings(settings, None, Run()) is settings         # key unset


def test_the_compacting_protocol_scales_and_is_checked():
    sc = load_scene("paper_fast_compaction")
    big, _ = sc.scaled_to(800)
    assert big["solver.dt_compacting"] / big["solver.dt"] == pytest.approx(2.0)
    assert (big["solver.compacting_speed"] / big["jamming.velocity_tol"]
            == pytest.approx(sc["solver.compacting_speed"] / sc["jamming.velocity_tol"]))
    # the plate's free step uses the larger dt: refused before any work
    bad = sc.with_overrides(**{"solver.dt_compacting": 2.0, "disks.n": 20})
    with pytest.raises(InputError, match="plates.top_mass"):
        jam(bad)
    setup = Setup.from_scene(tiny("paper_fast_compaction"))
    assert setup.solver.dt_compacting == pytest.approx(2 * setup.solver.dt)
    # a scene that does not set the keys keeps its text (packing files, checkpoint identity)
    assert "compacting" not in load_scene("paper_certified").to_toml()
    assert "dt_compacting = 0.2" in sc.to_toml()
