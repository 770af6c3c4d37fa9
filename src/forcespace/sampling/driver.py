"""The one sampling driver: set-up or resume, draw, buffer, checkpoint, stop.

Every sampler is a *walk* (:class:`~forcespace.sampling.hit_and_run.HitAndRunFrameWalk`
and :class:`~forcespace.sampling.billiard.BilliardFrameWalk`, both on the template
:class:`~forcespace.sampling.frame.FrameWalk`;
:class:`~forcespace.sampling.relax_walk.KickRelaxWalk`) with five parts:

* ``sampler`` (its name in files) and ``params`` (the parameters a file records
  and is fingerprinted with), ``tolerance_description`` (one line for the file);
* ``set_up()``: the work before the first sample (frame, rounding, burn-in; or the
  relaxed start), returning what a file keeps: (setup arrays, their
  (unit, description), checkpoint arrays, checkpoint attrs);
* ``resume(ensemble_file)``: continue from a file's set-up and checkpoint instead;
* ``draw(i)``: the i-th sample: (x (2m,) [F0], chain, violation / <Fn>);
* ``state(n_total)``: the checkpoint (arrays, attrs) after the last accepted sample
  (random streams included: a draw that fails or is interrupted leaves no trace in it).

While drawing, Ctrl-C only sets ``walk.interrupt`` (an
:class:`~forcespace.engine.interrupts.InterruptFlag`; a SIGINT inside a numba kernel's
dispatch can crash the process): it is honoured after the draw, or earlier where a walk
checks the flag (the relax walk, between chunks of Gauss-Seidel sweeps); the samples
drawn are appended, and the run stops with
:class:`~forcespace.engine.interrupts.Interrupted` saying how to resume.

:func:`run_walk` drives a walk to ``n`` samples in memory, or, given ``output``,
into a resumable ensemble file (locked while written; samples appended at growing
intervals, at most ``CHECKPOINT_SECONDS`` of work at risk). Files are read once at
the start (resume) and written as the run goes; nothing is read back.
"""
from __future__ import annotations

import time

import numpy as np

from .. import config
from ..engine.interrupts import Interrupted, deferred_sigint
from ..errors import InputError, require_int
from ..io import ensemble_file as ef
from ..io.jsonfile import dumps
from ..io.outputs import check_output_file, output_lock
from ..model.problem import checked_problem
from ..model.sphere_problem import SphereStaticsProblem
from ..progress import progress as progress_bar
from ..result import Computed
from .diagnostics import by_chain, converged, diagnostics, summarize, tracked_statistics
from ..model.ensemble import Ensemble

CHECKPOINT_SECONDS = 60.0


def flush_due(n_buffered: int, n_written: int, every: int, since_last: float) -> bool:
    """Whether buffered samples should be appended to the file now.

    Every append rewrites the file (atomically, through a temporary copy), so
    the interval grows with the file: at least ``every`` samples and at least
    a tenth of those already written (total I/O linear in the final size, not
    quadratic), but never more than CHECKPOINT_SECONDS of work at risk.
    """
    if n_buffered == 0:
        return False
    return n_buffered >= max(every, n_written // 10) or since_last >= CHECKPOINT_SECONDS


def _verify_stored(ensemble: Ensemble, problem, path) -> None:
    """InputError naming the first stored sample that is not in S (within the larger of
    its recorded violation and ``config.SAMPLE_VIOLATION``, plus round-off)."""
    for k, (x, v) in enumerate(zip(ensemble.samples, ensemble.violations)):
        now = problem.violation(x)
        allowed = max(float(v), config.SAMPLE_VIOLATION) * (1 + config.STORED_SAMPLE_SLACK)
        if not now <= allowed + 1e-15:
            raise InputError(path, f"samples[{k}]", f"is not in S of this problem (violation "
                             f"{now:.3g} <Fn>, recorded {float(v):.3g}): the file was "
                             "changed; delete it to sample again")


class _Sink:
    """Buffers samples and appends them to the ensemble file when due."""

    def __init__(self, path, n_written: int, every: int, walk):
        self.path, self.n_written, self.every, self.walk = path, n_written, every, walk
        self.last = time.perf_counter()
        self.buffer = []      # not yet in the file
        self.drawn = []       # every sample of this run, in order

    def add(self, x, chain, violation) -> None:
        self.buffer.append((x, chain, violation))
        self.drawn.append((x, chain, violation))
        if self.path is not None and flush_due(len(self.buffer), self.n_written, self.every,
                                               time.perf_counter() - self.last):
            self.flush()

    def flush(self, diagnostics_json: str | None = None) -> None:
        """Append the buffered samples (and the diagnostics, if given) to the file."""
        if self.path is not None and (self.buffer or diagnostics_json is not None):
            n_total = self.n_written + len(self.buffer)
            arrays, attrs = self.walk.state(n_total)
            X = np.array([b[0] for b in self.buffer], float)
            chains = np.array([b[1] for b in self.buffer], np.int64)
            viol = np.array([b[2] for b in self.buffer], float)
            self.n_written = ef.append(self.path, X, chains, viol, arrays, attrs,
                                       diagnostics_json)
            self.buffer = []
        self.last = time.perf_counter()


def check_target(target_ess, source="sample") -> None:
    """InputError unless target_ess is None or a finite number >= 4 (an ESS needs chains
    of at least 4 draws)."""
    if target_ess is not None and not (isinstance(target_ess, (int, float))
                                       and not isinstance(target_ess, bool)
                                       and np.isfinite(target_ess) and target_ess >= 4):
        raise InputError(source, "target_ess", "must be a number >= 4 (effective samples) "
                         "or None", got=target_ess)


class Stop:
    """When a run stops: ``n`` samples, or earlier at ``max_seconds`` since the start
    (status 1), or, with ``target_ess``, as soon as every tracked statistic of the
    samples has bulk and tail ESS >= target_ess and R-hat <= ``config.RHAT_MAX``
    (status 0; reaching n without it is status 1). ESS is checked after every
    ``chains`` samples once their number has grown by a quarter since the last check,
    from ``min_draws`` draws per chain on (default ``config.MIN_DRAWS_PER_CHAIN``: shorter
    chains overstate it; a walk measured otherwise says its own)."""

    def __init__(self, n: int, max_seconds=None, target_ess=None, chains: int = 1,
                 seed: int = 0, min_draws: int | None = None):
        self.n, self.max_seconds, self.target_ess = n, max_seconds, target_ess
        self.chains, self.seed = max(int(chains), 1), seed
        floor = config.MIN_DRAWS_PER_CHAIN if min_draws is None else int(min_draws)
        self.next_check = floor * self.chains
        self.last = {}

    def _after(self, k: int) -> int:
        """The check after the one at k samples: k grown by a quarter, in whole rounds
        of the chains."""
        return self.chains * -(-int(1.25 * k) // self.chains)

    def __call__(self, k: int, samples, t0: float):
        """(status, message) when the run should stop after k samples, else None;
        ``samples()`` returns (X (k, 2m), chains (k,))."""
        if self.target_ess is not None and k % self.chains == 0 and k >= self.next_check:
            self.next_check = self._after(k)
            X, chains = samples()
            s = summarize(tracked_statistics(by_chain(X, chains), seed=self.seed))
            self.last = {"min_ess": s["min_ess"], "max_rhat": s["max_rhat"], "k": k}
            if converged(s, self.target_ess):
                return 0, (f"converged: ESS >= {s['min_ess']:.0f} (target "
                           f"{self.target_ess:g}), R-hat <= {s['max_rhat']:.3f} after {k} "
                           "samples")
        if self.max_seconds is not None and time.perf_counter() - t0 > self.max_seconds:
            if k < self.n or self.target_ess is not None:
                return 1, f"stopped after max_seconds = {self.max_seconds:g} s with {k} " \
                          f"samples{self._short()}"
        return None

    def resumed(self, k: int, samples, t0: float):
        """A run resumed with k stored samples (k < n) takes up the checks of a run
        straight through: none before k (the run went on past them), the one at k if
        k is due one (a run stopped there, by convergence or by a kill before it
        checked). (status, message) if the run stops at k, else None."""
        if self.target_ess is None:
            return None
        while self.next_check < k:
            self.next_check = self._after(self.next_check)
        return self(k, samples, t0) if k == self.next_check else None

    def expected_total(self) -> int:
        """Samples the run is expected to draw: with a target ESS and an ESS measured after
        k samples, k x target / ESS (ESS grows about linearly with the draws), not before
        the next check and at most n; else n. What the progress bar's ETA is taken to."""
        ess = self.last.get("min_ess") if self.last else None
        if self.target_ess is None or not ess or not np.isfinite(ess):
            return self.n
        need = max(self.last["k"] * self.target_ess / ess, self.next_check)
        return int(min(self.n, self.chains * -(-int(np.ceil(need)) // self.chains)))

    def at_cap(self, k: int, samples=None):
        """(status, message) of a run that drew all n samples (``samples()``: as for
        ``__call__``, to say how far short of the target ESS it stopped)."""
        if self.target_ess is None:
            return 0, f"{k} samples"
        if samples is not None:
            X, chains = samples()
            s = summarize(tracked_statistics(by_chain(X, chains), seed=self.seed))
            self.last = {"min_ess": s["min_ess"], "max_rhat": s["max_rhat"]}
        return 1, f"reached n = {self.n} samples{self._short()}"

    def _short(self) -> str:
        if self.target_ess is None or not self.last:
            return ""
        return (f" short of the target ESS {self.target_ess:g} (ESS "
                f"{self.last['min_ess']:.0f}, R-hat {self.last['max_rhat']:.3f})")


def run_walk(walk, problem, stop: Stop, output=None, checkpoint_every: int = 10,
             progress: bool = False, t_start: float | None = None) -> Ensemble:
    """Draw samples of S with ``walk`` until ``stop`` says so (:class:`Stop`: a sample
    count, a time cap, a target ESS). ``output``: an ensemble file to write, resumed when
    it continues this run. Returns the whole ensemble (stored and new samples)."""
    require_int("sample", "n", stop.n, 1, "number of samples")
    require_int("sample", "checkpoint_every", checkpoint_every, 1)
    t0 = time.perf_counter() if t_start is None else t_start
    if output is None:
        return _draw(walk, problem, stop, None, None, checkpoint_every, progress, t0)
    check_output_file(output)
    with output_lock(output):
        old = ef.existing(output, problem, walk.sampler, walk.params)
        if old is not None:
            _verify_stored(old.ensemble, problem, output)
            walk.resume(old)
        else:
            setup, describe, checkpoint, checkpoint_attrs = walk.set_up()
            ef.create(output, problem, walk.sampler, walk.params, setup, describe, checkpoint,
                      checkpoint_attrs, walk.tolerance_description)
        return _draw(walk, problem, stop, output, old, checkpoint_every, progress, t0)


def _draw(walk, problem, stop, output, old, every, progress, t0) -> Ensemble:
    if output is None:
        walk.set_up()
    have = 0 if old is None else old.ensemble.n_samples
    sink = _Sink(output, have, every, walk)

    def samples():
        X = np.array([d[0] for d in sink.drawn], float).reshape(len(sink.drawn),
                                                                problem.n_columns)
        c = np.array([d[1] for d in sink.drawn], np.int64)
        if old is not None:
            X = np.vstack([old.ensemble.samples, X]) if len(X) else old.ensemble.samples
            c = np.concatenate([old.ensemble.chains, c])
        return X, c

    outcome = stop.at_cap(have, samples) if have >= stop.n else \
        stop.resumed(have, samples, t0) if have else None
    with deferred_sigint() as interrupt, \
            progress_bar(total=stop.n, desc=walk.sampler, unit="sample",
                         disable=not progress) as bar:
        walk.interrupt = interrupt
        bar.update(min(have, stop.n))
        try:
            for i in range(have, stop.n if outcome is None else have):
                sink.add(*walk.draw(i))
                interrupt.check()
                bar.update(1)
                if hasattr(walk, "postfix"):
                    bar.set_postfix(walk.postfix(), refresh=False)
                outcome = stop(i + 1, samples, t0)
                if outcome is not None:
                    break
                if stop.last and bar.total != stop.expected_total():
                    bar.total = stop.expected_total()     # the ETA to the target ESS
                    bar.refresh()
            if outcome is not None and outcome[0] == 0 and bar.total != bar.n:
                bar.total = bar.n       # converged: the bar ends full, not at n's 2 %
                bar.refresh()
        except Interrupted:    # Ctrl-C, honoured between draws or at a walk's safe point
            sink.flush()
            raise Interrupted(_where(have + len(sink.drawn), output)) from None
        except BaseException:
            sink.flush()       # finished samples are never lost
            raise
    try:
        status, message = outcome if outcome is not None else stop.at_cap(stop.n, samples)
        ens = _ensemble(walk, problem, old, sink, status, message, output)
    except KeyboardInterrupt:  # Ctrl-C while the run's diagnostics are computed
        with deferred_sigint():
            sink.flush()       # the samples are kept; the rerun finishes the run
        raise Interrupted(_where(have + len(sink.drawn), output)) from None
    diag = dumps(ens.diagnostics)
    with deferred_sigint():    # the last write is short: finished, not torn
        if sink.buffer or sink.drawn or (old is not None
                                         and old.ensemble.attrs.get("diagnostics") != diag):
            sink.flush(diag)
    return ens


def _where(k: int, output) -> str:
    """Where an interrupted run stands: its samples and how it resumes."""
    if output is None:
        return f"after {k} samples (in memory, not kept)"
    return f"{k} samples in {output}; rerun the same command to resume"


def _ensemble(walk, problem, old, sink, status, message, output) -> Ensemble:
    """The stored samples (if resumed) followed by this run's, as an Ensemble."""
    m2 = problem.n_columns
    X = np.array([d[0] for d in sink.drawn], float).reshape(len(sink.drawn), m2)
    chains = np.array([d[1] for d in sink.drawn], np.int64)
    viol = np.array([d[2] for d in sink.drawn], float)
    if old is not None:
        X = np.vstack([old.ensemble.samples, X])
        chains = np.concatenate([old.ensemble.chains, chains])
        viol = np.concatenate([old.ensemble.violations, viol])
    ens = Ensemble(sampler=walk.sampler, samples=X, chains=chains, violations=viol,
                   contacts=problem.contacts, disks=problem.disks, mu=problem.mu,
                   x_jammed=problem.x_jammed, force_scale=problem.force_scale,
                   params=dict(walk.params), attrs=ef.provenance(problem), status=status,
                   message=message, path=None if output is None else str(output),
                   per_contact=ef.per_contact(problem))
    ens.diagnostics = diagnostics(ens.samples, ens.chains, walk.params.get("seed", 0),
                                  ens.per_contact)
    return ens


class Sampler(Computed):
    """What every sampler's result has (the samplers are compute objects of this kind:
    ``Sampler(n, seed, ...).compute(problem)``): the samples, their eta, the parameters
    and the run's wall seconds."""

    n: int
    seed: int

    @property
    def ensemble(self) -> Ensemble:
        """The samples (:class:`~forcespace.model.ensemble.Ensemble`), with their
        convergence diagnostics."""
        return self._get("ensemble")

    @property
    def eta(self) -> float:
        """The paper's force ambiguity of the samples."""
        return self.ensemble.eta

    @property
    def params(self) -> dict:
        """The parameters the walk ran with (defaults filled in)."""
        return self._get("params")

    @property
    def times(self) -> dict:
        """Wall seconds of the run: wall_time_s, and for the walks in a rounded frame
        frame_s, rounding_s, burn_in_s (0 when resumed) and sampling_s (the rest)."""
        return self._get("times")

    def plot(self, packing, sample: int | None = None, ax=None, **kw):
        """Draw the ensemble (or sample ``sample``) on ``packing``
        (:meth:`Ensemble.plot`); returns the Axes."""
        return self.ensemble.plot(packing, sample, ax, **kw)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(n={self.n}, seed={self.seed}){self._outcome()}"

    def _outcome(self) -> str:
        """': k samples, eta ..., message' once computed (the repr says what it did)."""
        if not self.computed or self._results.get("ensemble") is None:
            return ""
        ens = self.ensemble
        said = "" if self.message == f"{ens.n_samples} samples" else f", {self.message}"
        return f": {ens.n_samples} samples, eta = {ens.eta:.4g}{said}"


class TimedStop(Stop):
    """:class:`Stop` that also counts the CPU seconds of its convergence checks (the
    run's diagnostics, kept apart from the sampling's)."""

    def __init__(self, *args, **kw):
        super().__init__(*args, **kw)
        self.cpu_s = 0.0

    def __call__(self, k, samples, t0):
        c0 = time.process_time()
        try:
            return super().__call__(k, samples, t0)
        finally:
            self.cpu_s += time.process_time() - c0


def _subclasses(cls) -> list:
    """Every subclass of ``cls``, at any depth."""
    return [c for sub in cls.__subclasses__() for c in (sub, *_subclasses(sub))]


class FrameSampler(Sampler):
    """A sampler that walks in the rounded affine frame of S (hit-and-run, billiard):
    ``Walk`` its :class:`~forcespace.sampling.frame.FrameWalk`, the options its own
    (checked by the subclass before ``__init__``); compute, results and summary are
    these, with :meth:`_walk_results` and :meth:`_summary_extra` for the walk's own."""

    Walk = None
    ConicWalk = None     # the walk on S of spheres, if the sampler has one

    def __init__(self, n: int, seed: int, max_seconds, checkpoint_every: int,
                 progress: bool, target_ess, **options):
        check_target(target_ess)
        self.n, self.seed, self.progress = n, seed, progress
        self.max_seconds, self.checkpoint_every = max_seconds, checkpoint_every
        self.target_ess = target_ess
        self.options = dict(seed=seed, **options)

    def compute(self, problem, output=None, analysis=None):
        """Sample S of ``problem`` (in memory, or into the ensemble file ``output``,
        resumed when it continues this run); ``analysis``: its ForceSpace, if computed."""
        t0, c0 = time.perf_counter(), time.process_time()
        Walk = self.walk_for(problem)
        problem = problem.check(type(self).__name__) \
            if isinstance(problem, SphereStaticsProblem) \
            else checked_problem(problem, type(self).__name__)
        walk = Walk(problem, self.options, analysis, self.progress)
        stop = TimedStop(self.n, self.max_seconds, self.target_ess, walk.params["chains"],
                         walk.params["seed"], walk.min_draws_per_chain())
        ens = run_walk(walk, problem, stop, output, self.checkpoint_every, self.progress,
                       t_start=t0)
        self._start()
        wall = time.perf_counter() - t0
        self._results.update(
            ensemble=ens, dim=walk.d, n_rows=int(walk.H0.shape[0]), params=walk.params,
            times=dict(walk.times, wall_time_s=wall, sampling_s=wall - sum(walk.times.values())),
            cpu=dict(walk.cpu, diagnostics_s=stop.cpu_s, total_s=time.process_time() - c0),
            frame_equality_floor=walk.frame_equality_floor, frame_widening=walk.widening,
            **self._walk_results(walk))
        self._finish(ens.status, ens.message)
        return self

    def walk_for(self, problem):
        """The walk for ``problem``: ``ConicWalk`` for a sphere problem (S with circular
        Coulomb cones), ``Walk`` otherwise; InputError if the sampler has no conic walk."""
        if isinstance(problem, SphereStaticsProblem):
            if self.ConicWalk is None:
                conic = sorted(c.__name__ for c in _subclasses(FrameSampler) if c.ConicWalk)
                raise InputError(type(self).__name__, "problem", "S of spheres (circular "
                                 f"Coulomb cones) is sampled by {' or '.join(conic)}; "
                                 "this sampler walks in polytopes only")
            return self.ConicWalk
        return self.Walk

    def _walk_results(self, walk) -> dict:
        """Results of the walk beyond the frame samplers' own."""
        return {}

    def _summary_extra(self) -> dict:
        """The walk's own lines of :meth:`summary`."""
        return {}

    def summary(self) -> dict:
        """The run's numbers (what ``forcespace sample --json`` prints)."""
        ens = self.ensemble
        return {"n_samples": ens.n_samples, "dim_S": self.dim, "n_rows": self.n_rows,
                **self.times, "cpu": self.cpu, **self._summary_extra(),
                "frame_equality_floor": self.frame_equality_floor,
                "frame_widening": self.frame_widening,
                "max_violation": float(ens.violations.max(initial=0.0)),
                "params": self.params, "status": self.status, "message": self.message,
                **ens.diagnostics}

    @property
    def dim(self) -> int:
        """Dimension of S (of the frame the walk ran in)."""
        return self._get("dim")

    @property
    def n_rows(self) -> int:
        """Inequality rows of the rounded polytope the walk moves in."""
        return self._get("n_rows")

    @property
    def cpu(self) -> dict:
        """CPU seconds (process time) of the run's stages."""
        return self._get("cpu")

    @property
    def frame_equality_floor(self) -> float:
        """Largest equilibrium residual of the frame's directions at a sample, / <Fn>."""
        return self._get("frame_equality_floor")

    @property
    def frame_widening(self) -> float:
        """How far [<Fn>] the frame moved every free row out (0 unless S had no point
        strictly inside in its affine hull): samples lie within it of S."""
        return self._get("frame_widening")
