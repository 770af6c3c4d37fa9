"""The jam profile (forcespace.engine.jam_profile) times the protocol's own jam: the same
trajectory as an unprofiled jam, every window and phase accounted for, the engine left as
it was."""
import numpy as np
import pytest

from forcespace.engine import compress, protocol
from forcespace.engine.jam_profile import compaction_phases, profile, scene_for, table
from forcespace.model.setup import Setup


def test_the_profiled_jam_is_the_protocols_own():
    setup = Setup.from_scene(scene_for("paper_certified", 40, 0.1, {}))
    windows, static = compress.run_window, protocol.static_network
    p = profile(setup)
    assert compress.run_window is windows and protocol.static_network is static
    log = protocol.build_packing(setup, show_progress=False).solver_log
    rows = p["windows"]
    # one row per window of the unprofiled jam, with its steps and sweeps per step
    assert [r["steps"] for r in rows] == list(log[:, 0].astype(int))
    assert np.array_equal([r["sweeps_per_step"] for r in rows], log[:, 3])
    assert p["steps"] == int(log[-1, 0]) and p["jam_end"] == "certificate"
    cpu = sum(r["cpu_s"] for r in rows)
    assert 0.0 < cpu <= p["cpu_s"] and 0.0 < p["static_cpu_s"] <= p["cpu_s"] - cpu + 1e-9
    assert p["certificates_tried"] >= 1 and np.isfinite(rows[0]["detect_s"])
    shares = table(p)
    assert len(shares) == 6 and shares[-1].startswith(f"| total ({p['steps']} steps")
    # the stages split the same windows: their steps and CPU add up to the windows'
    stages = [row.split("|") for row in compaction_phases(p)]
    assert sum(int(r[3]) for r in stages) == p["steps"]
    assert sum(float(r[4]) for r in stages) == pytest.approx(cpu, abs=0.06 * len(stages))
