"""The paper's perturb-and-relax walk through S (Unger et al., footnote on sampling).

From the last admissible network: add to fn and ft of every unknown contact
an independent kick uniform in [-<Fn>, <Fn>] (<Fn> = problem.force_scale, the
jammed mean normal force; ft is not kicked where mu = 0, since it is 0 by
definition there), then relax with the nonlinear Gauss-Seidel contact solver
(nlgs.nlgs_solve) in statics mode: positions fixed, gaps 0, velocities
``v = dt M^-1 (F_ext + contact forces)`` from rest, dt = 1 and the disk masses
acting only as preconditioner weights. Fixed supports (walls, support disks)
have zero inverse mass. Loads (fixed boundary forces and their torques) enter
as the initial velocities dt M^-1 F_ext.

Relaxation stops when the sample's violation of S (equilibrium residual;
Coulomb and fn >= 0 hold exactly after every Gauss-Seidel update) relative to
<Fn> is <= ``tol`` (default 1e-9), checked on the forces themselves every
``chunk`` sweeps.

Stalls. Contact dynamics with friction admits non-static solutions: after a
kick the Gauss-Seidel iteration can settle on forces under which some bodies
keep sliding (a fixed point of the sweep that is not in S), most often at
large mu. Such a relaxation (no 1 % progress in ``stall_sweeps`` sweeps, or
``max_sweeps`` reached) is finished by the exact Euclidean projection of its
forces onto S (:func:`forcespace.space.projection.distance_to_S`, KKT-verified): the
admissible network nearest to where the walk got stuck; where that projection
cannot be verified (ill-conditioned slices at large mu), by the network of S
nearest in the L1 norm (one LP, :func:`forcespace.space.projection.l1_nearest`),
counted as ``n_projected_l1``. Every such sample is
counted (``n_projected`` in the checkpoint attributes and the summary) and
listed (``checkpoint/projected``: indices of the projected samples). Finished samples are written before any error propagates.

For the plate problem (:func:`forcespace.model.problem.plate_problem`) the top
plate is a body of the relaxation that moves vertically only, loaded by
the plate force: the solver balances the same plate row as the LPs.
The walk is not proven to sample S uniformly.
"""
from __future__ import annotations

import copy
import json
import time

import numpy as np

from .. import config
from ..engine.frozen import frozen_contacts, relax
from ..engine.interrupts import InterruptFlag
from ..errors import InputError, NumericalError, require_int
from ..model.problem import StaticsProblem, checked_problem
from ..space.questions import check_bounded, check_feasible
from ..space.projection import Projector, l1_nearest
from ..streams import chain_generators, restored_generator
from .driver import Sampler, Stop, check_target, run_walk


class Relaxer:
    """A problem's frozen contact network for repeated NLGS relaxations."""

    def __init__(self, problem: StaticsProblem):
        p = problem
        if p.n_contacts == 0:
            raise InputError(p.source or "problem", "contacts",
                             "no unknown contact in the problem: nothing to relax")
        self.problem = p
        self.system = frozen_contacts(p)
        self.mu = self.system.mu
        self.n_l1 = 0          # stalls finished by the L1-nearest network (see relax)
        self.allowed = config.SAMPLE_VIOLATION   # what the last relax's point is verified to
        self.projector = Projector(p)   # exact projection of stalled relaxations onto S

    def relax(self, x, tol=config.SAMPLE_VIOLATION, chunk=200, max_sweeps=2_000_000, seed=0,
              stall_sweeps=config.RELAX_STALL_SWEEPS, interrupt=None):
        """Relax forces x (2m,) [F0] to an admissible network.

        Returns (x (2m,), RelaxResult, projected): ``projected`` is True when
        the relaxation stalled or hit ``max_sweeps`` and x is the exact
        projection of its end state onto S (see the module docstring).
        Raises NumericalError if even the projection cannot be verified;
        Interrupted when ``interrupt`` (an InterruptFlag, checked after every
        chunk of sweeps) was set.
        """
        rn = np.ascontiguousarray(x[0::2], dtype=float).copy()
        rt = np.ascontiguousarray(x[1::2], dtype=float).copy()
        rt[self.mu == 0.0] = 0.0
        out = np.empty(2 * rn.size)

        def violation(rn, rt):
            out[0::2] = rn
            out[1::2] = rt
            return self.problem.violation(out)

        interrupt = interrupt or InterruptFlag()
        res = relax(self.system, rn, rt, violation, tol, max_sweeps, seed, chunk,
                    stall_sweeps=stall_sweeps, on_chunk=lambda sweeps, v: interrupt.check())
        out[0::2] = rn
        out[1::2] = rt
        self.allowed = tol
        if res.converged:
            return out.copy(), res, False
        try:
            proj = self.projector(out)
            nearest, self.allowed = proj.nearest, max(tol, proj.allowed_violation)
        except NumericalError as exc:   # unverifiable on an ill-conditioned slice: L1 by LP
            nearest = l1_nearest(self.problem, out)
            self.n_l1 += 1
            v = self.problem.violation(nearest)
            if not v <= tol:
                raise NumericalError(f"{exc}; the L1-nearest network violates S by "
                                     f"{v:.2e} <Fn> (> tol = {tol:g})") from exc
        return nearest, res, True


def kick(x, mu, scale, rng):
    """Add uniform [-scale, scale] kicks to fn and ft (ft only where mu > 0)."""
    k = rng.uniform(-scale, scale, size=x.shape)
    k[1::2][mu == 0.0] = 0.0
    return x + k


def check_options(n, tol, checkpoint_every=1, source="sample"):
    """Refuse meaningless sampler options before any work (InputError)."""
    require_int(source, "n", n, 1, "number of samples", config.MAX_SAMPLES)
    require_int(source, "checkpoint_every", checkpoint_every, 1)
    if not (isinstance(tol, (int, float)) and np.isfinite(tol) and 0 < tol < 1):
        raise InputError(source, "tol", "must be a finite number in (0, 1) (violation of S "
                         "relative to <Fn>)", got=tol)


class KickRelaxWalk:
    """The relax walk as a walk of :func:`forcespace.sampling.driver.run_walk`.

    ``chains`` independent walks from the same relaxed start, sample i drawn by chain
    i % chains; chain c kicks with its own stream
    (:func:`forcespace.streams.chain_generators`). A draw kicks with a copy of its
    chain's generator, kept only when the sample is accepted: the checkpoint's stream
    state is always the one after the last stored sample, so a run interrupted (or
    failed) in a draw resumes to the same chain as a run straight through."""

    sampler = "relax"
    interrupt = InterruptFlag()     # set by run_walk: Ctrl-C between chunks of sweeps

    def __init__(self, problem: StaticsProblem, seed: int, tol: float, chunk: int,
                 max_sweeps: int, start, chains: int = 1):
        self.problem, self.seed, self.tol = problem, int(seed), float(tol)
        self.chunk, self.max_sweeps, self.start = chunk, max_sweeps, start
        self.chains = int(chains)
        self.relaxer = Relaxer(problem)
        self.params = {"seed": int(seed), "tol": float(tol),
                       "kick": "uniform +-<Fn> on fn and ft",
                       "kick_scale": problem.force_scale, "stall": "exact projection onto S"}
        if self.chains > 1:        # (one chain: the parameters, and files, of before)
            self.params["chains"] = self.chains
        self.tolerance_description = (f"every sample has max violation <= {tol} relative to "
                                      "<Fn> (checked after relaxation)")

    def set_up(self):
        """Relax the jammed network (or ``start``): every chain's first point."""
        p = self.problem
        x0 = p.x_jammed if self.start is None else np.asarray(self.start, float)
        x, res, projected = self.relaxer.relax(x0, self.tol, self.chunk, self.max_sweeps,
                                               self.seed)
        self.x, self.rng = np.tile(x, (self.chains, 1)), chain_generators(self.seed, self.chains)
        self.sweeps_total, self.projected = int(res.sweeps), []
        arrays, attrs = self.state(0)
        attrs["start_projected"] = int(projected)
        return ({"x_start": x}, {"x_start": ("F0", "jammed network relaxed to tol (walk start)")},
                arrays, attrs)

    def resume(self, stored) -> None:
        """Continue from an ensemble file's checkpoint."""
        path = stored.ensemble.path
        x = np.asarray(stored.checkpoint["x"], float).reshape(-1, self.problem.n_columns) \
            if np.size(stored.checkpoint["x"]) == self.chains * self.problem.n_columns \
            else None
        if x is None or not np.all(np.isfinite(x)):
            raise InputError(path, "checkpoint/x", f"must be {self.chains} finite vector(s) "
                             f"of length {self.problem.n_columns}; delete the file to restart")
        self.x = x.copy()
        try:
            states = json.loads(stored.checkpoint_attrs["rng_state"])
            states = [states] if self.chains == 1 else states
            if len(states) != self.chains:
                raise ValueError("one saved generator state per chain")
            self.rng = [restored_generator(st) for st in states]
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(path, "checkpoint/rng_state", f"unreadable ({exc}); the "
                             "checkpoint is corrupt: delete the file to restart") from None
        self.sweeps_total = int(stored.checkpoint_attrs.get("sweeps_total", 0))
        self.projected = [int(i) for i in stored.checkpoint.get("projected", [])]

    def draw(self, i: int):
        c = i % self.chains
        rng = copy.deepcopy(self.rng[c])      # the chain's stream moves on acceptance only
        xk = kick(self.x[c], self.problem.mu, self.problem.force_scale, rng)
        xn, res, projected = self.relaxer.relax(xk, self.tol, self.chunk, self.max_sweeps,
                                                self.seed + 1 + i, interrupt=self.interrupt)
        v = self.problem.violation(xn)
        if not v <= self.relaxer.allowed:   # tol, or a projection's equilibrium floor
            raise NumericalError(f"relax sample {i} violates S by {v:.3e} x <Fn> "
                                 f"({res.message})")
        self.x[c], self.rng[c] = xn, rng
        self.sweeps_total += res.sweeps
        if projected:
            self.projected.append(i)
        return xn, c, v

    def postfix(self) -> dict:
        return {"projected": len(self.projected)}

    def state(self, n_total: int):
        one = self.chains == 1
        rng = [g.bit_generator.state for g in self.rng]
        return ({"x": self.x[0] if one else self.x,
                 "projected": np.array(self.projected, np.int64)},
                {"rng_state": json.dumps(rng[0] if one else rng), "n_done": n_total,
                 "sweeps_total": int(self.sweeps_total), "n_projected": len(self.projected)})


class RelaxWalk(Sampler):
    """The paper's perturb-and-relax walk through S (compute object; module docstring).

    ``RelaxWalk(n=100, seed=1).compute(problem)`` draws ``n`` samples in memory;
    ``compute(problem, output=PATH)`` writes (and resumes) an ensemble file instead;
    ``compute(problem, start=x)`` starts from the network x (2m,) instead of the jammed
    one. ``tol``: largest violation of S of a sample, / <Fn>; ``max_seconds`` stops early
    (status 1). Results: ``ensemble``, ``sweeps_total``, ``projected`` (samples whose
    relaxation stalled and were finished by the exact projection onto S), ``n_projected_l1``
    (of those, finished by the L1-nearest network), ``times``.
    The walk is not proven to sample S uniformly.
    """

    def __init__(self, n: int = 100, seed: int = 0, tol: float = config.SAMPLE_VIOLATION,
                 chunk: int = 200, max_sweeps: int = 2_000_000,
                 max_seconds: float | None = None, checkpoint_every: int = 10,
                 progress: bool = False, chains: int = 1, target_ess: float | None = None):
        check_options(n, tol, checkpoint_every)
        require_int("sample", "chains", chains, 1, "independent walks", config.MAX_CHAINS)
        check_target(target_ess)
        self.n, self.seed, self.tol, self.progress = n, seed, tol, progress
        self.chunk, self.max_sweeps, self.chains = chunk, max_sweeps, chains
        self.max_seconds, self.checkpoint_every = max_seconds, checkpoint_every
        self.target_ess = target_ess

    def compute(self, problem: StaticsProblem, output=None, start=None) -> "RelaxWalk":
        """Walk through S of ``problem`` (refuses an empty or unbounded S)."""
        t0 = time.perf_counter()
        problem = checked_problem(problem, "RelaxWalk")
        walk = KickRelaxWalk(problem, self.seed, self.tol, self.chunk, self.max_sweeps, start,
                     self.chains)
        feas, _, _ = check_feasible(problem)
        if not feas:
            raise InputError(problem.source or "problem", "S",
                             "is empty (infeasible): nothing to sample")
        bounded, _, _ = check_bounded(problem)
        if not bounded:
            raise InputError(problem.source or "problem", "S",
                             "is unbounded (a recession direction exists, e.g. a wedged "
                             "contact); refusing to sample")
        ens = run_walk(walk, problem, Stop(self.n, self.max_seconds, self.target_ess,
                                           self.chains, self.seed),
                       output, self.checkpoint_every, self.progress, t_start=t0)
        self._start()
        self._results.update(ensemble=ens, sweeps_total=walk.sweeps_total,
                             projected=np.array(walk.projected, np.int64),
                             n_projected_l1=walk.relaxer.n_l1, params=walk.params,
                             times={"wall_time_s": time.perf_counter() - t0})
        self._finish(ens.status, ens.message)
        return self

    @property
    def sweeps_total(self) -> int:
        """Gauss-Seidel sweeps of the walk, the start's relaxation included."""
        return self._get("sweeps_total")

    @property
    def projected(self) -> np.ndarray:
        """Indices of samples whose relaxation stalled (a non-static fixed point) and
        were finished by the exact projection onto S."""
        return self._get("projected")

    @property
    def n_projected_l1(self) -> int:
        """Stalls of this run finished by the L1-nearest network (projection unverifiable)."""
        return self._get("n_projected_l1")

    def summary(self) -> dict:
        """The run's numbers (what ``forcespace sample --json`` prints)."""
        ens = self.ensemble
        return {"n_samples": ens.n_samples, **self.times,
                "max_violation": float(ens.violations.max(initial=0.0)),
                "sweeps_total": self.sweeps_total, "n_projected": int(self.projected.size),
                "n_projected_l1": self.n_projected_l1,
                "projected_convention": "samples whose relaxation stalled (non-static fixed "
                                        "point) and were finished by the exact projection "
                                        "onto S",
                "params": self.params, "status": self.status, "message": self.message}

    def __repr__(self) -> str:
        return f"RelaxWalk(n={self.n}, seed={self.seed}, tol={self.tol:g}){self._outcome()}"
