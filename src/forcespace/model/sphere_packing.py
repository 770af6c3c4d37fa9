"""A jammed packing of spheres (3-D): spheres, box, contact network and contact forces.

Conventions (those of :mod:`forcespace.model.packing`, carried to 3-D)
----------------------------------------------------------------------
* Units: lengths in R (the smallest radius of the scene's range), masses in rho R^3
  (sphere mass = density 4/3 pi r^3), forces in F0 (the top-plate load is in F0).
* Axes: x and y lateral and periodic (extents ``lateral`` = (lx, ly)), z vertical between
  a fixed lower plate (``BOTTOM``) at ``z_bottom`` and a load-controlled upper plate
  (``TOP``) at ``z_top``, both normal to z.
* Bodies: spheres 0..n-1, walls by their negative codes (BOTTOM is always body ``a``, TOP
  always body ``b``; normal (0, 0, 1)).
* A contact k joins bodies ``a[k]`` and ``b[k]``; ``normal[k]`` (3,) is the unit vector
  from a to b; the force ``fn n + ft`` acts on b and its negative on a, with ``ft[k]``
  (3,) the tangential force, perpendicular to n. ``fn > 0`` is compression. The torque
  of contact k is ``-r n x ft`` on b and on a (r each sphere's radius), the 3-D form of
  the disks' ``-r ft``. Coulomb: ``|ft| <= mu fn``.
* Periodic images: b's centre is taken at ``pos_b + (image_x lx, image_y ly, 0)``.

The rattler, force-bearing and coordination conventions are the disks' own (the same
methods): a rattler carries no force-bearing contact; z = 2 Nc / n over non-rattlers,
wall contacts counted, so an isostatic frictionless sphere packing has z = 6 up to
boundary terms.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .. import config
from ..errors import InputError
from .packing import Packing
from .setup import Setup
from .walls import BOTTOM, TOP, contact_mu_array


@dataclass
class SpherePacking:
    """A static sphere packing with its contact network and one admissible force state.

    Arrays: pos (n, 3), r (n,) [R]; a, b (Nc,) int; image (Nc, 2) int; normal, point
    (Nc, 3); gap (Nc,) [R]; fn (Nc,) [F0]; ft (Nc, 3) [F0].
    """

    pos: np.ndarray
    r: np.ndarray
    lateral: tuple           # (lx, ly) periodic extents [R]
    z_bottom: float          # top surface of the lower plate [R] (nan: no plate)
    z_top: float             # bottom surface of the upper plate [R] (nan: no plate)
    top_force: float         # downward load on the upper plate [F0]
    gravity: float           # acceleration along -z [F0/(rho R^4)]
    density: float | np.ndarray  # density [rho], uniform or per sphere (n,)
    mu: float                # sphere-sphere Coulomb friction
    plate_mu: float          # sphere-wall Coulomb friction
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
    solver_log: np.ndarray | None = None  # (k, 5) as Packing.solver_log
    source: str = field(default="", compare=False, repr=False)
    setup: Setup | None = field(default=None, compare=False, repr=False)

    dim = 3
    periodic_x = True        # a 3-D box is periodic in x and y
    measurement = None       # no measured sphere networks (the readers are 2-D)
    external = None          # no external forces besides gravity

    # ---- the network conventions shared with disks (the same code) -----------------
    mean_normal_force = Packing.mean_normal_force
    force_bearing = Packing.force_bearing
    rattlers = Packing.rattlers
    coordination = Packing.coordination
    max_overlap = Packing.max_overlap

    @classmethod
    def from_arrays(cls, pos, r, a, b, fn=None, ft=None, *, lateral, image=None,
                    z_bottom=np.nan, z_top=np.nan, top_force=0.0, gravity=0.0, density=1.0,
                    mu=0.0, plate_mu=0.0, scene_name="") -> "SpherePacking":
        """A sphere packing from positions, radii and a contact list; geometry derived.

        pos (n, 3), r (n,) [R]; a, b (Nc,) body indices (spheres >= 0; BOTTOM as a, TOP
        as b); fn (Nc,), ft (Nc, 3) [F0] (default 0); ``lateral`` (lx, ly) [R]; image
        (Nc, 2) (default the minimum image). Normals, contact points and gaps come from
        the geometry.
        """
        pos = np.asarray(pos, float).reshape(-1, 3).copy()
        r = np.asarray(r, float).copy()
        a = np.asarray(a, np.int64).copy()
        b = np.asarray(b, np.int64).copy()
        size = np.array([float(lateral[0]), float(lateral[1])])
        nc = a.shape[0]
        img = np.zeros((nc, 2), np.int64) if image is None else \
            np.asarray(image, np.int64).reshape(nc, 2).copy()
        normal, point, gap = np.zeros((nc, 3)), np.zeros((nc, 3)), np.zeros(nc)
        for k in range(nc):
            i, j = int(a[k]), int(b[k])
            if i >= 0 and j >= 0:
                d = pos[j] - pos[i]
                if image is None:
                    img[k] = -np.floor(d[:2] / size + 0.5).astype(np.int64)
                d[:2] += img[k] * size
                dist = np.linalg.norm(d)
                normal[k] = d / dist
                gap[k] = dist - r[i] - r[j]
                point[k] = pos[i] + (r[i] + 0.5 * gap[k]) * normal[k]
                continue
            if (i, j >= 0) != (BOTTOM, True) and (j, i >= 0) != (TOP, True):
                raise InputError("from_arrays", "a, b", f"contact {k}: BOTTOM must be body "
                                 "a and TOP body b (3-D boxes have no side walls)", got=(i, j))
            sphere, sign = (j, -1.0) if i == BOTTOM else (i, 1.0)
            normal[k] = (0.0, 0.0, 1.0)
            point[k] = pos[sphere] + sign * r[sphere] * normal[k]
            surface = z_bottom if i == BOTTOM else z_top
            gap[k] = (point[k, 2] - surface) * (-sign) if np.isfinite(surface) else 0.0
        p = cls(pos=pos, r=r, lateral=(float(size[0]), float(size[1])),
                z_bottom=float(z_bottom), z_top=float(z_top), top_force=float(top_force),
                gravity=float(gravity), density=density, mu=float(mu),
                plate_mu=float(plate_mu), a=a, b=b, normal=normal, point=point, image=img,
                gap=gap, fn=np.zeros(nc) if fn is None else np.asarray(fn, float).copy(),
                ft=np.zeros((nc, 3)) if ft is None else
                np.asarray(ft, float).reshape(nc, 3).copy(), scene_name=scene_name)
        return check_sphere_packing(p, "from_arrays")

    def branch_segments(self, contacts=None, view=(0, 1, 2)):
        """Segments (k, 2, len(view)) [R] of ``contacts`` (indices; default all) on the axes
        ``view`` ((0, 1, 2): in space; (0, 2): projected on x-z), centre to centre with b
        at its periodic image, plate contacts from the centre to the contact point; and
        their fn (k,) [F0] (the 3-D form of :meth:`Packing.branch_segments`)."""
        contacts = np.arange(self.n_contacts) if contacts is None else np.asarray(contacts,
                                                                                  int)
        size = np.array([self.lateral[0], self.lateral[1], 0.0])
        view = list(view)
        seg = np.empty((contacts.size, 2, len(view)))
        for row, k in enumerate(contacts):
            a, b = self.a[k], self.b[k]
            pa = self.pos[a] if a >= 0 else self.point[k]
            pb = self.pos[b] + np.append(self.image[k], 0) * size if b >= 0 else self.point[k]
            seg[row] = pa[view], pb[view]
        return seg, self.fn[contacts]

    def contact_table(self) -> dict:
        """Per-contact columns (each (Nc,)): contact, a, b, fn [F0], ft = |ft| [F0] and the
        tangential force vector ftx, fty, ftz [F0], force |F| [F0], mobilisation
        |ft|/(mu fn), mu, gap [R], bearing (force-bearing, 0/1): the disks' columns of
        :meth:`Packing.contact_table` (without the image, here two numbers)."""
        mu = contact_mu_array(self.a, self.b, self.mu, self.plate_mu)
        ft = np.linalg.norm(self.ft, axis=1)
        cap = mu * self.fn
        with np.errstate(divide="ignore", invalid="ignore"):
            mob = np.where(ft == 0.0, 0.0, np.where(cap > 0, ft / cap, np.nan))
        return {"contact": np.arange(self.n_contacts), "a": self.a.copy(), "b": self.b.copy(),
                "fn": self.fn.copy(), "ft": ft, "ftx": self.ft[:, 0].copy(),
                "fty": self.ft[:, 1].copy(), "ftz": self.ft[:, 2].copy(),
                "force": np.hypot(self.fn, ft), "mobilisation": mob, "mu": mu,
                "gap": self.gap.copy(), "bearing": self.force_bearing().astype(np.int64)}

    def __repr__(self) -> str:
        return (f"SpherePacking(n_spheres={self.n_spheres}, n_contacts={self.n_contacts}, "
                f"mu={self.mu:g}, box={self.lateral[0]:g} x {self.lateral[1]:g} R periodic, "
                f"scene={self.scene_name!r})")

    # ---- sizes and derived quantities ---------------------------------------------
    @property
    def n_spheres(self) -> int:
        return int(self.pos.shape[0])

    @property
    def n_disks(self) -> int:
        """The number of grains (the name the shared network methods use)."""
        return self.n_spheres

    @property
    def n_contacts(self) -> int:
        return int(self.a.shape[0])

    @property
    def x(self) -> np.ndarray:
        return self.pos[:, 0]

    @property
    def y(self) -> np.ndarray:
        return self.pos[:, 1]

    @property
    def z(self) -> np.ndarray:
        return self.pos[:, 2]

    @property
    def width(self) -> float:
        """Extent along x [R] (``lateral[0]``)."""
        return float(self.lateral[0])

    @property
    def mass(self) -> np.ndarray:
        """Sphere masses (n,) [rho R^3]."""
        return np.asarray(self.density, float) * 4.0 / 3.0 * np.pi * self.r**3

    @property
    def scene_slice_height(self) -> float | None:
        """``[analysis] slice_height`` of the scene that made this packing [R], or None."""
        return Packing.scene_slice_height.fget(self)

    def contact_forces(self) -> np.ndarray:
        """Force vectors on body b, shape (Nc, 3) [F0]."""
        return self.fn[:, None] * self.normal + self.ft

    def external_forces(self) -> np.ndarray:
        """Body forces on the spheres (gravity), shape (n, 3) [F0]."""
        f = np.zeros((self.n_spheres, 3))
        if self.gravity != 0.0:
            f[:, 2] = -self.mass * self.gravity
        return f

    def net_forces(self, fn=None, ft=None):
        """Net force (n, 3) [F0] and torque (n, 3) [F0 R] on every sphere (contacts and
        body forces), and the net vertical force on TOP (:func:`sphere_contact_sums`)."""
        fn = self.fn if fn is None else np.asarray(fn, float)
        ft = self.ft if ft is None else np.asarray(ft, float).reshape(-1, 3)
        force, torque = sphere_contact_sums(self, fn, ft, external=True)
        F = fn[:, None] * self.normal + ft
        plate = float(F[self.b == TOP, 2].sum() - self.top_force) \
            if np.isfinite(self.z_top) else 0.0
        return force, torque, plate

    def equilibrium_residual(self, fn=None, ft=None) -> float:
        """Largest force or torque imbalance (a component) of any sphere or the top plate:
        forces divided by the mean normal force, torques by r_k times it (as for disks)."""
        force, torque, plate = self.net_forces(fn, ft)
        scale = self.mean_normal_force()
        if scale == 0.0:
            return 0.0 if not (np.abs(force).max(initial=0) > 0) else float("inf")
        res = max(np.abs(force).max(initial=0.0),
                  (np.abs(torque) / self.r[:, None]).max(initial=0.0), abs(plate))
        return float(res / scale)

    def coulomb_violation(self, fn=None, ft=None) -> float:
        """Largest excess of |ft| over mu fn (and of -fn) over the contacts, divided by
        the mean normal force (0: every contact inside its Coulomb cone)."""
        fn = self.fn if fn is None else np.asarray(fn, float)
        ft = self.ft if ft is None else np.asarray(ft, float).reshape(-1, 3)
        mu = np.where((self.a < 0) | (self.b < 0), self.plate_mu, self.mu)
        excess = np.maximum(np.linalg.norm(ft, axis=1) - mu * fn, -fn)
        scale = self.mean_normal_force() or 1.0
        return float(max(excess.max(initial=0.0), 0.0) / scale)

    def packing_fraction(self) -> float | None:
        """Sphere volume over box volume (between the plates), or None without both."""
        if not (np.isfinite(self.z_top) and np.isfinite(self.z_bottom)):
            return None
        volume = self.lateral[0] * self.lateral[1] * (self.z_top - self.z_bottom)
        return float(4.0 / 3.0 * np.pi * (self.r**3).sum() / volume)

    def with_forces(self, fn, ft) -> "SpherePacking":
        """A copy carrying another force state (fn (Nc,), ft (Nc, 3)) on the same network."""
        return replace(self, fn=np.asarray(fn, float).copy(),
                       ft=np.asarray(ft, float).reshape(-1, 3).copy(), source="")

    def summary(self) -> dict:
        """The numbers `forcespace info --json` prints."""
        rat = self.rattlers()
        height = float(self.z_top - self.z_bottom) if np.isfinite(self.z_top) else None
        return {
            "dimension": 3,
            "n_spheres": self.n_spheres,
            "n_contacts": self.n_contacts,
            "n_force_bearing": int(self.force_bearing().sum()),
            "z": self.coordination(),
            "z_convention": "2*Nc/n over non-rattlers, Nc force-bearing contacts "
                            f"(fn > {config.FORCE_BEARING:g} <Fn>), wall contacts count; "
                            "rattler: a sphere with no force-bearing contact (carries no load)",
            "n_rattlers": int(rat.sum()),
            "mu": self.mu,
            "plate_mu": self.plate_mu,
            "seed": self.seed,
            "box": [float(self.lateral[0]), float(self.lateral[1]), height],
            "packing_fraction": self.packing_fraction(),
            "mean_normal_force": self.mean_normal_force(),
            "equilibrium_residual": self.equilibrium_residual(),
            "coulomb_violation": self.coulomb_violation(),
            "max_overlap": self.max_overlap(),
            **{k: v for k, v in self.meta.items() if isinstance(v, (int, float, str, bool))},
        }


def sphere_contact_sums(p: SpherePacking, fn, ft, contacts=None, external: bool = False):
    """The force (n, 3) [F0] and torque (n, 3) [F0 R] that contacts exert on the spheres:
    contact k pushes ``fn n + ft`` on b and its negative on a and turns both by
    ``-r n x ft``; ``contacts`` a mask or indices of the contacts that count (default
    all); ``external``: start from the body forces (gravity). Body forces first, then the
    contacts one by one (b, then a), as :func:`forcespace.model.packing.contact_sums`."""
    fn = np.asarray(fn, float)
    ft = np.asarray(ft, float).reshape(-1, 3)
    k = np.arange(p.n_contacts) if contacts is None else np.asarray(contacts)
    if k.dtype == bool:
        k = np.flatnonzero(k)
    F = fn[k, None] * p.normal[k] + ft[k]
    turn = np.cross(p.normal[k], ft[k])                       # n x ft
    body = np.column_stack([p.b[k], p.a[k]]).ravel()
    push = np.stack([F, -F], axis=1).reshape(-1, 3)
    twist = np.repeat(turn, 2, axis=0)
    on = body >= 0
    force = p.external_forces() if external else np.zeros((p.n_spheres, 3))
    torque = np.zeros((p.n_spheres, 3))
    np.add.at(force, body[on], push[on])
    np.add.at(torque, body[on], -p.r[body[on], None] * twist[on])
    return force, torque


def check_sphere_packing(p: SpherePacking, source="packing") -> SpherePacking:
    """Validate a sphere packing's arrays (shapes, finiteness, ranges, indices); returns
    it. InputError naming ``source``, the field and what is allowed."""
    def bad(name, allowed, got=None):
        raise InputError(source, name, allowed, got=got)

    pos = np.asarray(p.pos)
    if pos.ndim != 2 or pos.shape[1] != 3 or pos.shape[0] == 0:
        bad("spheres", "must be an (n, 4) table x, y, z, r with n >= 1", got=pos.shape)
    n = pos.shape[0]
    if np.shape(p.r) != (n,):
        bad("spheres/r", f"must have shape ({n},)", got=np.shape(p.r))
    if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(p.r))):
        bad("spheres", "must be finite (found NaN/inf)")
    if np.any(p.r <= 0):
        bad("spheres/r", "radii must be > 0", got=float(np.min(p.r)))
    rho = np.asarray(p.density, float)
    if rho.shape not in ((), (n,)) or not np.all(np.isfinite(rho)) or np.any(rho <= 0):
        bad("density", "must be finite and > 0 (one value or one per sphere)")
    for name in ("mu", "plate_mu", "gravity"):
        v = getattr(p, name)
        if not (np.isfinite(v) and v >= 0):
            bad(name, "must be a finite number >= 0", got=v)
    if len(p.lateral) != 2 or not all(np.isfinite(v) and v > 0 for v in p.lateral):
        bad("box/lateral", "must be two finite extents lx, ly > 0", got=p.lateral)
    nc = np.shape(p.a)[0]
    for name, shape in (("b", (nc,)), ("image", (nc, 2)), ("gap", (nc,)), ("fn", (nc,)),
                        ("ft", (nc, 3)), ("normal", (nc, 3)), ("point", (nc, 3))):
        if np.shape(getattr(p, name)) != shape:
            bad(f"contacts/{name}", f"must have shape {shape}", got=np.shape(getattr(p, name)))
    for name in ("a", "b"):
        idx = np.asarray(getattr(p, name))
        if idx.size and (idx.min() < TOP or idx.max() >= n):
            bad("contacts/bodies", f"indices must be spheres 0..{n - 1} or walls -1 "
                "(bottom), -2 (top)", got=(int(idx.min()), int(idx.max())))
    if np.any(p.a == p.b):
        bad("contacts/bodies", "a contact must join two different bodies")
    for name in ("normal", "point", "gap", "fn", "ft"):
        if not np.all(np.isfinite(getattr(p, name))):
            bad(f"contacts/{name}" if name not in ("fn", "ft") else "forces",
                "must be finite (found NaN/inf)")
    if nc and np.abs(np.linalg.norm(p.normal, axis=1) - 1.0).max() > 1e-6:
        bad("contacts/normal", "must be unit vectors")
    return p
