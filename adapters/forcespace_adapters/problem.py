"""The boundary-value problem a soft-particle code is asked to solve.

A :class:`SoftProblem` is a rigid packing reduced to what a DEM code needs:
which disks move, the fixed loads on them, and which plates remain walls.

* Full packing: every disk moves; the BOTTOM plate stays a wall (fixed,
  friction ``plate_mu``); gravity becomes a per-disk load ``-m g e_y``. The
  TOP plate, with ``top="plate"`` (default), stays a load-controlled plate
  (moves vertically only, total downward force ``top_force``); with
  ``top="loads"`` it is replaced by the forces its contacts carry in the
  rigid state, applied to the disks as fixed (dead) loads. Dead loads keep
  the rigid state an equilibrium but not a stable one: a column of disks
  under the plate can buckle once the plate no longer ties it to its
  neighbours (seen on a 20-disk engine packing: LIGGGHTS and pymunk both
  rearrange), so the plate is the default.
* Rattlers (``Packing.rattlers()``, the convention forcespace's statics uses
  to build S) are left out by default: they do not move, carry no force and
  their contacts are dropped (a rattler that a soft code lets wander would
  wedge itself into its cage and carry force on contacts S does not have).
* Slice (``y_range=(y0, y1)``): disks whose centres lie in the range move;
  every contact between an interior disk and anything else (outside disk or
  plate) becomes a fixed load with its torque ``-r*ft`` (frictional loads);
  no walls remain.

Sign conventions are those of :mod:`forcespace.model.packing`. Loads are forces
on the disks [F0], torques [F0 R] (counter-clockwise positive).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from forcespace.errors import InputError
from forcespace.extend import LEFT, RIGHT, TOP
from forcespace import Packing


def check_options(options, checks, source="options") -> None:
    """Raise InputError for the first failing ``(field, ok, allowed)`` check, or a value
    that is not a finite number (an integer where the field's default is one)."""
    import math
    import numbers

    for name, ok, allowed in checks:
        value = getattr(options, name)
        integral = isinstance(type(options).__dataclass_fields__[name].default, int)
        kind = numbers.Integral if integral else numbers.Real
        try:
            number = isinstance(value, kind) and not isinstance(value, bool) \
                and math.isfinite(float(value))
        except OverflowError:           # an integer beyond any float
            number = False
        if not (number and ok):
            what = "an integer" if integral else "a number"
            raise InputError(source, name, f"must be {what} {allowed}", got=value)


@dataclass
class SoftProblem:
    """Disks to simulate, their fixed loads and the remaining walls.

    ``active`` (n,) bool: disks that move; ``load`` (n, 2) [F0] and
    ``torque`` (n,) [F0 R]: fixed external load on each disk (zero for
    inactive disks); ``bottom_wall``: y of the fixed lower plate surface or
    None; ``wall_mu``: friction of that plate; ``mu``: disk-disk friction;
    ``internal`` (Nc,) bool: rigid contacts that remain unknowns (between
    active disks, or active disk and a kept wall); ``top_load`` (n,): the
    part of ``load`` that replaces the TOP plate (full packing only).
    """

    packing: Packing
    active: np.ndarray
    load: np.ndarray
    torque: np.ndarray
    bottom_wall: float | None
    wall_mu: float
    mu: float
    internal: np.ndarray
    description: str = "full"
    top_load: np.ndarray | None = None   # (n,) normal force of each disk's TOP contact [F0]
    top_plate: tuple | None = None       # (y_top [R], top_force [F0], plate_mu) for top="plate"

    @property
    def frictional_loads(self) -> bool:
        """True when some load has a torque (tangential boundary force)."""
        scale = max(np.abs(self.load).max(initial=0.0), 1e-300)
        return bool(np.abs(self.torque).max(initial=0.0) > 1e-12 * scale)

    @property
    def force_scale(self) -> float:
        """Mean normal force of the rigid state over force-bearing contacts [F0]."""
        s = self.packing.mean_normal_force()
        return s if s > 0 else 1.0

    def rigid_residual(self) -> float:
        """Largest imbalance of an active disk under the rigid internal forces and the loads.

        Relative to :attr:`force_scale` (torques divided by r). Zero (to
        round-off) when the rigid state is admissible: the exported problem
        balances.
        """
        return self.residual(self.packing.fn, self.packing.ft)

    def residual(self, fn, ft) -> float:
        """Same as :meth:`rigid_residual` for forces ``fn, ft`` (Nc,) on the rigid contacts."""
        p = self.packing
        fn = np.where(self.internal, fn, 0.0)
        ft = np.where(self.internal, ft, 0.0)
        F = fn[:, None] * p.normal + ft[:, None] * p.tangent
        force = self.load.copy()
        torque = self.torque.copy()
        ma, mb = p.a >= 0, p.b >= 0
        np.add.at(force, p.b[mb], F[mb])
        np.add.at(force, p.a[ma], -F[ma])
        np.add.at(torque, p.b[mb], -p.r[p.b[mb]] * ft[mb])
        np.add.at(torque, p.a[ma], -p.r[p.a[ma]] * ft[ma])
        act = self.active
        res = max(np.abs(force[act]).max(initial=0.0),
                  (np.abs(torque[act]) / p.r[act]).max(initial=0.0))
        if self.top_plate is not None:
            top = (p.b == TOP) & self.internal
            res = max(res, abs(F[top, 1].sum() - self.top_plate[1]))
        return float(res / self.force_scale)


def soft_problem(packing: Packing, y_range=None, exclude_rattlers: bool = True,
                 top: str = "plate", source="packing") -> SoftProblem:
    """Build the :class:`SoftProblem` of a full packing (default) or of a slice."""
    p = packing
    n = p.n_disks
    if ((p.a == LEFT) | (p.b == RIGHT) | (p.a == RIGHT) | (p.b == LEFT)).any():
        raise InputError(source, "contacts", "side walls (LEFT/RIGHT) are not supported by "
                         "the DEM adapters; use a packing periodic in x")
    F = p.contact_forces()
    load = p.external_forces()
    torque = np.zeros(n)
    keep = ~p.rattlers() if exclude_rattlers else np.ones(n, dtype=bool)
    # contacts touching an excluded rattler are dropped entirely
    alive = ((p.a < 0) | keep[np.maximum(p.a, 0)]) & ((p.b < 0) | keep[np.maximum(p.b, 0)])
    if y_range is None:
        active = keep.copy()
        if not np.isfinite(p.y_bottom):
            raise InputError(source, "box.y_bottom", "a full packing needs a bottom plate")
        if top not in ("plate", "loads"):
            raise InputError(source, "top", "must be 'plate' or 'loads'", got=top)
        if top == "plate":
            if not np.isfinite(p.y_top):
                raise InputError(source, "box.y_top", "top='plate' needs a top plate")
            load[~active] = 0.0
            return SoftProblem(p, active, load, torque, float(p.y_bottom), float(p.plate_mu),
                               float(p.mu), alive.copy(), "full, load-controlled top plate",
                               None, (float(p.y_top), float(p.top_force), float(p.plate_mu)))
        ctop = (p.b == TOP) & alive
        np.add.at(load, p.a[ctop], -F[ctop])
        np.add.at(torque, p.a[ctop], -p.r[p.a[ctop]] * p.ft[ctop])
        internal = ~(p.b == TOP) & alive
        load[~active] = 0.0
        top_load = np.zeros(n)
        np.add.at(top_load, p.a[ctop], p.fn[ctop])
        return SoftProblem(p, active, load, torque, float(p.y_bottom), float(p.plate_mu),
                           float(p.mu), internal, "full, top plate as dead loads", top_load)
    y0, y1 = map(float, y_range)
    if not y1 > y0:
        raise InputError(source, "y_range", "must be (y0, y1) with y1 > y0", got=y_range)
    active = (p.y >= y0) & (p.y <= y1) & keep
    if not active.any():
        raise InputError(source, "y_range", "contains no disk centre", got=y_range)
    act_a = (p.a >= 0) & active[np.maximum(p.a, 0)]
    act_b = (p.b >= 0) & active[np.maximum(p.b, 0)]
    internal = act_a & act_b
    # boundary contacts: exactly one side active -> fixed load on that disk
    on_b = act_b & ~act_a & alive
    on_a = act_a & ~act_b & alive
    np.add.at(load, p.b[on_b], F[on_b])
    np.add.at(torque, p.b[on_b], -p.r[p.b[on_b]] * p.ft[on_b])
    np.add.at(load, p.a[on_a], -F[on_a])
    np.add.at(torque, p.a[on_a], -p.r[p.a[on_a]] * p.ft[on_a])
    load[~active] = 0.0
    torque[~active] = 0.0
    return SoftProblem(p, active, load, torque, None, float(p.plate_mu), float(p.mu),
                       internal, f"slice y in [{y0:g}, {y1:g}]")
