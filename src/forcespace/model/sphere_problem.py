"""Statics of a fixed sphere packing: the conic problem whose solution set is S in 3-D.

Unknowns, equations and loads (the 3-D form of :mod:`forcespace.model.problem`)
--------------------------------------------------------------------------------
* Unknown columns: 3 per *unknown contact* j (problem order): ``x[3j] = fn``,
  ``x[3j+1] = f1``, ``x[3j+2] = f2`` [F0], the force on body b being
  ``fn n + f1 t1 + f2 t2`` in the contact's frame (``frame[j]`` = rows n, t1, t2; t1, t2
  from :func:`tangent_frame`, a fixed function of n).
* Rows: 6 per *interior sphere* i (problem order): ``6i..6i+2`` the net force (x, y, z),
  ``6i+3..6i+5`` the net torque divided by the sphere's radius (every row in F0). A
  tangential force ft turns both spheres of its contact by ``-r n x ft``, so its
  torque rows are ``-(f1 t2 - f2 t1)`` for a and b alike. ``A @ x = b`` with
  ``b = -(fixed loads)`` (body forces and the contacts held fixed). The plate problem
  adds one row: the top plate's vertical balance.
* Coulomb: for mu_j > 0 the second-order cone ``||(f1, f2)|| <= mu_j fn`` (which implies
  fn >= 0); for mu_j = 0, ``f1 = f2 = 0`` (fixed columns) and ``fn >= 0``.

So S = {x : A x = b, every contact in its cone}: convex, not a polyhedron (section 7 of
the science brief). Which contacts are unknowns, loads or dropped, and the rattler
convention, are exactly those of the disks' problems (one rule,
:func:`forcespace.model.problem.classify_contacts`): ``full`` (every non-rattler sphere
interior, the bottom plate a support, the top plate's forces fixed loads),
``full_plate`` (the top plate's contacts unknowns too, under its load), ``slice``
(spheres whose centres lie within ``height / 2`` of the box's middle in z).

The loads are not projected onto range(A) (the disks' problem does): b carries the
engine's own residual (<= ``jamming.static_tolerance`` <Fn>) as its inconsistency.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from .problem import check_problem_arrays, chosen_slice_height, classify_contacts
from .sphere_packing import SpherePacking, check_sphere_packing, sphere_contact_sums
from .walls import BOTTOM, TOP, contact_mu_array

SUPPORT, PLATE = -1, -2      # the body codes of ``ends``: a fixed support, the top plate


def tangent_frame(normal) -> tuple[np.ndarray, np.ndarray]:
    """Unit tangents t1, t2 (Nc, 3) of unit normals (Nc, 3): t1 along the coordinate axis
    least aligned with n, made orthogonal to n; t2 = n x t1 (so (n, t1, t2) is
    right-handed and n x t2 = -t1)."""
    n = np.asarray(normal, float).reshape(-1, 3)
    axis = np.zeros_like(n)
    axis[np.arange(n.shape[0]), np.argmin(np.abs(n), axis=1)] = 1.0
    t1 = axis - (axis * n).sum(1)[:, None] * n
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    return t1, np.cross(n, t1)


@dataclass
class SphereStaticsProblem:
    """The conic statics problem of an interior set of spheres.

    Shapes: n interior spheres, m unknown contacts. A (6n [+1], 3m) CSR, b [F0]; mu (m,);
    contacts (m,) packing contact indices of the columns; spheres (n,) packing sphere
    indices; ends (m, 2) the local body of a and b (interior index, ``SUPPORT`` -1 for a
    wall or a support sphere, ``PLATE`` -2 for the load-controlled plate); frame (m, 3, 3)
    rows n, t1, t2; mass, radius (n,) of the interior spheres [rho R^3], [R].
    """

    kind: str                  # "full", "full_plate" or "slice"
    height: float | None
    A: sp.csr_matrix
    b: np.ndarray
    mu: np.ndarray
    contacts: np.ndarray
    spheres: np.ndarray
    rattlers: np.ndarray
    load_contacts: np.ndarray
    ends: np.ndarray
    frame: np.ndarray
    x_jammed: np.ndarray
    force_scale: float         # <Fn> over unknown contacts with fn > 0 [F0]
    mass: np.ndarray
    radius: np.ndarray
    source: str = ""
    meta: dict = field(default_factory=dict)

    dim = 3

    def __repr__(self) -> str:
        h = "" if self.height is None else f", height={self.height:g} R"
        return (f"SphereStaticsProblem({self.kind}{h}: {self.n_interior} interior spheres, "
                f"{self.n_contacts} unknown contacts, {self.load_contacts.size} load "
                f"contacts, <Fn>={self.force_scale:.3g} F0)")

    @property
    def n_interior(self) -> int:
        return int(self.spheres.shape[0])

    @property
    def disks(self) -> np.ndarray:
        """The interior grains (the disks' problems' name): :attr:`spheres`."""
        return self.spheres

    @property
    def n_contacts(self) -> int:
        return int(self.contacts.shape[0])

    @property
    def n_columns(self) -> int:
        return 3 * self.n_contacts

    @property
    def load_force(self) -> np.ndarray:
        """Fixed loads on the interior spheres (n, 3) [F0]."""
        return -self.b[:6 * self.n_interior].reshape(-1, 6)[:, :3]

    @property
    def load_torque(self) -> np.ndarray:
        """Fixed torques on the interior spheres (n, 3) [F0 R]."""
        return -self.b[:6 * self.n_interior].reshape(-1, 6)[:, 3:] * self.radius[:, None]

    def scaled(self, factor: float) -> "SphereStaticsProblem":
        """The same problem with every force multiplied by ``factor`` (> 0)."""
        f = float(factor)
        meta = dict(self.meta)
        for k in ("packing_fn", "packing_ft"):
            meta[k] = np.asarray(meta[k], float) * f
        return dataclasses.replace(self, b=self.b * f, x_jammed=self.x_jammed * f,
                                   force_scale=self.force_scale * f, meta=meta)

    def check(self, source: str = "problem") -> "SphereStaticsProblem":
        """The problem itself if its arrays are consistent, else InputError naming the
        field (the disks' door check, 3 columns per contact and 6 rows per sphere)."""
        check_problem_arrays(self, source, per_contact=3, per_body=6, grain="sphere",
                             columns="fn, f1, f2")
        if np.shape(self.frame) != (self.n_contacts, 3, 3):
            raise InputError(self.source or source, "frame", "must be (m, 3, 3): rows n, t1, "
                             "t2 of every unknown contact", got=np.shape(self.frame))
        return self

    # ---- column maps ----------------------------------------------------------------
    def forces_from_packing(self, fn, ft) -> np.ndarray:
        """Packing forces fn (Nc,), ft (Nc, 3) -> problem vector x (3m,)."""
        fn = np.asarray(fn, float)[self.contacts]
        ft = np.asarray(ft, float).reshape(-1, 3)[self.contacts]
        x = np.empty(self.n_columns)
        x[0::3] = fn
        x[1::3] = (ft * self.frame[:, 1]).sum(1)
        x[2::3] = (ft * self.frame[:, 2]).sum(1)
        return x

    def to_packing_forces(self, x, base_fn=None, base_ft=None):
        """Problem vector x (3m,) -> packing-indexed fn (Nc,), ft (Nc, 3); contacts that
        are not unknowns keep ``base_fn``/``base_ft`` (default: the packing's)."""
        x = np.asarray(x, float)
        if x.shape != (self.n_columns,):
            raise InputError("forces", "x", f"must have shape ({self.n_columns},)", got=x.shape)
        fn = np.array(self.meta["packing_fn"] if base_fn is None else base_fn, float)
        ft = np.array(self.meta["packing_ft"] if base_ft is None else base_ft, float)
        fn[self.contacts] = x[0::3]
        ft[self.contacts] = x[1::3, None] * self.frame[:, 1] + x[2::3, None] * self.frame[:, 2]
        return fn, ft

    # ---- constraints ----------------------------------------------------------------
    def fixed_columns(self) -> np.ndarray:
        """Columns held at 0 by definition: f1, f2 of frictionless contacts."""
        j = np.flatnonzero(self.mu == 0.0)
        return np.sort(np.concatenate([3 * j + 1, 3 * j + 2]))

    def cone_excess(self, x) -> np.ndarray:
        """Per unknown contact (m,): ``||(f1, f2)|| - mu fn`` (mu > 0), or ``-fn``
        (mu = 0) [F0]; <= 0 inside the cone."""
        x = np.asarray(x, float).reshape(-1, 3)
        ft = np.hypot(x[:, 1], x[:, 2])
        return np.where(self.mu > 0, ft - self.mu * x[:, 0], -x[:, 0])

    def residuals(self, x):
        """Equilibrium residual ``A x - b`` [F0] and :meth:`cone_excess` [F0]."""
        x = np.asarray(x, float)
        return self.A @ x - self.b, self.cone_excess(x)

    def violation(self, x) -> float:
        """Largest violation of equilibrium, the cones, fn >= 0 and the fixed columns,
        divided by ``force_scale`` (dimensionless)."""
        x = np.asarray(x, float)
        if x.shape != (self.n_columns,) or not np.all(np.isfinite(x)):
            return float("inf")
        eq, cone = self.residuals(x)
        v = max(np.abs(eq).max(initial=0.0), cone.max(initial=0.0),
                (-x[0::3]).max(initial=0.0), np.abs(x[self.fixed_columns()]).max(initial=0.0))
        return float(v / self.force_scale)

    def summary(self) -> dict:
        return {"kind": self.kind, "height": self.height, "dimension": 3,
                "n_interior": self.n_interior, "n_contacts": self.n_contacts,
                "n_unknowns": self.n_columns, "n_equations": int(self.A.shape[0]),
                "n_rattlers_excluded": int(self.rattlers.size),
                "n_load_contacts": int(self.load_contacts.size),
                "force_scale": self.force_scale}


def _equilibrium_matrix(p: SpherePacking, contacts, frame, local) -> sp.csr_matrix:
    """A (6n, 3m): the rows and columns of the module docstring."""
    rows, cols, vals = [], [], []
    for j, k in enumerate(contacts):
        nrm, t1, t2 = frame[j]
        for body, sgn in ((p.b[k], 1.0), (p.a[k], -1.0)):
            i = local[body] if body >= 0 else -1
            if i < 0:
                continue
            for d in range(3):
                rows += [6 * i + d] * 3 + [6 * i + 3 + d] * 2
                cols += [3 * j, 3 * j + 1, 3 * j + 2, 3 * j + 1, 3 * j + 2]
                vals += [sgn * nrm[d], sgn * t1[d], sgn * t2[d], -t2[d], t1[d]]
    n = int((local >= 0).sum())
    A = sp.csr_matrix((vals, (rows, cols)), shape=(6 * n, 3 * len(contacts)))
    A.sum_duplicates()
    A.eliminate_zeros()
    return A


def build_sphere_problem(p: SpherePacking, interior_mask, unknown_walls, kind, height=None,
                         gap_tol: float = np.inf, source: str = "", support_mask=None,
                         rattlers=None, mu: float | None = None) -> SphereStaticsProblem:
    """Assemble the conic problem of the interior spheres ``interior_mask`` (n,); the
    arguments are those of :func:`forcespace.model.problem.build_problem` (supports:
    ``unknown_walls`` wall codes and the spheres of ``support_mask``; ``rattlers``
    overrides the packing's; ``mu`` replaces the sphere-sphere friction)."""
    source = source or p.source
    if mu is not None and not (np.isfinite(mu) and 0 <= mu <= 1e6):
        raise InputError(source or "problem", "mu", "must be a number in [0, 1e6]", got=mu)
    check_sphere_packing(p, source or "packing")
    rat = p.rattlers() if rattlers is None else np.asarray(rattlers, bool)
    interior = np.asarray(interior_mask, bool) & ~rat
    spheres = np.flatnonzero(interior)
    if spheres.size == 0:
        raise InputError(source or "packing", "interior",
                         "no non-rattler sphere in the chosen region")
    local = -np.ones(p.n_spheres, dtype=np.int64)
    local[spheres] = np.arange(spheres.size)
    unknown, load = classify_contacts(p, interior, rat, unknown_walls, gap_tol, support_mask)
    contacts = np.flatnonzero(unknown)
    mu_spheres = p.mu if mu is None else float(mu)
    mus = contact_mu_array(p.a[contacts], p.b[contacts], mu_spheres, p.plate_mu)
    nrm = p.normal[contacts]
    t1, t2 = tangent_frame(nrm)
    frame = np.stack([nrm, t1, t2], axis=1)
    A = _equilibrium_matrix(p, contacts, frame, local)
    load_force, load_torque = sphere_contact_sums(p, p.fn, p.ft, load, external=True)
    b = -np.concatenate([load_force[spheres], load_torque[spheres] / p.r[spheres, None]],
                        axis=1).ravel()
    ends = np.empty((contacts.size, 2), np.int64)
    for col, body in ((0, p.a[contacts]), (1, p.b[contacts])):
        ends[:, col] = np.where(body >= 0, local[np.maximum(body, 0)], SUPPORT)
        ends[(body == TOP) & (kind == "full_plate"), col] = PLATE
    x_j = np.zeros(3 * contacts.size)
    fn_j = p.fn[contacts]
    x_j[0::3] = fn_j
    x_j[1::3] = (p.ft[contacts] * t1).sum(1)
    x_j[2::3] = (p.ft[contacts] * t2).sum(1)
    pos = fn_j[fn_j > 0]
    scale = float(pos.mean()) if pos.size else float(np.abs(b[b != 0]).mean() if
                                                     np.any(b != 0) else 1.0)
    return SphereStaticsProblem(
        kind=kind, height=height, A=A, b=b, mu=mus, contacts=contacts, spheres=spheres,
        rattlers=np.flatnonzero(rat & np.asarray(interior_mask, bool)),
        load_contacts=np.flatnonzero(load), ends=ends, frame=frame, x_jammed=x_j,
        force_scale=scale, mass=np.asarray(p.mass, float)[spheres], radius=p.r[spheres],
        source=source,
        meta={"packing_fn": np.asarray(p.fn, float).copy(),
              "packing_ft": np.asarray(p.ft, float).copy(), "packing_mu": p.mu,
              "plate_mu": p.plate_mu, "mu_override": None if mu is None else float(mu),
              "scene_name": p.scene_name, "scene_text": p.scene_text})


def sphere_full_problem(packing: SpherePacking, gap_tol: float = np.inf, source: str = "",
                        mu: float | None = None, rattlers=None) -> SphereStaticsProblem:
    """All non-rattler spheres; BOTTOM a support, TOP forces fixed loads (``rattlers``
    (n,) bool: the spheres left out, default the packing's)."""
    return build_sphere_problem(packing, np.ones(packing.n_spheres, bool), (BOTTOM,), "full",
                                gap_tol=gap_tol, source=source, mu=mu, rattlers=rattlers)


def sphere_plate_problem(packing: SpherePacking, gap_tol: float = np.inf, source: str = "",
                         mu: float | None = None, rattlers=None) -> SphereStaticsProblem:
    """All non-rattler spheres under the load-controlled plate: TOP contacts unknowns too
    and one more row, ``sum of their fn = top_force`` (S of the packing protocol;
    ``rattlers`` as :func:`sphere_full_problem`)."""
    prob = build_sphere_problem(packing, np.ones(packing.n_spheres, bool), (BOTTOM, TOP),
                                "full_plate", gap_tol=gap_tol, source=source, mu=mu,
                                rattlers=rattlers)
    top_cols = 3 * np.flatnonzero(np.asarray(packing.b)[prob.contacts] == TOP)
    row = sp.csr_matrix((np.ones(top_cols.size), (np.zeros(top_cols.size, int), top_cols)),
                        shape=(1, prob.n_columns))
    return dataclasses.replace(prob, A=sp.vstack([prob.A, row]).tocsr(),
                               b=np.append(prob.b, packing.top_force))


def sphere_slice_problem(packing: SpherePacking, height: float, gap_tol: float = np.inf,
                         source: str = "", mu: float | None = None) -> SphereStaticsProblem:
    """The paper's slice in 3-D: spheres with |z - z_c| <= height/2 (z_c the middle
    between the plates); their contacts with anything outside are fixed loads."""
    if not (np.isfinite(height) and height > 0):
        raise InputError(source or "slice", "height", "must be a finite number > 0 [R]",
                         got=height)
    p = packing
    zc = 0.5 * (p.z_bottom + p.z_top) if np.isfinite(p.z_bottom + p.z_top) else \
        0.5 * (p.z.min() + p.z.max())
    mask = np.abs(p.z - zc) <= 0.5 * height
    return build_sphere_problem(p, mask, (), "slice", height=float(height), gap_tol=gap_tol,
                                source=source, mu=mu)


def sphere_problem_for(packing: SpherePacking, slice_height: float | None = None,
                       full: bool = False, gap_tol: float = np.inf, mu: float | None = None,
                       source: str = "") -> SphereStaticsProblem:
    """The problem a command asks for (the disks' :func:`~forcespace.model.problem.problem_for`
    for spheres): the slice of ``slice_height`` [R], the whole packing with ``full``, else
    the slice height of the packing's scene, else the whole packing."""
    height = chosen_slice_height(packing, slice_height, full, source)
    if height is None:
        return sphere_full_problem(packing, gap_tol=gap_tol, source=source, mu=mu)
    return sphere_slice_problem(packing, height, gap_tol=gap_tol, source=source, mu=mu)
