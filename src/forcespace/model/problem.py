"""Statics of a fixed packing: the linear problem whose solution set is S.

Unknowns, equations and loads
-----------------------------
* Unknown columns: 2 per *unknown contact* j (problem order), ``x[2j] = fn``,
  ``x[2j+1] = ft`` [F0], in the contact's own frame (packing.py conventions:
  force ``fn*n + ft*t`` on body b, t = (-n_y, n_x), torque ``-r*ft`` on both disks).
* Rows: 3 per *interior disk* i (problem order): ``3i`` net x force, ``3i+1``
  net y force, ``3i+2`` net torque divided by the disk radius r_i (so every row
  is in F0 and equally scaled). ``A @ x = b`` with ``b = -(fixed loads)``:
  the fixed loads are body forces (gravity) plus the forces and torques of the
  contacts whose force is held fixed.
* Coulomb: for mu_j > 0, ``ft - mu fn <= 0`` and ``-ft - mu fn <= 0`` (they
  imply fn >= 0). For mu_j = 0, ``ft = 0`` (the column is *fixed*, not an
  unknown degree of freedom) and ``-fn <= 0``.

Slice problem (the paper's): interior disks are the non-rattler disks whose
centres lie in the horizontal band ``|y - y_c| <= height/2``, y_c the middle
between the plates (or of the disk centres without plates). A contact between
two interior disks is unknown; a contact of an interior disk with anything
else (outside disk or wall) is a fixed load carrying its packing force.

Full problem: interior disks are all non-rattlers; contacts with BOTTOM (and
LEFT/RIGHT, when present) are unknowns (supports, their mu is ``plate_mu``);
contacts with TOP are fixed loads (its plate force is prescribed).

Plate problem: as the full problem, but the TOP contacts are unknowns too and
one extra row holds the plate's vertical balance (sum of their fn = top_force):
S of the packing protocol itself, with a load-controlled plate.

Rattler convention: ``Packing.rattlers()`` (a disk with no force-bearing
contact: it carries no load) decides. A rattler is never interior: its
3 rows are absent and every contact touching it is dropped entirely (neither
unknown nor load: its force is 0 in the jammed state by construction). The
dropped rattlers are listed in ``StaticsProblem.rattlers``. Contacts whose
gap exceeds ``gap_tol`` [R] are not contacts (open) and are dropped as well.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from ..linalg import project_on_range
from .packing import Packing, check_packing, contact_sums
from .walls import BOTTOM, LEFT, RIGHT, TOP, contact_mu_array

# the kinds of the inequality rows of S (StaticsProblem.inequalities): Coulomb's two sides
# of a frictional contact, and no tension at a frictionless one
SLIDES_PLUS = 0     # ft - mu fn <= 0: tight when the contact slides in +t
SLIDES_MINUS = 1    # -ft - mu fn <= 0: tight when it slides in -t
NO_TENSION = 2      # -fn <= 0 (mu = 0): tight when the contact carries nothing


@dataclass
class StaticsProblem:
    """The linear statics problem of an interior set of disks.

    Shapes: n = interior disks, m = unknown contacts.
    A (3n, 2m) sparse CSR, b (3n,) [F0]; mu (m,); contacts (m,) packing
    contact indices of the unknown columns; disks (n,) packing disk indices.
    ``mass, radius`` (n,) of the interior disks. Everything else a solver needs
    is read off this H-representation (A, b, mu and the bounds): the loads
    (``load_force``, ``load_torque``), the bodies and normals of every contact
    (:meth:`contact_geometry`), and the plate's balance row.
    """

    kind: str                  # "slice" or "full"
    height: float | None       # slice height [R] (None for full)
    A: sp.csr_matrix
    b: np.ndarray
    mu: np.ndarray
    contacts: np.ndarray
    disks: np.ndarray
    rattlers: np.ndarray       # packing indices of rattlers excluded from the problem
    load_contacts: np.ndarray  # packing indices of contacts held as fixed loads
    x_jammed: np.ndarray       # packing forces in column order (2m,)
    force_scale: float         # <Fn>: mean jammed fn over unknown contacts with fn > 0 [F0]
    mass: np.ndarray
    radius: np.ndarray
    source: str = ""
    meta: dict = field(default_factory=dict)
    _inequalities: tuple | None = field(default=None, init=False, repr=False, compare=False)
    _inequalities_mu: np.ndarray | None = field(default=None, init=False, repr=False,
                                                compare=False)

    dim = 2         # disks (a SphereStaticsProblem has 3)

    def __repr__(self) -> str:
        h = "" if self.height is None else f", height={self.height:g} R"
        return (f"StaticsProblem({self.kind}{h}: {self.n_interior} interior disks, "
                f"{self.n_contacts} unknown contacts, {self.load_contacts.size} load contacts, "
                f"<Fn>={self.force_scale:.3g} F0)")

    # ---- sizes ------------------------------------------------------------
    @property
    def n_interior(self) -> int:
        return int(self.disks.shape[0])

    @property
    def n_contacts(self) -> int:
        return int(self.contacts.shape[0])

    @property
    def n_columns(self) -> int:
        return 2 * self.n_contacts

    def scaled(self, factor: float) -> "StaticsProblem":
        """The same problem with every force multiplied by ``factor`` (> 0).

        A, mu and the geometry are unchanged; b, the loads, the jammed and
        packing forces and ``force_scale`` scale. S scales exactly with it, so
        analyses run on ``scaled(1 / force_scale)`` (forces of order 1, where
        the LP solver's absolute tolerances mean what they say) and scale back.
        """
        f = float(factor)
        meta = dict(self.meta)
        for k in ("b_raw", "packing_fn", "packing_ft", "load_x", "b_body"):
            if k in meta:
                meta[k] = np.asarray(meta[k], float) * f
        return dataclasses.replace(
            self, b=self.b * f, x_jammed=self.x_jammed * f, force_scale=self.force_scale * f,
            meta=meta)

    # ---- the contact network, read off A -----------------------------------------
    def contact_geometry(self):
        """(a, b, nx, ny) (m,) of every unknown contact, read off A.

        a, b: interior-disk indices 0..n-1 of the contact's bodies, -1 for a
        support (wall, support disk, or the plate); n = (nx, ny) the unit
        normal from a to b. A holds +n in the force rows of b and -n in those
        of a; which interior disk is called b is immaterial (relabelling flips
        n and t together and keeps fn, ft), so the lower-indexed one is.
        """
        n = self.n_interior
        F = self.A[:3 * n].tocsc()
        m = self.n_contacts
        a = -np.ones(m, np.int64)
        b = -np.ones(m, np.int64)
        nx = np.zeros(m)
        ny = np.zeros(m)
        for j in range(m):
            lo, hi = F.indptr[2 * j], F.indptr[2 * j + 1]
            rows, vals = F.indices[lo:hi], F.data[lo:hi]
            bodies = np.unique(rows[rows % 3 != 2] // 3)
            first = bodies[0]
            b[j] = first
            nx[j] = vals[rows == 3 * first].sum() if (rows == 3 * first).any() else 0.0
            ny[j] = vals[rows == 3 * first + 1].sum() if (rows == 3 * first + 1).any() else 0.0
            if bodies.size > 1:
                a[j] = bodies[1]
        return a, b, nx, ny

    def contact_disks(self, contacts) -> np.ndarray:
        """Packing indices of the interior disks touched by problem contacts ``contacts``."""
        n = self.n_interior
        cols = 2 * np.asarray(contacts, np.int64)
        rows = self.A[:3 * n][:, cols].tocoo().row
        return self.disks[np.unique(rows // 3)]

    # ---- loads (from the rows of b) -----------------------------------------
    @property
    def load_force(self) -> np.ndarray:
        """Fixed loads on the interior disks (n, 2) [F0]: b = -(loads), rows 3i, 3i+1."""
        n = self.n_interior
        return -np.column_stack([self.b[0:3 * n:3], self.b[1:3 * n:3]])

    @property
    def load_torque(self) -> np.ndarray:
        """Fixed torques on the interior disks (n,) [F0 R]: row 3i+2 holds torque / r_i."""
        n = self.n_interior
        return -self.b[2:3 * n:3] * self.radius

    # ---- column maps --------------------------------------------------------
    def forces_from_packing(self, fn, ft) -> np.ndarray:
        """Packing-indexed forces (Nc,), (Nc,) -> problem vector x (2m,)."""
        fn = np.asarray(fn, float)
        ft = np.asarray(ft, float)
        x = np.empty(self.n_columns)
        x[0::2] = fn[self.contacts]
        x[1::2] = ft[self.contacts]
        return x

    def to_packing_forces(self, x, base_fn=None, base_ft=None):
        """Problem vector x (2m,) -> packing-indexed (fn, ft), each (Nc,).

        Contacts that are not unknowns keep ``base_fn/base_ft`` (default: the
        jammed forces of the packing this problem was built from; loads keep
        their fixed values, dropped contacts theirs).
        """
        x = np.asarray(x, float)
        if x.shape != (self.n_columns,):
            raise InputError("forces", "x", f"must have shape ({self.n_columns},)", got=x.shape)
        fn = np.array(self.meta["packing_fn"] if base_fn is None else base_fn, float)
        ft = np.array(self.meta["packing_ft"] if base_ft is None else base_ft, float)
        fn[self.contacts] = x[0::2]
        ft[self.contacts] = x[1::2]
        return fn, ft

    # ---- constraints --------------------------------------------------------
    def fixed_columns(self) -> np.ndarray:
        """Indices of columns held at 0 by definition (ft of frictionless contacts)."""
        return 2 * np.flatnonzero(self.mu == 0.0) + 1

    def inequalities(self):
        """Inequalities ``G @ x <= 0``: G (p, 2m) CSR and their owners.

        Returns (G, contact (p,), kind (p,)) with kind ``SLIDES_PLUS``:
        ``ft - mu fn <= 0``, ``SLIDES_MINUS``: ``-ft - mu fn <= 0`` (mu > 0),
        ``NO_TENSION``: ``-fn <= 0`` (mu = 0). Built once per problem (mu and the
        contacts do not change).
        """
        if self._inequalities is None or not np.array_equal(self._inequalities_mu, self.mu):
            self._inequalities = self._build_inequalities()
            self._inequalities_mu = np.array(self.mu, float)    # mu changed in place: rebuilt
        return self._inequalities

    def check(self, source: str = "problem") -> "StaticsProblem":
        """The problem itself if its arrays are consistent, else InputError naming the
        field (what every computation checks at its door: a field set after building,
        e.g. ``mu`` = NaN, gave an analysis of a wrong S without a word)."""
        return check_problem_arrays(self, source, per_contact=2, per_body=3, grain="disk",
                                    columns="fn, ft")

    def _build_inequalities(self):
        rows, cols, vals, owner, kind = [], [], [], [], []
        p = 0
        for j, mj in enumerate(self.mu):
            if mj > 0.0:
                for s, k in ((1.0, SLIDES_PLUS), (-1.0, SLIDES_MINUS)):
                    rows += [p, p]
                    cols += [2 * j, 2 * j + 1]
                    vals += [-mj, s]
                    owner.append(j)
                    kind.append(k)
                    p += 1
            else:
                rows.append(p)
                cols.append(2 * j)
                vals.append(-1.0)
                owner.append(j)
                kind.append(NO_TENSION)
                p += 1
        G = sp.csr_matrix((vals, (rows, cols)), shape=(p, self.n_columns))
        return G, np.array(owner, dtype=np.int64), np.array(kind, dtype=np.int64)

    def bounds(self):
        """Column bounds for LPs: fn in [0, inf); ft free (mu>0) or [0, 0] (mu=0)."""
        lo = np.full(self.n_columns, -np.inf)
        hi = np.full(self.n_columns, np.inf)
        lo[0::2] = 0.0
        fixed = self.fixed_columns()
        lo[fixed] = 0.0
        hi[fixed] = 0.0
        return lo, hi

    def residuals(self, x):
        """Equilibrium residual ``A x - b`` (3n,) and inequality values ``G x`` (p,) [F0]."""
        x = np.asarray(x, float)
        G, _, _ = self.inequalities()
        return self.A @ x - self.b, G @ x

    def violation(self, x) -> float:
        """Largest violation of equilibrium, Coulomb, fn >= 0 and the fixed columns,
        divided by ``force_scale`` (dimensionless)."""
        x = np.asarray(x, float)
        if x.shape != (self.n_columns,) or not np.all(np.isfinite(x)):
            return float("inf")
        eq, ineq = self.residuals(x)
        v = max(np.abs(eq).max(initial=0.0), ineq.max(initial=0.0),
                (-x[0::2]).max(initial=0.0), np.abs(x[self.fixed_columns()]).max(initial=0.0))
        return float(v / self.force_scale)

    def summary(self) -> dict:
        return {"kind": self.kind, "height": self.height, "n_interior": self.n_interior,
                "n_contacts": self.n_contacts, "n_rattlers_excluded": int(self.rattlers.size),
                "n_load_contacts": int(self.load_contacts.size),
                "force_scale": self.force_scale}


def _centre_y(p: Packing) -> float:
    if np.isfinite(p.y_bottom) and np.isfinite(p.y_top):
        return 0.5 * (p.y_bottom + p.y_top)
    return 0.5 * (p.y.min() + p.y.max())


def slice_bounds(p: Packing, height: float) -> tuple[float, float]:
    """(y_low, y_high) [R] of the slice of ``height`` in the middle of the packing (between
    the plates, else of the disks' centres): the slice holds the disks with centres in
    between."""
    yc = _centre_y(p)
    return yc - 0.5 * height, yc + 0.5 * height


def classify_contacts(p, interior, rat, unknown_walls, gap_tol, support_mask):
    """Masks (Nc,) of the unknown contacts (between two interior disks, or between an
    interior disk and a support: a wall of ``unknown_walls`` or a disk of
    ``support_mask``) and of the load contacts (every other closed contact of an
    interior disk). Contacts of rattlers and open contacts (gap > gap_tol) are neither.
    ``p``: any packing with a, b, gap (disks or spheres: the rule has no dimension)."""
    a = np.asarray(p.a, np.int64)
    bb = np.asarray(p.b, np.int64)
    closed = np.asarray(p.gap, float) <= gap_tol
    is_int = lambda idx: (idx >= 0) & interior[np.maximum(idx, 0)]  # noqa: E731
    is_rat = lambda idx: (idx >= 0) & rat[np.maximum(idx, 0)]  # noqa: E731
    ia, ib = is_int(a), is_int(bb)
    touches = (ia | ib) & closed & ~is_rat(a) & ~is_rat(bb)
    wall_unknown = np.zeros_like(touches)
    for w in unknown_walls:
        wall_unknown |= (a == w) | (bb == w)
    if support_mask is not None:
        sup = np.asarray(support_mask, bool) & ~interior
        is_sup = lambda idx: (idx >= 0) & sup[np.maximum(idx, 0)]  # noqa: E731
        wall_unknown |= is_sup(a) | is_sup(bb)
    unknown = touches & ((ia & ib) | (wall_unknown & (ia | ib)))
    return unknown, touches & ~unknown


def _equilibrium_matrix(p: Packing, contacts, interior, local) -> sp.csr_matrix:
    """A (3n, 2m): rows 3i, 3i+1, 3i+2 = x force, y force, torque / r_i of interior disk
    i; columns 2j, 2j+1 = fn, ft of unknown contact j (module docstring)."""
    nrm = np.asarray(p.normal, float)
    tng = np.stack([-nrm[:, 1], nrm[:, 0]], axis=1)
    n = int(interior.sum())
    rows, cols, vals = [], [], []
    for j, k in enumerate(contacts):
        for body, sgn in ((p.b[k], 1.0), (p.a[k], -1.0)):
            if body < 0 or not interior[body]:
                continue
            i = local[body]
            rows += [3 * i, 3 * i + 1, 3 * i, 3 * i + 1, 3 * i + 2]
            cols += [2 * j, 2 * j, 2 * j + 1, 2 * j + 1, 2 * j + 1]
            vals += [sgn * nrm[k, 0], sgn * nrm[k, 1], sgn * tng[k, 0], sgn * tng[k, 1], -1.0]
    A = sp.csr_matrix((vals, (rows, cols)), shape=(3 * n, 2 * contacts.size))
    A.sum_duplicates()
    return A


def _consistent_loads(A, b, mu) -> np.ndarray:
    """b projected onto range(A) over the columns that are really unknown.

    A x = b is solvable only if b lies in range(A); a jammed packing balances its
    loads only to the engine's tolerance, so b is replaced by its least-squares
    projection (the caller records the removed part). ft of a frictionless contact is
    fixed at 0, so a load component only it could balance is an inconsistency, not
    something S may absorb."""
    m = mu.size
    unknown_cols = np.flatnonzero(np.repeat(mu > 0.0, 2) | (np.arange(2 * m) % 2 == 0))
    if unknown_cols.size == 0:
        return np.zeros_like(b)
    return project_on_range(A[:, unknown_cols], b)


def build_problem(p: Packing, interior_mask, unknown_walls, kind, height=None,
                  gap_tol: float = np.inf, source: str = "", support_mask=None,
                  rattlers=None, mu: float | None = None,
                  wall_mu: float | None = None) -> StaticsProblem:
    """Assemble the problem for the interior disks given by ``interior_mask`` (n,).

    ``unknown_walls``: wall codes whose contacts with interior disks are unknowns
    (supports); contacts with other walls are fixed loads. ``support_mask`` (n,)
    optionally marks non-interior disks that act as fixed supports as well
    (their contacts with interior disks are unknowns, mu = packing mu).
    ``rattlers`` (n,) overrides ``Packing.rattlers()`` (for hand-built systems).
    ``mu``: friction coefficient of the disk-disk contacts instead of the
    packing's own (the paper's frictionless packing "with friction switched
    on"); wall contacts keep ``plate_mu`` unless ``wall_mu`` is given (a measured frame's
    walls as unknowns). Recorded as ``meta["mu_override"]``, ``meta["wall_mu"]``.
    """
    source = source or getattr(p, "source", "")
    if getattr(p, "dim", 2) != 2:
        raise InputError(source or "packing", "dimension", "must be 2: this question about S "
                         "is answered for disks only so far; a sphere packing's S: "
                         "`forcespace analyze` (API: ForceSpace on sphere_slice_problem, "
                         "sphere_full_problem or sphere_plate_problem)",
                         got=p.dim)
    if mu is not None and not (np.isfinite(mu) and 0 <= mu <= 1e6):
        raise InputError(source or "problem", "mu", "must be a number in [0, 1e6] (as the "
                         "scene's physics.mu)", got=mu)
    if np.isnan(gap_tol) or gap_tol < 0:
        raise InputError(source or "problem", "gap_tol", "must be a number >= 0 [R] (or inf)",
                         got=gap_tol)
    if wall_mu is not None and not (np.isfinite(wall_mu) and 0 <= wall_mu <= 1e6):
        raise InputError(source or "problem", "wall_mu", "must be a number in [0, 1e6] (a "
                         "Coulomb coefficient)", got=wall_mu)
    mu_override = None if mu is None else float(mu)
    mu_wall = p.plate_mu if wall_mu is None else float(wall_mu)
    check_packing(p, source or "packing")
    rat = p.rattlers() if rattlers is None else np.asarray(rattlers, bool)
    interior = np.asarray(interior_mask, bool) & ~rat
    disks = np.flatnonzero(interior)
    if disks.size == 0:
        raise InputError(source or "packing", "interior", "no non-rattler disk in the chosen region")
    local = -np.ones(p.n_disks, dtype=np.int64)
    local[disks] = np.arange(disks.size)
    n = disks.size

    unknown, load = classify_contacts(p, interior, rat, unknown_walls, gap_tol, support_mask)
    contacts = np.flatnonzero(unknown)
    m = contacts.size
    mu_disks = p.mu if mu_override is None else mu_override
    mu = contact_mu_array(p.a[contacts], p.b[contacts], mu_disks, mu_wall)
    r = np.asarray(p.r, float)
    A = _equilibrium_matrix(p, contacts, interior, local)
    # loads: body forces and the fixed contact forces
    b_raw = _rhs(p, load, disks)
    bvec = _consistent_loads(A, b_raw, mu)
    inconsistency = float(np.abs(b_raw - bvec).max(initial=0.0))

    x_j = np.empty(2 * m)
    x_j[0::2] = p.fn[contacts]
    x_j[1::2] = p.ft[contacts]
    pos = p.fn[contacts][p.fn[contacts] > 0]
    if pos.size:
        scale = float(pos.mean())
    else:
        nz = np.abs(bvec[np.abs(bvec) > 0])
        scale = float(nz.mean()) if nz.size else 1.0

    return StaticsProblem(
        kind=kind, height=height, A=A, b=bvec, mu=mu, contacts=contacts, disks=disks,
        rattlers=np.flatnonzero(rat & np.asarray(interior_mask, bool)),
        load_contacts=np.flatnonzero(load), x_jammed=x_j, force_scale=scale,
        mass=np.asarray(p.mass, float)[disks], radius=r[disks],
        source=source,
        meta={"load_inconsistency": inconsistency / scale, "b_raw": b_raw,
              "packing_fn": np.asarray(p.fn, float).copy(),
              "packing_ft": np.asarray(p.ft, float).copy(),
              "packing_mu": p.mu, "plate_mu": p.plate_mu, "wall_mu": mu_wall,
              "mu_override": mu_override,
              "scene_name": p.scene_name, "scene_text": p.scene_text,
              **_load_terms(p, np.flatnonzero(load), interior, local, disks, mu_disks,
                            mu_wall)})


def _rhs(p: Packing, contacts, disks) -> np.ndarray:
    """b (3n,) = -(body forces + the forces of ``contacts`` held fixed) on ``disks``:
    rows x, y, torque / r (module docstring)."""
    force, torque = contact_sums(p, p.fn, p.ft, contacts, external=True)
    b = np.empty(3 * disks.size)
    b[0::3] = -force[disks, 0]
    b[1::3] = -force[disks, 1]
    b[2::3] = -torque[disks] / np.asarray(p.r, float)[disks]
    return b


def _load_terms(p: Packing, load, interior, local, disks, mu_disks, mu_wall) -> dict:
    """How b depends on the load contacts (for measured loads, which may be adjusted):
    b_raw = b_body - load_A @ load_x, load_A (3n, 2L) the equilibrium columns of the L
    load contacts, load_x (2L,) their forces (fn, ft) [F0], load_mu (L,) their friction,
    b_body (3n,) minus the body forces alone."""
    return {"load_A": _equilibrium_matrix(p, load, interior, local),
            "load_x": np.column_stack([p.fn[load], p.ft[load]]).ravel(),
            "load_mu": contact_mu_array(p.a[load], p.b[load], mu_disks, mu_wall),
            "b_body": _rhs(p, np.zeros(0, np.int64), disks)}


def problem_for(packing: Packing, slice_height: float | None = None, full: bool = False,
                gap_tol: float = np.inf, mu: float | None = None,
                source: str = "") -> StaticsProblem:
    """The problem a command asks for: the slice of ``slice_height`` [R], the whole
    packing with ``full``, else the slice height of the packing's scene, else the
    whole packing. ``mu``: disk-disk friction instead of the packing's own."""
    height = chosen_slice_height(packing, slice_height, full, source)
    if height is None:
        return full_problem(packing, gap_tol=gap_tol, source=source, mu=mu)
    return slice_problem(packing, height, gap_tol=gap_tol, source=source, mu=mu)


def chosen_slice_height(packing, slice_height: float | None, full: bool,
                        source: str = "") -> float | None:
    """The slice height [R] a command asks for, or None for the whole packing:
    ``slice_height``, None with ``full``, else the scene's ``[analysis] slice_height``
    (None when it has none). Disks or spheres alike."""
    if full and slice_height is not None:
        raise InputError(source or "problem_for", "slice_height, full",
                         "give one of them, not both (a slice or the whole packing)")
    if full:
        return None
    return packing.scene_slice_height if slice_height is None else slice_height


def slice_problem(packing: Packing, height: float, gap_tol: float = np.inf,
                  source: str = "", mu: float | None = None) -> StaticsProblem:
    """The paper's slice: disks with |y - y_c| <= height/2 (see module docstring)."""
    if not (np.isfinite(height) and height > 0):
        raise InputError(source or "slice", "height", "must be a finite number > 0 [R]", got=height)
    yc = _centre_y(packing)
    mask = np.abs(np.asarray(packing.y, float) - yc) <= 0.5 * height
    return build_problem(packing, mask, unknown_walls=(), kind="slice", height=float(height),
                         gap_tol=gap_tol, source=source, mu=mu)


def full_problem(packing: Packing, gap_tol: float = np.inf, source: str = "",
                 mu: float | None = None) -> StaticsProblem:
    """All non-rattler disks; BOTTOM (and side walls) are supports, TOP forces are loads."""
    mask = np.ones(packing.n_disks, dtype=bool)
    return build_problem(packing, mask, unknown_walls=(BOTTOM, LEFT, RIGHT), kind="full",
                         gap_tol=gap_tol, source=source, mu=mu)


def plate_problem(packing: Packing, gap_tol: float = np.inf, source: str = "",
                  mu: float | None = None) -> StaticsProblem:
    """Full packing under a load-controlled top plate: TOP contacts are unknowns too
    (friction plate_mu) and one extra row holds the plate's vertical balance
    sum(fn over TOP contacts) = top_force.

    This is S of the packing protocol itself and of soft-particle runs with a
    plate; :func:`full_problem` (TOP forces fixed at their jammed values) is a
    subset of it.
    """
    mask = np.ones(packing.n_disks, dtype=bool)
    prob = build_problem(packing, mask, unknown_walls=(BOTTOM, TOP, LEFT, RIGHT),
                         kind="full_plate", gap_tol=gap_tol, source=source, mu=mu)
    top_cols = 2 * np.flatnonzero(np.asarray(packing.b)[prob.contacts] == TOP)
    row = sp.csr_matrix((np.ones(top_cols.size), (np.zeros(top_cols.size, dtype=int), top_cols)),
                        shape=(1, prob.n_columns))
    return dataclasses.replace(prob, A=sp.vstack([prob.A, row]).tocsr(),
                               b=np.append(prob.b, packing.top_force))


__all__ = ["StaticsProblem", "slice_problem", "full_problem", "plate_problem", "build_problem",
           "problem_for", "TOP"]


def checked_problem(problem, who: str) -> StaticsProblem:
    """``problem`` if it is a consistent :class:`StaticsProblem`, else InputError naming
    ``who`` (the compute object it was handed to) and what is wrong."""
    if not isinstance(problem, StaticsProblem):
        raise InputError(who, "problem", "must be a StaticsProblem (forcespace.slice_problem, "
                         "full_problem or plate_problem of a packing)",
                         got=type(problem).__name__)
    return problem.check()


def check_problem_arrays(problem, source: str, per_contact: int, per_body: int, grain: str,
                         columns: str):
    """``problem`` (a disks' or spheres' statics problem) if its arrays are consistent,
    else InputError naming the field: A sparse and finite with ``per_contact`` columns per
    unknown contact and at least ``per_body`` rows per interior ``grain``, b one per row,
    x_jammed (``columns`` per contact), mu >= 0, force_scale > 0."""
    from ..errors import require_array
    source = problem.source or source
    m, n = problem.n_contacts, problem.n_interior
    A = problem.A
    if m == 0:
        raise InputError(source, "contacts", "no unknown contact in the problem (nothing "
                         "to analyse or sample)")
    if not sp.issparse(A) or A.shape[1] != per_contact * m or A.shape[0] < per_body * n \
            or not np.all(np.isfinite(A.data)):
        raise InputError(source, "A", f"must be a sparse matrix of finite numbers with "
                         f"{per_contact * m} columns ({per_contact} per unknown contact) and "
                         f">= {per_body * n} rows ({per_body} per interior {grain}, then e.g. "
                         "a plate's balance)", got=getattr(A, "shape", type(A)))
    require_array(source, "b", problem.b, (A.shape[0],), "the loads, one per row of A [F0]")
    require_array(source, "x_jammed", problem.x_jammed, (per_contact * m,),
                  f"{columns} per contact [F0]")
    mu = require_array(source, "mu", problem.mu, (m,), "Coulomb coefficient per contact")
    if mu.size and mu.min() < 0:
        raise InputError(source, "mu", "must be >= 0 (Coulomb coefficients)",
                         got=float(mu.min()))
    if not (np.isfinite(problem.force_scale) and problem.force_scale > 0):
        raise InputError(source, "force_scale", "must be a finite number > 0 (<Fn>, "
                         "the mean normal force) [F0]", got=problem.force_scale)
    return problem
