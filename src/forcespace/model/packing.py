"""A jammed packing: disks, box, contact network and contact forces.

Conventions (used everywhere in forcespace)
-------------------------------------------
* Units: lengths in R (the smallest radius of the scene's radius range),
  masses in rho*R^2 (2-D density rho, disk mass = density*pi*r^2),
  forces in the scene's force unit F0 (the top-plate load is given in F0).
* Bodies: disks are 0..n-1. Walls have negative codes: ``BOTTOM`` (fixed
  lower plate), ``TOP`` (load-controlled upper plate, vertical motion only),
  ``LEFT`` and ``RIGHT`` (side walls, only when x is not periodic).
* A contact k joins body ``a[k]`` and body ``b[k]``; ``normal[k]`` is the
  unit vector from a to b; the force ``fn*n + ft*t`` acts on b and its
  negative on a, with t = (-n_y, n_x) (n turned by +90 degrees).
  ``fn > 0`` is compression. For a disk the torque of contact k is
  ``-r*ft`` on b and ``-r*ft`` on a (both bodies turn the same way).
* Periodic x: b's centre is taken at ``x_b + image*width``.
* Wall contacts: BOTTOM is always ``a`` (n = (0, 1)), TOP is always ``b``
  (n = (0, 1)), LEFT is ``a`` (n = (1, 0)), RIGHT is ``b`` (n = (1, 0)); WALL (a
  measured frame's wall, any normal) is always ``a``, its normal points into the disk.
* Body forces: gravity (``gravity``, along -y) plus, for measured packings, any
  per-disk external force and torque (``external`` (n, 3): fx, fy [F0], torque [F0 R]).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .. import config
from ..errors import InputError
from .measurement import Measurement, check_measurement
from .setup import Setup
from .walls import (BOTTOM, LEFT, RIGHT, TOP, WALL, WALL_NAMES,  # noqa: F401 (re-exported)
                    contact_mu_array)


@dataclass
class Packing:
    """A static packing with its contact network and one admissible force state.

    Arrays: x, y, r of shape (n,) [R]; a, b, image of shape (Nc,) int;
    normal, point of shape (Nc, 2); gap, fn, ft of shape (Nc,) [R], [F0], [F0].
    """

    x: np.ndarray
    y: np.ndarray
    r: np.ndarray
    width: float
    periodic_x: bool
    y_bottom: float          # top surface of the lower plate [R] (nan: no plate)
    y_top: float             # bottom surface of the upper plate [R] (nan: no plate)
    top_force: float         # downward load on the upper plate [F0]
    gravity: float           # acceleration along -y [F0/(rho R^3)]
    density: float | np.ndarray  # 2-D density [rho], uniform or per disk (n,)
    mu: float                # disk-disk Coulomb friction
    plate_mu: float          # disk-wall Coulomb friction
    a: np.ndarray
    b: np.ndarray
    normal: np.ndarray
    point: np.ndarray
    image: np.ndarray
    gap: np.ndarray
    fn: np.ndarray
    ft: np.ndarray
    seed: int = 0
    scene_text: str = ""
    scene_name: str = ""
    meta: dict = field(default_factory=dict)
    solver_log: np.ndarray | None = None  # (k, 5): step, max |v|, |v_top|, sweeps/step, rel. change
    # the file it was read from ("" if built in memory): problems built from it name it as
    # their source, so ensembles record the packing file they sample
    source: str = field(default="", compare=False, repr=False)
    # the scene that made it as records (the engine's, or read from scene_text by
    # io.packing_file); None for packings from elsewhere (from_arrays, other formats)
    setup: Setup | None = field(default=None, compare=False, repr=False)
    # per-disk external force and torque besides gravity, (n, 3): fx, fy [F0], torque
    # [F0 R] (None: none); measured data: which forces are data, their uncertainty and
    # provenance (None: the engine made every force)
    external: np.ndarray | None = field(default=None, compare=False, repr=False)
    measurement: Measurement | None = field(default=None, compare=False, repr=False)

    # ---- construction, files, figures ----------------------------------------
    @classmethod
    def from_arrays(cls, x, y, r, a, b, fn=None, ft=None, *, width=None, periodic_x=False,
                    image=None, y_bottom=np.nan, y_top=np.nan, top_force=0.0, gravity=0.0,
                    density=1.0, mu=0.0, plate_mu=0.0, scene_name="", wall_normal=None,
                    external=None, measurement=None) -> "Packing":
        """A packing from positions, radii and a contact list; geometry derived.

        x, y, r (n,) [R]; a, b (Nc,) body indices (disks >= 0, walls BOTTOM,
        TOP, LEFT, RIGHT, WALL with the wall conventions of the module docstring);
        fn, ft (Nc,) [F0] (default 0). Normals, contact points and gaps come
        from the geometry (periodic x: b at x_b + image*width, image default
        the minimum image). Without ``width`` a non-periodic box spans the disks.
        ``wall_normal`` (Nc, 2): the unit normal of each WALL contact (from the wall
        into the disk; other rows ignored); its contact point is the disk's surface
        point facing the wall, its gap 0. ``external`` (n, 3), ``measurement``: as the
        fields.
        """
        x, y, r = (np.asarray(v, float).copy() for v in (x, y, r))
        if wall_normal is not None:
            wall_normal = np.asarray(wall_normal, float)
        a = np.asarray(a, np.int64).copy()
        b = np.asarray(b, np.int64).copy()
        nc = a.shape[0]
        if width is None:
            if periodic_x:
                raise InputError("from_arrays", "width", "is needed with periodic_x")
            width = float((x + r).max() - min(0.0, (x - r).min()))
        img = np.zeros(nc, np.int64) if image is None else np.asarray(image, np.int64).copy()
        normal = np.zeros((nc, 2))
        gap = np.zeros(nc)
        point = np.zeros((nc, 2))
        for k in range(nc):
            i, j = int(a[k]), int(b[k])
            if i >= 0 and j >= 0:
                dx = x[j] - x[i]
                if periodic_x and image is None:
                    img[k] = -int(np.floor(dx / width + 0.5))
                dx += img[k] * width
                dist = np.hypot(dx, y[j] - y[i])
                normal[k] = dx / dist, (y[j] - y[i]) / dist
                gap[k] = dist - r[i] - r[j]
                point[k] = (x[i], y[i]) + (r[i] + 0.5 * gap[k]) * normal[k]
            elif i == WALL:
                if j < 0 or wall_normal is None:
                    raise InputError("from_arrays", "wall_normal", f"contact {k}: a WALL "
                                     "contact needs a disk as body b and its normal", got=(i, j))
                normal[k] = wall_normal[k]
                point[k] = (x[j], y[j]) - r[j] * normal[k]
            else:
                disk = j if i < 0 else i
                wall = i if i < 0 else j
                if (wall, disk == j) not in ((BOTTOM, True), (TOP, False), (LEFT, True),
                                             (RIGHT, False)):
                    raise InputError("from_arrays", "a, b", f"contact {k}: BOTTOM and LEFT "
                                     "must be body a, TOP and RIGHT body b", got=(i, j))
                horizontal = wall in (BOTTOM, TOP)
                normal[k] = (0.0, 1.0) if horizontal else (1.0, 0.0)
                sign = -1.0 if wall in (BOTTOM, LEFT) else 1.0
                point[k] = (x[disk], y[disk]) + sign * r[disk] * normal[k]
                surface = {BOTTOM: y_bottom, TOP: y_top, LEFT: 0.0, RIGHT: width}[wall]
                coord = point[k, 1] if horizontal else point[k, 0]
                gap[k] = (coord - surface) * (-sign) if np.isfinite(surface) else 0.0
        zeros = np.zeros(nc)
        p = cls(x=x, y=y, r=r, width=float(width), periodic_x=bool(periodic_x),
                y_bottom=float(y_bottom), y_top=float(y_top), top_force=float(top_force),
                gravity=float(gravity), density=density, mu=float(mu), plate_mu=float(plate_mu),
                a=a, b=b, normal=normal, point=point, image=img, gap=gap,
                fn=zeros.copy() if fn is None else np.asarray(fn, float).copy(),
                ft=zeros.copy() if ft is None else np.asarray(ft, float).copy(),
                scene_name=scene_name, measurement=measurement,
                external=None if external is None else np.asarray(external, float).copy())
        return check_packing(p, "from_arrays")

    def plot(self, ax=None, values=None, signed: bool = False, **kw):
        """Draw the disks and the force network on ``ax`` (see
        :func:`forcespace.plot.plot_packing`); returns the Axes."""
        from ..plot import plot_packing
        return plot_packing(self, ax, values=values, signed=signed, **kw)

    def __repr__(self) -> str:
        walls = "periodic x" if self.periodic_x else "side walls"
        return (f"Packing(n_disks={self.n_disks}, n_contacts={self.n_contacts}, mu={self.mu:g}, "
                f"width={self.width:g} R, {walls}, scene={self.scene_name!r})")

    @property
    def scene_slice_height(self) -> float | None:
        """``[analysis] slice_height`` of the scene that made this packing [R], or None
        (absent, 0, or no readable scene stored)."""
        setup = self.setup or Setup.from_text(self.scene_text)
        if setup is None:   # no scene, or one that does not validate: no default
            return None
        return setup.slice_height if setup.slice_height > 0 else None

    # ---- derived quantities -------------------------------------------------
    @property
    def n_disks(self) -> int:
        return int(self.x.shape[0])

    @property
    def n_contacts(self) -> int:
        return int(self.a.shape[0])

    @property
    def mass(self) -> np.ndarray:
        """Disk masses, shape (n,) [rho R^2]."""
        return np.asarray(self.density, float) * np.pi * self.r**2

    @property
    def tangent(self) -> np.ndarray:
        """Unit tangents t = (-n_y, n_x), shape (Nc, 2)."""
        return np.stack([-self.normal[:, 1], self.normal[:, 0]], axis=1)

    def contact_forces(self) -> np.ndarray:
        """Force vectors on body b, shape (Nc, 2) [F0]."""
        return self.fn[:, None] * self.normal + self.ft[:, None] * self.tangent

    def external_forces(self) -> np.ndarray:
        """Body forces on the disks (gravity plus ``external``), shape (n, 2) [F0]."""
        f = np.zeros((self.n_disks, 2))
        if self.gravity != 0.0:
            f[:, 1] = -self.mass * self.gravity
        if self.external is not None:
            f += self.external[:, :2]
        return f

    def external_torques(self) -> np.ndarray:
        """External torques on the disks (from ``external``), shape (n,) [F0 R]."""
        if self.external is None:
            return np.zeros(self.n_disks)
        return np.asarray(self.external[:, 2], float).copy()

    def net_forces(self, fn=None, ft=None):
        """Net force (n, 2) and torque (n,) on every disk (contacts and body forces), and
        the net vertical force on TOP. Uses the packing's forces unless ``fn``/``ft`` are
        given (:func:`contact_sums`)."""
        fn = self.fn if fn is None else fn
        ft = self.ft if ft is None else ft
        force, torque = contact_sums(self, fn, ft, external=True)
        F = fn[:, None] * self.normal + ft[:, None] * self.tangent
        top = (self.b == TOP)
        plate = float(F[top, 1].sum() - self.top_force) if np.isfinite(self.y_top) else 0.0
        return force, torque, plate

    def mean_normal_force(self) -> float:
        """Mean normal force over force-bearing contacts [F0] (0 if none)."""
        carrying = self.fn > 0
        return float(self.fn[carrying].mean()) if carrying.any() else 0.0

    def equilibrium_residual(self, fn=None, ft=None) -> float:
        """Largest force/torque imbalance of any disk or the top plate.

        Force imbalances are divided by the mean normal force, torques by
        r_k times the mean normal force. Disks without contacts and without
        body forces (rattlers in zero gravity) are in equilibrium trivially.
        """
        force, torque, plate = self.net_forces(fn, ft)
        scale = self.mean_normal_force()
        if scale == 0.0:
            return 0.0 if not (np.abs(force).max(initial=0) > 0) else float("inf")
        res = max(np.abs(force).max(initial=0.0),
                  (np.abs(torque) / self.r).max(initial=0.0), abs(plate))
        return float(res / scale)

    def max_overlap(self) -> float:
        """Largest overlap (negative gap) among the contacts [R]; 0 if none."""
        return float(max(0.0, -self.gap.min(initial=0.0)))

    def force_bearing(self, rel_threshold: float | None = None) -> np.ndarray:
        """Mask (Nc,) of contacts whose normal force exceeds threshold * mean force
        (default ``config.FORCE_BEARING``)."""
        threshold = config.FORCE_BEARING if rel_threshold is None else rel_threshold
        return self.fn > threshold * max(self.mean_normal_force(), 1e-300)

    def rattlers(self, rel_threshold: float | None = None) -> np.ndarray:
        """Boolean mask (n,) of rattlers: disks that carry no load.

        Convention: a rattler has no force-bearing contact (fn above
        ``rel_threshold`` times the mean normal force), whatever its number
        of touching neighbours. A disk that bears load is never a rattler,
        even with 1 or 2 contacts (a disk in a groove under gravity).
        Measured packings whose data leave some contact forces unknown
        (``measurement.known``): a disk with no measured force-bearing contact is
        decided by geometry instead (:func:`geometric_rattlers`).
        """
        live = self.force_bearing(rel_threshold)
        carrying = np.zeros(self.n_disks, dtype=bool)
        carrying[self.a[live & (self.a >= 0)]] = True
        carrying[self.b[live & (self.b >= 0)]] = True
        m = self.measurement
        if m is None or np.all(m.known):
            return ~carrying
        return geometric_rattlers(self, carrying, ~np.asarray(m.known, bool))

    def coordination(self, rel_threshold: float | None = None) -> float:
        """z = 2 Nc / n over non-rattler disks, Nc = force-bearing contacts among them.

        Disk-wall contacts count as full contacts, so an isostatic frictionless
        packing gives z = 4 up to O(1/n) boundary terms.
        """
        rat = self.rattlers(rel_threshold)
        live = self.force_bearing(rel_threshold)
        keep_a = (self.a < 0) | ~rat[np.maximum(self.a, 0)]
        keep_b = (self.b < 0) | ~rat[np.maximum(self.b, 0)]
        nc = int((live & keep_a & keep_b).sum())
        n = int((~rat).sum())
        return 2.0 * nc / n if n else 0.0

    def branch_segments(self, values=None):
        """Segments (Nc, 2, 2) [R] from centre to centre (walls: to the contact point), and
        the values to draw on them (default fn). A segment crossing the periodic boundary
        runs from a's centre toward b's image."""
        p = self
        seg = np.empty((p.n_contacts, 2, 2))
        for k in range(p.n_contacts):
            a, b = p.a[k], p.b[k]
            pa = np.array([p.x[a], p.y[a]]) if a >= 0 else p.point[k]
            pb = np.array([p.x[b] + p.image[k] * p.width, p.y[b]]) if b >= 0 else p.point[k]
            if a < 0:
                pa = pb - (p.r[b]) * p.normal[k]
            if b < 0:
                pb = pa + (p.r[a]) * p.normal[k]
            seg[k] = pa, pb
        return seg, (p.fn if values is None else values)

    def contact_table(self) -> dict:
        """Per-contact columns (each (Nc,)): contact, a, b, image, fn, ft [F0], force |F|
        [F0], mobilisation |ft|/(mu fn), mu, gap [R], bearing (force-bearing, 0/1)."""
        nc = self.n_contacts
        mu = contact_mu_array(self.a, self.b, self.mu, self.plate_mu)
        cap = mu * self.fn
        with np.errstate(divide="ignore", invalid="ignore"):
            mob = np.where(self.ft == 0.0, 0.0,
                           np.where(cap > 0, np.abs(self.ft) / cap, np.nan))
        return {"contact": np.arange(nc), "a": self.a.copy(), "b": self.b.copy(),
                "image": self.image.copy(), "fn": self.fn.copy(), "ft": self.ft.copy(),
                "force": np.hypot(self.fn, self.ft), "mobilisation": mob, "mu": mu,
                "gap": self.gap.copy(), "bearing": self.force_bearing().astype(np.int64)}

    def with_forces(self, fn, ft) -> "Packing":
        """A copy carrying another force state on the same contact network."""
        return replace(self, fn=np.asarray(fn, float).copy(), ft=np.asarray(ft, float).copy(),
                       source="")

    def summary(self) -> dict:
        """The numbers `forcespace info --json` prints."""
        rat = self.rattlers()
        return {
            "n_disks": self.n_disks,
            "n_contacts": self.n_contacts,
            "n_force_bearing": int(self.force_bearing().sum()),
            "z": self.coordination(),
            "z_convention": "2*Nc/n over non-rattlers, Nc force-bearing contacts "
                            f"(fn > {config.FORCE_BEARING:g} <Fn>), wall contacts count; "
                            "rattler: a disk with no force-bearing contact (carries no load)",
            "n_rattlers": int(rat.sum()),
            "mu": self.mu,
            "plate_mu": self.plate_mu,
            "seed": self.seed,
            "width": self.width,
            "height": float(self.y_top - self.y_bottom) if np.isfinite(self.y_top) else None,
            "packing_fraction": self.packing_fraction(),
            "mean_normal_force": self.mean_normal_force(),
            "equilibrium_residual": self.equilibrium_residual(),
            "max_overlap": self.max_overlap(),
            **{k: v for k, v in self.meta.items() if isinstance(v, (int, float, str, bool))},
            **({"measurement": self.measurement.summary()} if self.measurement is not None
               else {}),
            "units": SUMMARY_UNITS,
        }

    def packing_fraction(self) -> float | None:
        """Disk area over box area (between the plates), or None without both plates."""
        if not (np.isfinite(self.y_top) and np.isfinite(self.y_bottom)):
            return None
        return float(np.pi * (self.r**2).sum() / (self.width * (self.y_top - self.y_bottom)))

    @property
    def fingerprint(self) -> str:
        """Hash (32 hex digits) of the geometry: disks (x, y, r) and box (width, periodic
        x, plates), to 1e-9 R (blind to round-off). A soft network records the fingerprint
        of the packing it was made from (``meta["packing_fingerprint"]``)."""
        import hashlib

        h = hashlib.sha256()
        for v in (self.x, self.y, self.r, [self.width, float(self.periodic_x),
                                           self.y_bottom, self.y_top]):
            h.update((np.round(np.asarray(v, float), 9) + 0.0).tobytes())
        return h.hexdigest()[:32]


def contact_sums(p: Packing, fn, ft, contacts=None, external: bool = False):
    """The force (n, 2) [F0] and torque (n,) [F0 R] that contacts exert on the disks:
    contact k pushes ``fn n + ft t`` on body b and its negative on body a, and turns
    both by ``-r ft``. ``contacts``: a mask or indices of the contacts that count
    (default all); ``fn, ft`` (Nc,) [F0]; ``external``: start from the body forces
    (gravity and ``p.external``, torques included). THE force assembly of forcespace:
    body forces first, then the contacts one by one (b, then a), so every caller gets
    the same bits."""
    fn = np.asarray(fn, float)
    ft = np.asarray(ft, float)
    F = fn[:, None] * p.normal + ft[:, None] * p.tangent
    k = np.arange(p.n_contacts) if contacts is None else np.asarray(contacts)
    if k.dtype == bool:
        k = np.flatnonzero(k)
    body = np.column_stack([p.b[k], p.a[k]]).ravel()        # b then a, contact by contact
    push = np.stack([F[k], -F[k]], axis=1).reshape(-1, 2)
    turn = np.repeat(ft[k], 2)
    disk = body >= 0
    force = p.external_forces() if external else np.zeros((p.n_disks, 2))
    torque = p.external_torques() if external else np.zeros(p.n_disks)
    np.add.at(force, body[disk], push[disk])
    np.add.at(torque, body[disk], -p.r[body[disk]] * turn[disk])
    return force, torque


def geometric_rattlers(p: Packing, carrying, unknown) -> np.ndarray:
    """Rattlers (n,) bool of a packing whose contacts ``unknown`` (Nc,) have no measured
    force: a disk that ``carrying`` (n,) (a measured force-bearing contact) is never one;
    the others are pruned by geometry, repeatedly: a disk without body force (gravity,
    ``external``) with fewer than 2 contacts that may carry force (unknown ones, to a
    wall or to a disk not pruned) is a rattler. Exact: one contact alone cannot balance a
    disk, so its force is 0 in every admissible network (S is unchanged)."""
    loaded = carrying.copy()
    if p.gravity > 0:
        loaded[:] = True
    if p.external is not None:
        loaded |= np.any(np.asarray(p.external) != 0.0, axis=1)
    a, b = np.asarray(p.a), np.asarray(p.b)
    rattler = np.zeros(p.n_disks, dtype=bool)
    while True:
        live = unknown & ((a < 0) | ~rattler[np.maximum(a, 0)]) & (
            (b < 0) | ~rattler[np.maximum(b, 0)])
        count = np.zeros(p.n_disks, np.int64)
        np.add.at(count, a[live & (a >= 0)], 1)
        np.add.at(count, b[live & (b >= 0)], 1)
        new = rattler | (~loaded & (count < 2))
        if np.array_equal(new, rattler):
            return rattler
        rattler = new


def check_force_signs(p: Packing, source="packing") -> Packing:
    """InputError unless every normal force is >= 0 up to round-off
    (``config.FN_ROUND_OFF`` of the mean |fn|): contacts push. Checked on every read of a packing file (a file whose
    forces were negated, or edited, is refused); a packing built in memory may carry
    any trial forces."""
    fn = np.asarray(p.fn, float)
    if fn.size:
        floor = -config.FN_ROUND_OFF * float(np.abs(fn).mean())
        if fn.min() < floor:
            k = int(np.argmin(fn))
            raise InputError(source, f"forces[{k}, 0]", "normal forces must be >= 0 (contacts "
                             f"push: fn > 0 is compressive); {int((fn < floor).sum())} of "
                             f"{fn.size} are negative", got=float(fn[k]))
    return p


def check_packing(p: Packing, source="packing") -> Packing:
    """Validate a packing's arrays (shapes, finiteness, ranges, indices); returns it.

    Raises InputError naming ``source``, the field and what is allowed. Called
    on every read of a packing file and before building a statics problem.
    """
    def bad(field, allowed, got=None):
        raise InputError(source, field, allowed, got=got)

    n = p.x.shape[0] if np.ndim(p.x) == 1 else bad("disks", "must be an (n, 3) table x, y, r")
    if n == 0:
        bad("disks", "the packing has no disks")
    for name in ("y", "r"):
        if np.shape(getattr(p, name)) != (n,):
            bad(f"disks/{name}", f"must have shape ({n},)", got=np.shape(getattr(p, name)))
    for name in ("x", "y", "r"):
        if not np.all(np.isfinite(getattr(p, name))):
            bad(f"disks/{name}", "must be finite (found NaN/inf)")
    if np.any(p.r <= 0):
        bad("disks/r", "radii must be > 0", got=float(np.min(p.r)))
    rho = np.asarray(p.density, float)
    if rho.shape not in ((), (n,)) or not np.all(np.isfinite(rho)) or np.any(rho <= 0):
        bad("density", "must be finite and > 0 (one value or one per disk)")
    for name, lo in (("mu", 0.0), ("plate_mu", 0.0), ("gravity", 0.0)):
        v = getattr(p, name)
        if not (np.isfinite(v) and v >= lo):
            bad(name, f"must be a finite number >= {lo:g}", got=v)
    if not (np.isfinite(p.width) and p.width > 0):
        bad("box/width", "must be a finite number > 0", got=p.width)
    if not np.isfinite(p.top_force):
        bad("box/top_force", "must be finite", got=p.top_force)
    for name in ("y_bottom", "y_top"):
        if np.isinf(getattr(p, name)):
            bad(f"box/{name}", "must be finite, or NaN for an absent plate")
    nc = p.a.shape[0]
    for name, shape in (("b", (nc,)), ("image", (nc,)), ("gap", (nc,)), ("fn", (nc,)),
                        ("ft", (nc,)), ("normal", (nc, 2)), ("point", (nc, 2))):
        if np.shape(getattr(p, name)) != shape:
            bad(f"contacts/{name}", f"must have shape {shape}", got=np.shape(getattr(p, name)))
    for name, field in (("a", "contacts/bodies"), ("b", "contacts/bodies"),
                        ("image", "contacts/image")):
        if not np.issubdtype(np.asarray(getattr(p, name)).dtype, np.integer):
            bad(field, "must be integers", got=np.asarray(getattr(p, name)).dtype.name)
    for name in ("a", "b"):
        idx = np.asarray(getattr(p, name))
        if idx.size and (idx.min() < WALL or idx.max() >= n):
            bad("contacts/bodies", f"indices must be disks 0..{n - 1} or walls -1..-5",
                got=(int(idx.min()), int(idx.max())))
    if np.any(p.a == p.b):
        bad("contacts/bodies", "a contact must join two different bodies")
    for name in ("normal", "point", "gap", "fn", "ft"):
        if not np.all(np.isfinite(getattr(p, name))):
            bad(f"contacts/{name}" if name not in ("fn", "ft") else "forces",
                "must be finite (found NaN/inf)")
    if nc and np.abs(np.hypot(p.normal[:, 0], p.normal[:, 1]) - 1.0).max() > \
            config.UNIT_NORMAL_TOL:
        bad("contacts/normal", "must be unit vectors")
    _check_unique_contacts(p, bad)
    if np.any((p.b == WALL) | ((p.a == WALL) & (p.b < 0))):
        bad("contacts/bodies", "a WALL (-5) contact has the wall as body a and a disk as b")
    if p.external is not None:
        ext = np.asarray(p.external)
        if ext.shape != (n, 3) or not np.all(np.isfinite(ext)):
            bad("external", f"must be finite, shape ({n}, 3): fx, fy [F0], torque [F0 R]",
                got=ext.shape)
    check_measurement(p.measurement, n, nc, source)
    return p


def _check_unique_contacts(p: Packing, bad) -> None:
    """Each contact once: the same two bodies (in either order) through the same periodic
    image twice would count one contact's forces twice (dim S grew from 6 to 8). A
    measured frame's WALL contacts are told apart by their normal (a disk may touch
    several wall segments)."""
    a, b, img = (np.asarray(v, np.int64) for v in (p.a, p.b, p.image))
    swap = a > b
    wall = (a == WALL)[:, None] * np.round(np.asarray(p.normal, float).reshape(-1, 2) * 1e9)
    key = np.column_stack([np.where(swap, b, a), np.where(swap, a, b),
                           np.where(swap, -img, img), wall.astype(np.int64)])
    _, first, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    if np.any(counts > 1):
        k = int(first[np.argmax(counts > 1)])
        twin = int(np.flatnonzero((key == key[k]).all(1))[1])
        bad("contacts/bodies", f"contact {twin} repeats contact {k} (bodies {a[k]} and "
            f"{b[k]}, image {img[k]}): each contact must be listed once")


def tile(p: Packing, k: int) -> Packing:
    """The periodic packing ``p`` repeated k times along x: k n disks in a box k times as
    wide, the same contacts and forces in every copy, the top load k times larger (so the
    loads per width are unchanged). A packing with the contact structure of a real jammed
    one at any size, for tests and benchmarks."""
    if not p.periodic_x:
        raise InputError("tile", "periodic_x", "only a packing periodic in x can be tiled")
    if not (isinstance(k, int) and k >= 1):
        raise InputError("tile", "k", "must be an integer >= 1", got=k)
    n = p.n_disks
    x = np.tile(p.x, k) + np.repeat(np.arange(k), n) * p.width
    a_blocks, b_blocks, img_blocks = [], [], []
    for c in range(k):
        a_blocks.append(np.where(p.a >= 0, p.a + c * n, p.a))
        # b's image: the copy (c + image) mod k, with the wrap carried by the new image
        tgt = c + p.image
        b_blocks.append(np.where(p.b >= 0, p.b + (tgt % k) * n, p.b))
        img_blocks.append(np.where(p.b >= 0, np.floor_divide(tgt, k), 0))
    fields = {name: np.concatenate([getattr(p, name)] * k)
              for name in ("normal", "point", "gap", "fn", "ft")}
    density = p.density if np.ndim(p.density) == 0 else np.tile(p.density, k)
    if p.measurement is not None:
        raise InputError("tile", "packing", "a measured packing (a frame) cannot be tiled")
    external = None if p.external is None else np.tile(p.external, (k, 1))
    return replace(p, x=x, y=np.tile(p.y, k), r=np.tile(p.r, k), width=k * p.width,
                   top_force=k * p.top_force, density=density, a=np.concatenate(a_blocks),
                   b=np.concatenate(b_blocks), image=np.concatenate(img_blocks), source="",
                   external=external, **fields)


# the unit of every dimensioned number of Packing.summary (`forcespace info --json`): R the
# smallest disk's radius scale of the scene, F0 the scene's load unit (the top-plate force,
# or rho g R^2 without a plate), <Fn> the packing's mean normal force
SUMMARY_UNITS = {
    "width": "R", "height": "R", "max_overlap": "R", "mean_normal_force": "F0",
    "equilibrium_residual": "<Fn> (largest force imbalance of a disk or the plate / <Fn>; "
                            "torques / (r <Fn>))",
    "static_residual": "<Fn> (as equilibrium_residual, at the end of the static solve)",
    "z": "contacts per non-rattler disk", "packing_fraction": "1", "mu": "1",
    "plate_mu": "1", "compress_seconds": "s (wall clock)", "static_seconds": "s (wall clock)",
    "wall_seconds": "s (wall clock)", "steps": "time steps",
}
