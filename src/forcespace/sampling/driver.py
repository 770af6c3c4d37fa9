"""The one sampling driver: set-up or resume, draw, buffer, checkpoint, stop.

Every sampler is a *walk* (hit-and-run, the relax walk) with five parts:

* ``sampler`` (its name in files) and ``params`` (the parameters a file records
  and is fingerprinted with), ``tolerance_description`` (one line for the file);
* ``set_up()``: the work before the first sample (frame, rounding, burn-in; or the
  relaxed start), returning what a file keeps: (setup arrays, their
  (unit, description), checkpoint arrays, checkpoint attrs);
* ``resume(ensemble_file)``: continue from a file's set-up and checkpoint instead;
* ``draw(i)``: the i-th sample: (x (2m,) [F0], chain, violation / <Fn>);
* ``state(n_total)``: the checkpoint (arrays, attrs) after the last accepted sample.

:func:`run_walk` drives a walk to ``n`` samples in memory, or, given ``output``,
into a resumable ensemble file (locked while written; samples appended at growing
intervals, at most ``CHECKPOINT_SECONDS`` of work at risk). Files are read once at
the start (resume) and written as the run goes; nothing is read back.
"""
from __future__ import annotations

import time

import numpy as np

from .. import config
from ..errors import InputError, require_int
from ..io import ensemble_file as ef
from ..io.jsonfile import dumps
from ..io.outputs import check_output_file, output_lock
from ..progress import progress as progress_bar
from .diagnostics import diagnostics
from .ensemble import Ensemble

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
        if not now <= max(float(v), config.SAMPLE_VIOLATION) * (1 + 1e-6) + 1e-15:
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


def run_walk(walk, problem, n: int, output=None, checkpoint_every: int = 10,
             max_seconds: float | None = None, progress: bool = False,
             t_start: float | None = None) -> Ensemble:
    """Draw samples of S with ``walk`` until there are ``n`` (or ``max_seconds`` since
    ``t_start`` have passed: status 1, every sample drawn kept). ``output``: an ensemble
    file to write, resumed when it continues this run. Returns the whole ensemble."""
    require_int("sample", "n", n, 1, "number of samples")
    require_int("sample", "checkpoint_every", checkpoint_every, 1)
    t0 = time.perf_counter() if t_start is None else t_start
    if output is None:
        return _draw(walk, problem, n, None, None, checkpoint_every, max_seconds, progress, t0)
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
        return _draw(walk, problem, n, output, old, checkpoint_every, max_seconds, progress,
                     t0)


def _draw(walk, problem, n, output, old, every, max_seconds, progress, t0) -> Ensemble:
    if output is None:
        walk.set_up()
    have = 0 if old is None else old.ensemble.n_samples
    sink = _Sink(output, have, every, walk)
    status, message = 0, f"{max(n, have)} samples"
    with progress_bar(total=n, desc=walk.sampler, unit="sample", disable=not progress) as bar:
        bar.update(min(have, n))
        try:
            for i in range(have, n):
                sink.add(*walk.draw(i))
                bar.update(1)
                if hasattr(walk, "postfix"):
                    bar.set_postfix(walk.postfix(), refresh=False)
                if max_seconds is not None and time.perf_counter() - t0 > max_seconds:
                    if i + 1 < n:
                        status, message = 1, (f"stopped after max_seconds = {max_seconds:g} s "
                                              f"with {i + 1} of {n} samples")
                    break
        except BaseException:
            sink.flush()       # finished samples are never lost
            raise
    ens = _ensemble(walk, problem, old, sink, status, message, output)
    if sink.buffer or sink.drawn:
        sink.flush(dumps(ens.diagnostics))
    return ens


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
                   message=message, path=None if output is None else str(output))
    if walk.sampler == "hit-and-run":
        ens.diagnostics = diagnostics(ens.samples, ens.chains, walk.params.get("seed", 0))
    return ens
