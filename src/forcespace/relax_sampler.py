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
forces onto S (:func:`forcespace.polytope.distance_to_S`, KKT-verified): the
admissible network nearest to where the walk got stuck; where that projection
cannot be verified (ill-conditioned slices at large mu), by the network of S
nearest in the L1 norm (one LP, :func:`forcespace.polytope.l1_nearest`),
counted as ``n_projected_l1``. Every such sample is
counted (``n_projected`` in the checkpoint attributes and the summary) and
listed (``checkpoint/projected``: indices of the projected samples). Finished samples are written before any error propagates.

For the plate problem (:func:`forcespace.statics.plate_problem`) the top
plate is a body of the relaxation that moves vertically only, loaded by
the plate force: the solver balances the same plate row as the LPs.
The walk is not proven to sample S uniformly.
"""
from __future__ import annotations

import json
import sys
import time

import numpy as np

from . import ensemble_file as ef
from .errors import InputError, NumericalError, require_int
from .polytope import check_bounded, check_feasible, distance_to_S, l1_nearest
from .relaxation import FrozenContacts, relax
from .statics import StaticsProblem

DEFAULT_TOL = 1e-9
STALL_SWEEPS = 20_000   # no 1 % progress in this many sweeps: a stalled relaxation


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

    def relax(self, x, tol=DEFAULT_TOL, chunk=200, max_sweeps=2_000_000, seed=0,
              stall_sweeps=STALL_SWEEPS):
        """Relax forces x (2m,) [F0] to an admissible network.

        Returns (x (2m,), RelaxResult, projected): ``projected`` is True when
        the relaxation stalled or hit ``max_sweeps`` and x is the exact
        projection of its end state onto S (see the module docstring).
        Raises NumericalError if even the projection cannot be verified.
        """
        rn = np.ascontiguousarray(x[0::2], dtype=float).copy()
        rt = np.ascontiguousarray(x[1::2], dtype=float).copy()
        rt[self.mu == 0.0] = 0.0
        out = np.empty(2 * rn.size)

        def violation(rn, rt):
            out[0::2] = rn
            out[1::2] = rt
            return self.problem.violation(out)

        res = relax(self.system, rn, rt, violation, tol, max_sweeps, seed, chunk,
                    stall_sweeps=stall_sweeps)
        out[0::2] = rn
        out[1::2] = rt
        if res.converged:
            return out.copy(), res, False
        try:
            nearest = distance_to_S(self.problem, out).nearest
        except NumericalError as exc:   # unverifiable on an ill-conditioned slice: L1 by LP
            nearest = l1_nearest(self.problem, out)
            self.n_l1 += 1
            v = self.problem.violation(nearest)
            if not v <= tol:
                raise NumericalError(f"{exc}; the L1-nearest network violates S by "
                                     f"{v:.2e} <Fn> (> tol = {tol:g})") from exc
        return nearest, res, True


def frozen_contacts(p: StaticsProblem) -> FrozenContacts:
    """The solver view of a statics problem, derived from its H-representation.

    Kernel bodies: the interior disks 0..n-1 (mass and inertia of the disk),
    one fixed ground n for every support (walls, support disks: they never
    move, so one body stands for all), and for the plate problem the plate
    n+1, which moves vertically only, pressed down by the plate row's load
    b[-1] = top_force. Contacts, normals and loads are read off A and b
    (:meth:`StaticsProblem.contact_geometry`); masses only precondition.
    """
    n = p.n_interior
    ground = n
    a, b, nx, ny = p.contact_geometry()
    plate = p.kind == "full_plate" and p.A.shape[0] > 3 * n
    nb = n + (2 if plate else 1)
    ka = np.where(a >= 0, a, ground)
    if plate:
        on_plate = np.zeros(p.n_contacts, bool)
        on_plate[p.A[3 * n].indices // 2] = True
        ka[on_plate & (a < 0)] = n + 1
    radius = np.append(p.radius, 0.0)
    inv_m = np.zeros(nb)
    inv_m[:n] = 1.0 / p.mass
    inv_my = inv_m.copy()
    inv_i = np.zeros(nb)
    inv_i[:n] = 1.0 / (0.5 * p.mass * p.radius ** 2)
    v_ext = (np.zeros(nb), np.zeros(nb), np.zeros(nb))
    v_ext[0][:n] = p.load_force[:, 0] / p.mass
    v_ext[1][:n] = p.load_force[:, 1] / p.mass
    v_ext[2][:n] = p.load_torque * inv_i[:n]
    if plate:   # the plate's mass only preconditions too
        m_plate = float(p.mass.mean())
        inv_my[n + 1] = 1.0 / m_plate
        v_ext[1][n + 1] = -p.b[3 * n] / m_plate
    return FrozenContacts(a=ka.astype(np.int64), b=b.astype(np.int64), nx=nx, ny=ny,
                          ra=radius[np.where(a >= 0, a, n)], rb=radius[b],
                          mu=p.mu.astype(float), inv_mx=inv_m, inv_my=inv_my, inv_i=inv_i,
                          v_ext=v_ext)


def kick(x, mu, scale, rng):
    """Add uniform [-scale, scale] kicks to fn and ft (ft only where mu > 0)."""
    k = rng.uniform(-scale, scale, size=x.shape)
    k[1::2][mu == 0.0] = 0.0
    return x + k


def check_options(n, tol, checkpoint_every=1, source="sample"):
    """Refuse meaningless sampler options before any work (InputError)."""
    require_int(source, "n", n, 1, "number of samples")
    require_int(source, "checkpoint_every", checkpoint_every, 1)
    if not (isinstance(tol, (int, float)) and np.isfinite(tol) and 0 < tol < 1):
        raise InputError(source, "tol", "must be a finite number in (0, 1) (violation of S "
                         "relative to <Fn>)", got=tol)


def sample(problem: StaticsProblem, n: int, out, packing_file: str = "", scene_name: str = "",
           scene_text: str = "", seed: int = 0, tol: float = DEFAULT_TOL, chunk: int = 200,
           max_sweeps: int = 2_000_000, checkpoint_every: int = 10, progress: bool = False,
           max_seconds: float | None = None, start=None) -> dict:
    """Write ``n`` perturb-and-relax samples to ``out`` (resumes a matching file).

    ``start`` (2m,): first network (default: the jammed forces, relaxed to tol).
    Returns a summary dict. Refuses an infeasible or unbounded S. Samples
    finished before an error are in the file when the error propagates.
    """
    check_options(n, tol, checkpoint_every)
    t0 = time.perf_counter()
    relaxer = Relaxer(problem)
    feas, _, _ = check_feasible(problem)
    if not feas:
        raise InputError(problem.source or "problem", "S", "is empty (infeasible): nothing to sample")
    bounded, _, _ = check_bounded(problem)
    if not bounded:
        raise InputError(problem.source or "problem", "S",
                         "is unbounded (a recession direction exists, e.g. a wedged contact); "
                         "refusing to sample")
    params = {"seed": int(seed), "tol": float(tol), "kick": "uniform +-<Fn> on fn and ft",
              "kick_scale": problem.force_scale, "stall": "exact projection onto S"}
    ens = ef.existing(out, problem, "relax", params)
    if ens is None:
        x0 = problem.x_jammed if start is None else np.asarray(start, float)
        x, res, projected = relaxer.relax(x0, tol, chunk, max_sweeps, seed)
        rng = np.random.default_rng(seed)
        ef.create(out, problem, "relax", params, packing_file, scene_name, scene_text,
                  setup={"x_start": x},
                  setup_describe={"x_start": ("F0", "jammed network relaxed to tol (walk start)")},
                  checkpoint={"x": x, "projected": np.zeros(0, np.int64)},
                  checkpoint_attrs={"rng_state": json.dumps(rng.bit_generator.state),
                                    "n_done": 0, "sweeps_total": int(res.sweeps),
                                    "n_projected": 0, "start_projected": int(projected)},
                  tolerance_description=f"every sample has max violation <= {tol} relative to "
                                        f"<Fn> (checked after relaxation)")
        ens = ef.read(out)
    x = ens.checkpoint["x"].copy()
    rng = np.random.default_rng()
    try:
        rng.bit_generator.state = json.loads(ens.checkpoint_attrs["rng_state"])
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(out, "checkpoint/rng_state", f"unreadable ({exc}); the checkpoint is "
                         "corrupt: delete the file to restart") from None
    sweeps_total = int(ens.checkpoint_attrs.get("sweeps_total", 0))
    projected_idx = [int(i) for i in ens.checkpoint.get("projected", [])]
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=n, initial=min(ens.n_samples, n), desc="relax", unit="sample",
                   file=sys.stderr)

    def state(n_total):
        return ({"x": x, "projected": np.array(projected_idx, np.int64)},
                {"rng_state": json.dumps(rng.bit_generator.state), "n_done": n_total,
                 "sweeps_total": int(sweeps_total), "n_projected": len(projected_idx)})

    try:
        with ef.SampleWriter(out, ens.n_samples, checkpoint_every, state, max_seconds,
                             t0) as writer:
            while writer.n_total < n:
                i = writer.n_total
                xk = kick(x, problem.mu, problem.force_scale, rng)
                xn, res, projected = relaxer.relax(xk, tol, chunk, max_sweeps, seed + 1 + i)
                v_check = problem.violation(xn)
                if not v_check <= tol:
                    raise NumericalError(f"relax sample {i} violates S by {v_check:.3e} x "
                                         f"<Fn> ({res.message})")
                x = xn
                sweeps_total += res.sweeps
                if projected:
                    projected_idx.append(i)
                if bar is not None:
                    bar.update(1)
                    bar.set_postfix(sweeps=res.sweeps, projected=len(projected_idx),
                                    refresh=False)
                if writer.add(x, 0, v_check):
                    break
    finally:
        if bar is not None:
            bar.close()
    ens = ef.read(out)
    return {"n_samples": ens.n_samples, "wall_time_s": time.perf_counter() - t0,
            "max_violation": float(ens.violations.max(initial=0.0)),
            "sweeps_total": sweeps_total, "n_projected": len(projected_idx),
            "n_projected_l1": relaxer.n_l1,
            "projected_convention": "samples whose relaxation stalled (non-static fixed "
                                    "point) and were finished by the exact projection onto S",
            "params": params}


class RelaxWalk:
    """The paper's perturb-and-relax walk through S (compute object; see :func:`sample`).

    ``RelaxWalk(n=100, seed=1).run(problem)`` returns the samples as an
    :class:`~forcespace.ensemble_file.Ensemble` in memory; ``output=PATH``
    writes (and resumes) an ensemble file instead.
    """

    def __init__(self, n: int = 100, seed: int = 0, tol: float = DEFAULT_TOL,
                 progress: bool = False):
        check_options(n, tol)
        self.n, self.seed, self.tol, self.progress = n, seed, tol, progress
        self.summary: dict = {}

    def run(self, problem: StaticsProblem, output=None,
            max_seconds: float | None = None) -> "ef.Ensemble":
        """Walk through ``problem``'s S; stops early (fewer than n samples, all kept)
        after ``max_seconds``. The run's numbers are in ``self.summary``."""
        from .h5io import MemoryFile
        out = MemoryFile("<relax>") if output is None else output
        self.summary = sample(problem, self.n, out, seed=self.seed, tol=self.tol,
                              progress=self.progress, max_seconds=max_seconds)
        return ef.read(out)

    def __repr__(self) -> str:
        return f"RelaxWalk(n={self.n}, seed={self.seed}, tol={self.tol:g})"
