"""Samplers off the seed-1 path: stalls, the plate problem, lost samples, bad options."""

import numpy as np
import pytest

from ensemble_cases import grooves, pyramid
from forcespace import config
from forcespace.cli import main
from forcespace.io.ensemble_file import read_file
from forcespace.sampling.diagnostics import read_ensemble
from forcespace.sampling import hit_and_run as har
from forcespace.sampling import relax_walk as rs
from forcespace.sampling.hit_and_run import HitAndRun
from forcespace.sampling.relax_walk import RelaxWalk
from forcespace.errors import InputError, NumericalError
from forcespace.io.packing_file import write_packing
from forcespace.model.problem import full_problem, plate_problem

THETAS, MU = [np.pi / 6, np.pi / 5], 0.3


@pytest.fixture(scope="module")
def frictional_plate_packing():
    from forcespace.engine.protocol import build_packing
    from forcespace.model.scene import load_scene
    scene = load_scene("quick")
    return build_packing(scene.with_overrides(**{"disks.n": 20, "physics.mu": 0.3}),
                         show_progress=False)


def _in_S(prob, X, tol=1e-9):
    assert max(prob.violation(x) for x in X) <= tol


def test_a_stalled_relaxation_is_finished_by_the_projection_and_counted(tmp_path):
    # a pyramid on a floor is a mechanism: after kicks Gauss-Seidel settles on a sliding
    # (non-static) solution; the walk used to abort there, losing its samples
    _, prob = pyramid(3, 0.6)
    out = tmp_path / "r.h5"
    walk = RelaxWalk(12, seed=2).compute(prob, output=out)
    res = walk.summary()
    stored = read_file(out)
    ens = stored.ensemble
    assert ens.n_samples == 12 and res["max_violation"] <= 1e-9
    _in_S(prob, ens.samples)
    projected = stored.checkpoint["projected"]
    assert np.array_equal(projected, walk.projected)
    assert res["n_projected"] == projected.size >= 1
    assert set(projected.tolist()) <= set(range(12))


def test_relax_walk_on_the_plate_problem_balances_the_plate(frictional_plate_packing, tmp_path):
    # the plate's balance row (sum of TOP fn = top_force) was in A, b but not in the
    # solver's copy, which held the plate fixed: every relaxation stalled
    p = frictional_plate_packing
    prob = plate_problem(p)
    top = np.flatnonzero(np.asarray(p.b)[prob.contacts] == -2)
    assert top.size >= 1
    res = RelaxWalk(10, seed=1).compute(prob, output=tmp_path / "plate.h5").summary()
    X = read_ensemble(tmp_path / "plate.h5").samples
    _in_S(prob, X)
    assert res["n_projected"] == 0             # relaxed by NLGS itself, not projected
    assert X[:, 2 * top].sum(axis=1) == pytest.approx(p.top_force, rel=1e-8)
    assert np.ptp(X[:, 2 * top], axis=0).max() > 1e-3 * prob.force_scale  # plate forces move


def test_finished_samples_survive_an_error_in_the_walk(tmp_path, monkeypatch):
    _, prob = grooves(THETAS, MU)
    out = tmp_path / "r.h5"
    calls = {"n": 0}
    real_kick = rs.kick

    def failing_kick(*args):
        calls["n"] += 1
        if calls["n"] == 8:
            raise NumericalError("simulated failure in sample 7")
        return real_kick(*args)

    monkeypatch.setattr(rs, "kick", failing_kick)
    with pytest.raises(NumericalError, match="simulated"):
        RelaxWalk(20, seed=4, checkpoint_every=5).compute(prob, output=out).summary()
    assert read_ensemble(out).n_samples == 7          # not 5: the two past the checkpoint are kept
    monkeypatch.setattr(rs, "kick", real_kick)
    RelaxWalk(20, seed=4, checkpoint_every=5).compute(prob, output=out).summary()   # and the walk resumes after them
    full = tmp_path / "full.h5"
    RelaxWalk(20, seed=4, checkpoint_every=5).compute(prob, output=full).summary()
    assert np.array_equal(read_ensemble(out).samples, read_ensemble(full).samples)


@pytest.mark.parametrize("kw, field", [
    (dict(n=0), "n"), (dict(n=5, tol=float("inf")), "tol"), (dict(n=5, tol=float("nan")), "tol"),
    (dict(n=5, tol=0.0), "tol"), (dict(n=5, checkpoint_every=0), "checkpoint_every")])
def test_relax_options_are_refused_before_any_work(tmp_path, kw, field):
    _, prob = grooves(THETAS, MU)
    with pytest.raises(InputError, match=field):
        RelaxWalk(**kw).compute(prob, output=tmp_path / "r.h5").summary()
    assert not (tmp_path / "r.h5").exists()


@pytest.mark.parametrize("kw, field", [
    (dict(chains=0), "chains"), (dict(thin=0, burn_in=0), "thin"), (dict(burn_in=-1), "burn_in"),
    (dict(direction="diagonal"), "direction")])
def test_hit_and_run_options_are_refused_before_any_work(tmp_path, kw, field):
    _, prob = grooves(THETAS, MU)
    with pytest.raises(InputError, match=field):
        HitAndRun(5, **kw).compute(prob, output=tmp_path / "h.h5").summary()
    assert not (tmp_path / "h.h5").exists()


def test_cli_sample_options_exit_2_with_one_line(tmp_path, capsys):
    p, _ = pyramid(3, 0.6)
    write_packing(p, tmp_path / "p.h5")
    base = ["sample", str(tmp_path / "p.h5"), "--full", "-n", "5", "-o", str(tmp_path / "e.h5"),
            "--quiet"]
    for extra in (["--sampler", "hit-and-run", "--chains", "0"],
                  ["--sampler", "hit-and-run", "--thin", "0", "--burn-in", "0"],
                  ["--sampler", "relax", "--tol", "inf"]):
        assert main(base + extra) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "must be" in err[0]
    assert not (tmp_path / "e.h5").exists()


def test_relax_on_a_problem_without_unknown_contacts_is_refused(tmp_path):
    p, _ = pyramid(3, 0.6)
    prob = full_problem(p)
    from dataclasses import replace
    empty = replace(prob, contacts=prob.contacts[:0])
    with pytest.raises(InputError, match="no unknown contact"):
        RelaxWalk(5).compute(empty, output=tmp_path / "r.h5").summary()


def test_ensemble_of_a_point_like_S_reports_no_ratio_of_round_off(tmp_path):
    def ensemble_summary(path):
        return read_ensemble(path).summary()
    _, prob = grooves(THETAS, 0.0)                  # frictionless grooves: dim S = 0
    RelaxWalk(10, seed=1).compute(prob, output=tmp_path / "r.h5").summary()
    out = ensemble_summary(tmp_path / "r.h5")
    assert out["eta"] < 1e-8                         # the solver floor
    assert out["jammed_distance_over_mean"] is None  # was a ratio of round-off (e.g. 8382)
    assert "numerically a point" in out["jammed_distance_over_mean_reason"]
    _, prob = grooves(THETAS, MU)                    # dim S = 2: a real ratio
    RelaxWalk(10, seed=1).compute(prob, output=tmp_path / "r2.h5").summary()
    out = ensemble_summary(tmp_path / "r2.h5")
    assert 0 < out["jammed_distance_over_mean"] < 10


def test_hit_and_run_keeps_finished_samples_on_an_error(tmp_path, monkeypatch):
    _, prob = grooves(THETAS, MU)
    out = tmp_path / "h.h5"
    real = har.har_steps
    calls = {"n": 0}

    def failing(*args):
        calls["n"] += 1
        if calls["n"] == 4 + 8:            # 4 burn-ins, then the 8th sample fails
            raise NumericalError("simulated failure")
        return real(*args)

    monkeypatch.setattr(har, "har_steps", failing)
    with pytest.raises(NumericalError, match="simulated"):
        HitAndRun(20, seed=3, checkpoint_every=5).compute(prob, output=out).summary()
    assert read_ensemble(out).n_samples == 7
    monkeypatch.setattr(har, "har_steps", real)
    HitAndRun(20, seed=3, checkpoint_every=5).compute(prob, output=out).summary()   # resumes from the last good state
    X = read_ensemble(out).samples
    assert X.shape[0] == 20 and max(prob.violation(x) for x in X) <= config.SAMPLE_VIOLATION


def test_a_relax_draw_interrupted_after_its_kick_resumes_to_the_straight_chain(tmp_path,
                                                                               monkeypatch):
    # the chain's stream was checkpointed as it stood after the unfinished draw's kick:
    # the resumed chain differed from the straight run from that sample on (issue 48)
    from forcespace.engine.interrupts import Interrupted
    _, prob = grooves(THETAS, MU)
    out, full = tmp_path / "r.h5", tmp_path / "full.h5"
    calls = {"n": 0}
    real_kick = rs.kick

    def interrupted_kick(*args):
        calls["n"] += 1
        x = real_kick(*args)          # the stream has moved on ...
        if calls["n"] == 8:           # ... and then Ctrl-C arrives in sample 7's relaxation
            raise Interrupted()
        return x

    monkeypatch.setattr(rs, "kick", interrupted_kick)
    with pytest.raises(Interrupted, match=f"7 samples in {out}; rerun"):
        RelaxWalk(20, seed=4, checkpoint_every=5).compute(prob, output=out)
    assert read_ensemble(out).n_samples == 7
    monkeypatch.setattr(rs, "kick", real_kick)
    RelaxWalk(20, seed=4, checkpoint_every=5).compute(prob, output=out)
    RelaxWalk(20, seed=4, checkpoint_every=5).compute(prob, output=full)
    assert np.array_equal(read_ensemble(out).samples, read_ensemble(full).samples)


def _interrupt_while_drawing(cmd, after: int):
    """Run ``cmd`` (a forcespace command line with its progress bar), send SIGINT once
    its bar shows ``after`` samples drawn; (exit code, stderr without bar lines)."""
    import re
    import signal
    import subprocess
    import sys
    proc = subprocess.Popen([sys.executable, "-c", "import sys; from forcespace.cli import "
                             f"main; sys.exit(main({cmd!r}))"], stderr=subprocess.PIPE,
                            text=True)
    seen = ""
    while not any(int(k) >= after for k in re.findall(r"relax:.*?\| *(\d+)/", seen[-200:])):
        ch = proc.stderr.read(1)
        assert ch, seen[-2000:]
        seen += ch
    proc.send_signal(signal.SIGINT)
    err = seen + proc.stderr.read()
    rc = proc.wait(timeout=120)
    lines = [ln for ln in err.replace("\r", "\n").splitlines()
             if ln.strip() and not ln.startswith("relax")]
    return rc, lines


@pytest.mark.slow
def test_ctrl_c_while_the_relax_walk_draws_exits_130_and_resumes_bit_for_bit(tmp_path):
    # Ctrl-C while the relax walk drew ended in a segmentation fault (exit 139, in
    # engine/nlgs.py solve: a SIGINT in numba's dispatch) on 6 of 7 interrupts, the
    # samples since the last append lost, the lock left; the one clean exit resumed to a
    # chain that differed from the straight run (issue 48)
    from forcespace.engine.protocol import build_packing
    from forcespace.model.scene import load_scene
    packing = build_packing(load_scene("quick").with_overrides(
        **{"disks.n": 24, "physics.mu": 0.5}), show_progress=False)
    pack = tmp_path / "p.h5"
    write_packing(packing, pack)
    out, full = tmp_path / "r.h5", tmp_path / "full.h5"
    # n well beyond the last interrupt: 600 samples take ~1.5 s, and a bar read late (a
    # loaded machine) let the draws end before the signal, which then met the run's
    # finishing ("interrupted" without the resume line; 1 of ~10 suite runs)
    args = ["sample", str(pack), "--sampler", "relax", "-n", "2000", "--seed", "3",
            "--checkpoint-every", "1000"]
    assert main(args + ["-o", str(full), "--quiet"]) == 0
    for after in (20, 200, 400):
        rc, lines = _interrupt_while_drawing(args + ["-o", str(out)], after)
        assert rc == 130 and len(lines) == 1, lines
        assert lines[0].startswith("interrupted; ") and f"samples in {out}; rerun" in lines[0]
        k = int(lines[0].split()[1])
        assert k >= after and read_ensemble(out).n_samples == k    # none lost
        assert not list(tmp_path.glob("r.h5?*"))     # no lock or temporary file left
    assert main(args + ["-o", str(out), "--quiet"]) == 0
    assert np.array_equal(read_ensemble(out).samples, read_ensemble(full).samples)


@pytest.mark.parametrize("cls, kw", [(HitAndRun, dict(thin=1, target_ess=400)),
                                     (RelaxWalk, dict(target_ess=400))])
def test_a_target_ess_run_rerun_killed_or_interrupted_resumes_to_the_straight_run(
        tmp_path, monkeypatch, cls, kw):
    # rerunning a finished --target-ess run added 4 samples each time (400 -> 404 ->
    # 408); after kill -9, SIGTERM or a retry the resumed run stopped elsewhere than the
    # straight run: the ESS checks started over at the resume instead of keeping the
    # straight run's schedule (issue 48)
    import shutil
    from forcespace.engine.interrupts import Interrupted
    from forcespace.sampling import driver
    _, prob = grooves([0.3, 0.5], 0.2)
    full = tmp_path / "full.h5"
    snaps = []
    real_append = driver.ef.append

    def append_and_keep(path, *a, **k):      # the file as a kill -9 after this append
        n = real_append(path, *a, **k)        # leaves it
        snaps.append(tmp_path / f"snap{len(snaps)}.h5")
        shutil.copyfile(path, snaps[-1])
        return n

    monkeypatch.setattr(driver.ef, "append", append_and_keep)
    straight = cls(n=100_000, seed=1, checkpoint_every=4, **kw).compute(prob, output=full)
    monkeypatch.setattr(driver.ef, "append", real_append)
    X = read_ensemble(full).samples
    n = len(X)
    assert straight.success and f"after {n} samples" in straight.message and n > 500
    for _ in range(2):                                         # rerun: nothing drawn
        again = cls(n=100_000, seed=1, **kw).compute(prob, output=full)
        assert (again.message, again.ensemble.n_samples) == (straight.message, n)
    assert np.array_equal(read_ensemble(full).samples, X)
    assert len(snaps) >= 6
    for snap in snaps[1:-1:len(snaps) // 6]:                   # killed after an append
        resumed = cls(n=100_000, seed=1, **kw).compute(prob, output=snap)
        assert resumed.message == straight.message
        assert np.array_equal(read_ensemble(snap).samples, X)
    for k in (n - 8, n):        # Ctrl-C after sample k, before its ESS check
        out = tmp_path / f"stop{k}.h5"
        check = driver.Stop.__call__

        def interrupted_at_k(stop, kk, samples, t0, k=k):
            if kk == k:
                raise Interrupted()
            return check(stop, kk, samples, t0)

        with monkeypatch.context() as m:
            m.setattr(driver.Stop, "__call__", interrupted_at_k)
            with pytest.raises(Interrupted, match=f"{k} samples in"):
                cls(n=100_000, seed=1, **kw).compute(prob, output=out)
        resumed = cls(n=100_000, seed=1, **kw).compute(prob, output=out)
        assert resumed.message == straight.message
        assert np.array_equal(read_ensemble(out).samples, X)


def test_a_ctrl_c_while_a_run_finishes_keeps_its_samples_and_says_where(tmp_path,
                                                                       monkeypatch):
    # a Ctrl-C that landed after the last draw (the run's diagnostics) said only
    # "interrupted": a bare KeyboardInterrupt, no line on where the samples are
    from forcespace.engine.interrupts import Interrupted
    from forcespace.sampling import driver
    _, prob = grooves([0.3, 0.5], 0.2)
    straight = HitAndRun(n=60, seed=1, thin=1).compute(prob, output=tmp_path / "full.h5")
    out = tmp_path / "e.h5"
    real = driver.diagnostics

    def ctrl_c(*a, **k):
        raise KeyboardInterrupt

    with monkeypatch.context() as m:
        m.setattr(driver, "diagnostics", ctrl_c)
        with pytest.raises(Interrupted, match=f"60 samples in {out}; rerun"):
            HitAndRun(n=60, seed=1, thin=1, checkpoint_every=1000).compute(prob, output=out)
    assert driver.diagnostics is real
    assert np.array_equal(read_ensemble(out).samples, straight.ensemble.samples)
    again = HitAndRun(n=60, seed=1, thin=1).compute(prob, output=out)   # finishes it
    assert (again.success, again.message) == (straight.success, straight.message)
    assert again.ensemble.diagnostics == straight.ensemble.diagnostics


@pytest.mark.parametrize("sampler", ["hit-and-run", "billiard", "relax"])
def test_every_sampler_on_a_determinate_S_gives_its_one_point(tmp_path, sampler):
    """The frictionless paper packing's slice (dim S = 0): every sample is the jammed
    network, eta = 0, in memory and through a file, from the API and the CLI (the
    billiard walk ended in "cannot reshape array of size 0" after writing its samples)."""
    import forcespace as fs
    from forcespace.sampling.billiard import BilliardWalk
    from paths import DATA
    prob = fs.slice_problem(fs.read_packing(DATA / "paper_mu0_seed2.h5"), 28.0)
    cls = {"hit-and-run": HitAndRun, "billiard": BilliardWalk, "relax": RelaxWalk}[sampler]
    for out in (None, tmp_path / "e.h5"):
        run = cls(12, seed=1).compute(prob, output=out)
        assert run.success and run.ensemble.n_samples == 12
        assert run.ensemble.eta < 1e-8
        assert np.abs(run.ensemble.samples - prob.x_jammed).max() < 1e-6 * prob.force_scale
    assert main(["sample", str(DATA / "paper_mu0_seed2.h5"), "--slice", "28", "--sampler",
                 sampler, "-n", "12", "-o", str(tmp_path / "c.h5"), "--quiet"]) == 0
    assert read_ensemble(tmp_path / "c.h5").eta < 1e-8
