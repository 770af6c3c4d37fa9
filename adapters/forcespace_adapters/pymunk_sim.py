"""pymunk 7 adapter: solve a packing's boundary-value problem with Chipmunk's rigid-body solver.

pymunk (Chipmunk) is a 2-D physics engine: it takes disk packings only. A sphere packing
(``box.dimension = 3``) is cross-validated with LIGGGHTS' 3-D deck
(:mod:`forcespace_adapters.liggghts3d`); ``forcespace export pymunk`` refuses it in one line.

Mapping (units are forcespace's: lengths R, forces F0, density rho):

* every active disk -> dynamic body, mass rho*pi*r^2, moment m r^2/2, a
  Circle shape; disk-disk friction mu (each circle gets sqrt(mu), pymunk
  multiplies the two values); elasticity 0.
* the BOTTOM plate (full packing) -> static segment at y_bottom; its friction
  with the disks is set per arbiter in a pre-solve callback (= plate_mu).
* fixed loads and torques (top-plate forces, gravity, slice boundary forces)
  -> ``body.force``/``body.torque`` re-applied before every step (pymunk
  resets them after each step); they ramp in linearly over ``ramp_steps``.
* periodic x (pymunk has none): every disk within ``twin_margin`` of the left
  edge gets a dynamic twin at x + width, tied to it inside the solver by two
  pivot joints to a helper body of infinite moment (fixes the offset) and a
  gear joint (equal rotation). Shape filters let twins touch real disks only
  (not twins, not the floor), so every cross-boundary contact is seen once.
* contact forces = ``arbiter.total_impulse / dt`` after a step; a contact
  with a twin is a contact with image +1.

Run until the largest per-disk residual sqrt(F^2 + (T/r)^2) (loads plus
contact forces on a disk and its twin) is below ``tolerance * <Fn>`` or
``max_steps`` is reached.
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, replace

import numpy as np
import pymunk

from forcespace.errors import InputError
from forcespace.extend import BOTTOM, TOP
from forcespace import Packing

from .problem import SoftProblem, check_options

REAL, TWIN, FLOOR, PLATE = 0b0001, 0b0010, 0b0100, 0b1000
DISK_TYPE, FLOOR_TYPE, PLATE_TYPE = 1, 2, 3


@dataclass
class PymunkOptions:
    """Parameters of a pymunk run.

    dt: time step in units of t0 = sqrt(m_min R / <Fn>) (the time a mean
    contact force needs to move the lightest disk by R, roughly); iterations:
    solver iterations per step; damping: fraction of velocity kept per t0;
    slop: allowed overlap [R] before position correction; bias: fraction of
    overlap left uncorrected after t0; tolerance: stop when the largest
    per-disk residual < tolerance * <Fn>; ramp_steps, check_every, max_steps
    in steps; twin_margin [R] beyond 2*r_max for twin creation.
    """

    dt: float = 0.01
    iterations: int = 30
    damping: float = 0.1
    slop: float = 1e-5
    bias: float = 1e-3
    tolerance: float = 1e-6
    ramp_steps: int = 200
    check_every: int = 50
    max_steps: int = 50_000
    twin_margin: float = 2.0

    def validate(self, source="options"):
        big = 10 ** 12       # steps: beyond any run (pymunk does ~1e4 steps/s)
        checks = [("dt", 0 < self.dt <= 1e3, "in (0, 1e3] t0"),
                  ("iterations", 1 <= self.iterations <= 2 ** 31 - 1,
                   "in [1, 2**31 - 1] (a C int of pymunk)"),
                  ("damping", 0 < self.damping <= 1, "in (0, 1]"),
                  ("slop", 0 <= self.slop <= 1, "in [0, 1] R"),
                  ("bias", 0 < self.bias < 1, "in (0, 1)"),
                  ("tolerance", 0 < self.tolerance < 1, "in (0, 1) <Fn> (a residual of "
                   "<Fn> or more is no static state)"),
                  ("ramp_steps", 1 <= self.ramp_steps <= big, f"in [1, {big:.0e}]"),
                  ("check_every", 1 <= self.check_every <= big, f"in [1, {big:.0e}]"),
                  ("max_steps", 1 <= self.max_steps <= big, f"in [1, {big:.0e}]"),
                  ("twin_margin", 0 <= self.twin_margin <= 1e3, "in [0, 1e3] R")]
        check_options(self, checks, source)


class PymunkScene:
    """The pymunk space of a :class:`SoftProblem` plus the maps back to disk indices."""

    def __init__(self, problem: SoftProblem, options: PymunkOptions | None = None,
                 source="packing"):
        opt = options or PymunkOptions()
        opt.validate()
        self.problem, self.opt = problem, opt
        p = problem.packing
        self.p = p
        scale = problem.force_scale
        self.t0 = float(np.sqrt(p.mass.min() * 1.0 / scale))
        self.dt = opt.dt * self.t0
        space = pymunk.Space()
        space.iterations = int(opt.iterations)
        space.damping = float(opt.damping ** (1.0 / self.t0))
        space.collision_slop = float(opt.slop)
        space.collision_bias = float(opt.bias ** (1.0 / self.t0))
        space.gravity = (0.0, 0.0)
        self.space = space
        W = float(p.width)
        self.W = W
        mu = float(problem.mu)
        fr = float(np.sqrt(mu))
        self.disks = np.flatnonzero(problem.active)
        self.body = {}
        self.shape_owner = {}            # shape -> (disk index, image)
        m = p.mass
        x0 = np.mod(p.x, W) if p.periodic_x else p.x.copy()
        for i in self.disks:
            b = pymunk.Body(float(m[i]), float(0.5 * m[i] * p.r[i] ** 2))
            b.position = (float(x0[i]), float(p.y[i]))
            s = pymunk.Circle(b, float(p.r[i]))
            s.friction = fr
            s.elasticity = 0.0
            s.collision_type = DISK_TYPE
            s.filter = pymunk.ShapeFilter(categories=REAL, mask=REAL | TWIN | FLOOR | PLATE)
            space.add(b, s)
            self.body[i] = b
            self.shape_owner[s] = (int(i), 0)
        self.twins = {}
        if p.periodic_x:
            lim = 2.0 * float(p.r.max()) + opt.twin_margin
            if W < 2 * lim:
                raise InputError(source, "box.width", f"too narrow for twin bodies (need > {2 * lim:g} R)",
                                 got=W)
            for i in self.disks:
                if x0[i] < lim:
                    ob = self.body[i]
                    tb = pymunk.Body(ob.mass, ob.moment)
                    tb.position = (ob.position.x + W, ob.position.y)
                    ts = pymunk.Circle(tb, float(p.r[i]))
                    ts.friction = fr
                    ts.elasticity = 0.0
                    ts.collision_type = DISK_TYPE
                    ts.filter = pymunk.ShapeFilter(categories=TWIN, mask=REAL)
                    hb = pymunk.Body(ob.mass, float("inf"))
                    hb.position = ob.position
                    j1 = pymunk.PivotJoint(ob, hb, (0, 0), (0, 0))
                    j2 = pymunk.PivotJoint(tb, hb, (0, 0), (W, 0))
                    g = pymunk.GearJoint(ob, tb, 0.0, 1.0)
                    for c in (j1, j2, g):
                        c.collide_bodies = False
                    space.add(tb, ts, hb, j1, j2, g)
                    self.twins[int(i)] = tb
                    self.shape_owner[ts] = (int(i), 1)
        self.floor = None
        if problem.bottom_wall is not None:
            xlo = -4.0 * float(p.r.max())
            xhi = W + 4.0 * float(p.r.max()) + lim if p.periodic_x else W
            fl = pymunk.Segment(space.static_body, (xlo, problem.bottom_wall),
                                (xhi, problem.bottom_wall), 0.0)
            fl.friction = 0.0
            fl.collision_type = FLOOR_TYPE
            fl.filter = pymunk.ShapeFilter(categories=FLOOR, mask=REAL)
            space.add(fl)
            self.floor = fl
            wall_mu = float(problem.wall_mu)

            def _pre(arb, _space, _data):
                arb.friction = wall_mu
            space.on_collision(DISK_TYPE, FLOOR_TYPE, pre_solve=_pre)
        self.plate = None
        self.plate_shape = None
        if problem.top_plate is not None:
            y_top, T, pmu = problem.top_plate
            self.plate_force = float(T)
            pb = pymunk.Body(float(5.0 * m[self.disks].mean()), float("inf"))
            pb.position = (0.5 * W, y_top)
            half = 0.5 * W + 4.0 * float(p.r.max()) + (lim if p.periodic_x else 0.0)
            ps = pymunk.Segment(pb, (-half, 0.0), (half, 0.0), 0.0)
            ps.friction = 0.0
            ps.collision_type = PLATE_TYPE
            ps.filter = pymunk.ShapeFilter(categories=PLATE, mask=REAL)

            def _vertical(body, gravity, damping, dt):
                pymunk.Body.update_velocity(body, gravity, damping, dt)
                body.velocity = (0.0, body.velocity.y)
            pb.velocity_func = _vertical
            space.add(pb, ps)
            self.plate, self.plate_shape = pb, ps
            plate_mu = float(pmu)

            def _pre_plate(arb, _space, _data):
                arb.friction = plate_mu
            space.on_collision(DISK_TYPE, PLATE_TYPE, pre_solve=_pre_plate)
        self.steps = 0
        self.scale = scale

    # ------------------------------------------------------------------
    def apply_loads(self, ramp: float = 1.0):
        """Set the fixed loads (times ``ramp``) on the bodies; pymunk clears them every step."""
        prob = self.problem
        for i in self.disks:
            b = self.body[i]
            b.force = (ramp * prob.load[i, 0], ramp * prob.load[i, 1])
            b.torque = ramp * prob.torque[i]
        if self.plate is not None:
            self.plate.force = (0.0, -ramp * self.plate_force)

    def step(self, n: int, ramp: float | None = None):
        """Advance ``n`` steps, re-applying the loads (times ``ramp`` in [0, 1], default 1)."""
        for _ in range(n):
            self.apply_loads(1.0 if ramp is None else ramp)
            self.space.step(self.dt)
            self.steps += 1

    def contacts(self):
        """Current contacts: list of (a, b, image_of_b, force_on_b (2,), point_a (2,), point_b (2,)).

        Disk pairs: a real, b real or twin (image +1 relative to a); wall
        contacts have a = BOTTOM. Points are where the solver applies the
        impulse on each body (b's point in b's image frame).
        """
        seen = set()
        out = []
        dt = self.dt

        def visit(arb):
            sa, sb = arb.shapes
            key = (id(sa), id(sb)) if id(sa) < id(sb) else (id(sb), id(sa))
            if key in seen:
                return
            seen.add(key)
            J = arb.total_impulse
            # each_arbiter puts the visited body's shape first; total_impulse acts on it
            Fb = -np.array([J.x, J.y]) / dt      # force on shape b
            pts = arb.contact_point_set.points
            if not pts:
                return
            pa, pb = np.array(pts[0].point_a), np.array(pts[0].point_b)
            if sb is self.floor:
                out.append((BOTTOM, self.shape_owner[sa][0], 0, -Fb, pb, pa))
                return
            if sb is self.plate_shape:
                out.append((self.shape_owner[sa][0], TOP, 0, Fb, pa, pb))
                return
            (ia, ima), (ib, imb) = self.shape_owner[sa], self.shape_owner[sb]
            if ima:                               # a is a twin: shift everything by -W
                shift = np.array([self.W, 0.0])
                pa, pb = pa - shift, pb - shift
            out.append((ia, ib, imb - ima, Fb, pa, pb))

        for i in self.disks:
            self.body[i].each_arbiter(visit)
            if i in self.twins:
                self.twins[i].each_arbiter(visit)
        return out

    def residual(self):
        """Net force (n, 2) and torque (n,) on every active disk (plus its twin) [F0, F0 R]."""
        force = self.problem.load.copy()
        torque = self.problem.torque.copy()
        self._plate_residual = -self.plate_force if self.plate is not None else 0.0
        for a, b, image, F, pa, pb in self.contacts():
            if b >= 0:
                cb = self._centre(b, image)
                force[b] += F
                lb = pb - cb
                torque[b] += lb[0] * F[1] - lb[1] * F[0]
            else:
                self._plate_residual += F[1]
            if a >= 0:
                ca = self._centre(a)
                force[a] -= F
                la = pa - ca
                torque[a] -= la[0] * F[1] - la[1] * F[0]
        return force, torque

    def _centre(self, i, image=0):
        pos = self.body[i].position
        return np.array([pos.x + image * self.W, pos.y])

    def max_residual(self) -> float:
        """Largest sqrt(F^2 + (T/r)^2) over active disks, relative to <Fn>."""
        f, t = self.residual()
        d = self.disks
        res = np.sqrt((f[d] ** 2).sum(1) + (t[d] / self.p.r[d]) ** 2)
        return float(max(res.max(initial=0.0), abs(self._plate_residual)) / self.scale)

    # ------------------------------------------------------------------
    def ramp(self):
        """Raise the loads linearly from 0 to 1 over ``ramp_steps`` steps."""
        for k in range(self.opt.ramp_steps):
            self.step(1, (k + 1) / self.opt.ramp_steps)

    def run(self, progress=None) -> dict:
        """Ramp the loads in, then step until settled. Returns run statistics."""
        opt = self.opt
        t = time.perf_counter()
        self.ramp()
        converged = False
        res = float("inf")
        while self.steps < opt.max_steps:
            self.step(opt.check_every)
            res = self.max_residual()
            if progress:
                progress(self.steps, res)
            if res < opt.tolerance:
                converged = True
                break
        return {"converged": converged, "steps": self.steps, "max_residual_rel": res,
                "wall_time_s": time.perf_counter() - t}

    def soft_packing(self, info: dict | None = None) -> Packing:
        """The current state as a soft-network :class:`Packing` (same schema).

        Disk pairs: a = first shape's disk, b = second's, image from twins;
        normal from the centres; fn, ft of the force on b in that frame;
        gap = distance - r_a - r_b. BOTTOM contacts a = BOTTOM. Full packing:
        the top loads appear as TOP contacts carrying the imposed forces.
        Inactive disks keep their rigid positions and have no contacts.
        """
        p, prob = self.p, self.problem
        x, y = p.x.copy(), p.y.copy()
        for i in self.disks:
            x[i], y[i] = self.body[i].position
        A, B, IMG, FN, FT = [], [], [], [], []
        for a, b, image, F, _pa, _pb in self.contacts():
            if a == BOTTOM or b == TOP:
                nv, image = np.array([0.0, 1.0]), 0
            else:
                d = np.array([x[b] + image * self.W - x[a], y[b] - y[a]])
                nv = d / float(np.hypot(*d))
            A.append(a); B.append(b); IMG.append(image)
            FN.append(F @ nv); FT.append(F @ np.array([-nv[1], nv[0]]))
        if prob.top_load is not None:
            for i in np.flatnonzero(prob.top_load != 0.0):
                A.append(int(i)); B.append(TOP); IMG.append(0)
                FN.append(prob.top_load[i]); FT.append(0.0)
        meta = {"code": "pymunk", **{k: v for k, v in asdict(self.opt).items()},
                "dt_abs": self.dt, "t0": self.t0, "problem": prob.description,
                "force_scale": prob.force_scale,
                "packing_fingerprint": prob.packing.fingerprint, **(info or {})}
        if self.plate is not None:
            y_top = self.plate.position.y
        else:
            y_top = p.y_top if prob.top_load is not None else np.nan
        has_top = prob.top_load is not None or self.plate is not None
        # normals, contact points and gaps from the soft centres and plate positions; the
        # forces are the ones measured in that geometry (fn, ft on b)
        soft = Packing.from_arrays(
            x, y, p.r, np.array(A, dtype=np.int64), np.array(B, dtype=np.int64),
            np.array(FN, float), np.array(FT, float), width=p.width, periodic_x=p.periodic_x,
            image=np.array(IMG, dtype=np.int64), y_bottom=p.y_bottom, y_top=y_top,
            top_force=p.top_force if has_top else 0.0, gravity=p.gravity, density=p.density,
            mu=p.mu, plate_mu=p.plate_mu, scene_name=p.scene_name)
        return replace(soft, seed=p.seed, scene_text=p.scene_text, meta=meta)


def simulate(problem: SoftProblem, options: PymunkOptions | None = None, progress=None):
    """Build the scene, run it; returns (soft Packing, run info dict)."""
    scene = PymunkScene(problem, options)
    info = scene.run(progress)
    return scene.soft_packing(info), info
