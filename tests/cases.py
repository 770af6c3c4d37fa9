"""Small hand-built jammed packings for the tests (moved here from the adapters, which are
a plug-in and no place for test fixtures).

``two_row_packing``: a periodic row of unit disks on the bottom plate with a second row
resting in its grooves and the top plate on the second row. Its frictionless force state
(computed in closed form) is admissible for any friction coefficient.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from forcespace.model.packing import BOTTOM, TOP, Packing


def two_row_packing(n_cols: int = 5, spacing: float = 1.2, load: float = 1.0,
                    mu: float = 0.1, seed: int = 0) -> Packing:
    """2*n_cols unit disks: lower row at x = 2*s*i + s, y = 1; upper row at x = 2*s*j,
    resting on lower disks j-1 and j. ``spacing`` s (1 < s < 2) sets the gap between lower
    disks (2s - 2); ``load`` [F0] is the top-plate force per upper disk."""
    s = float(spacing)
    if not 1.0 < s < 2.0:
        raise ValueError("spacing must lie in (1, 2)")
    W = 2 * s * n_cols
    xl, xu = 2 * s * np.arange(n_cols) + s, 2 * s * np.arange(n_cols)
    yu = 1.0 + np.sqrt(4.0 - s**2)
    x = np.concatenate([xl, xu])
    y = np.concatenate([np.ones(n_cols), np.full(n_cols, yu)])
    r = np.ones(2 * n_cols)
    y_top = yu + 1.0
    a, b, img = [], [], []
    for i in range(n_cols):                       # bottom plate
        a.append(BOTTOM); b.append(i); img.append(0)
    for j in range(n_cols):                       # upper j on lower j-1 (periodic) and j
        for i in (j - 1, j):
            a.append(i % n_cols); b.append(n_cols + j); img.append(1 if i < 0 else 0)
    for j in range(n_cols):                       # top plate
        a.append(n_cols + j); b.append(TOP); img.append(0)
    p = Packing.from_arrays(x, y, r, a, b, width=W, periodic_x=True, image=img,
                            y_bottom=0.0, y_top=y_top, top_force=load * n_cols, mu=mu,
                            scene_name="two_row_toy")
    # closed-form frictionless forces: each upper disk carries `load` on two supports
    fn = np.zeros(p.n_contacts)
    fn[p.b == TOP] = load
    down = np.zeros(n_cols)
    for j in range(n_cols):
        ks = np.flatnonzero(p.b == n_cols + j)
        f = np.linalg.solve(p.normal[ks].T, np.array([0.0, load]))
        fn[ks] = f
        np.add.at(down, p.a[ks], f * p.normal[ks, 1])
    fn[p.a == BOTTOM] = down[p.b[p.a == BOTTOM]]
    return replace(p.with_forces(fn, np.zeros(p.n_contacts)), seed=seed,
                   meta={"builder": "tests/cases.py"})


def sphere_on_supports(pos, r, mu, load):
    """The last of the spheres ``pos`` (n, 3), ``r`` (n,) held by the others (fixed
    supports, each touching it) under the fixed ``load`` (3,) [F0]: (SpherePacking, its
    SphereStaticsProblem with that sphere interior; b = -(loads))."""
    from forcespace.model.sphere_packing import SpherePacking
    from forcespace.model.sphere_problem import build_sphere_problem
    n = len(r)
    below = list(range(n - 1))
    p = SpherePacking.from_arrays(pos, r, below, [n - 1] * len(below), lateral=(50, 50),
                                  mu=mu, fn=np.ones(len(below)))
    interior = np.arange(n) == n - 1
    prob = build_sphere_problem(p, interior, (), "hand", support_mask=~interior,
                                rattlers=np.zeros(n, bool))
    prob.b[:3] -= np.asarray(load, float)
    return p, prob


def conic_problem(rows, b, mu):
    """A SphereStaticsProblem of len(mu) contacts with the equality rows ``rows`` (k, 3m)
    and right-hand side ``b`` (no spheres: S = {A x = b, x in the cones})."""
    import scipy.sparse as sp

    from forcespace.model.sphere_problem import SphereStaticsProblem
    m = len(mu)
    frame = np.tile(np.eye(3), (m, 1, 1))
    return SphereStaticsProblem(
        kind="hand", height=None, A=sp.csr_matrix(np.asarray(rows, float)),
        b=np.asarray(b, float), mu=np.asarray(mu, float), contacts=np.arange(m),
        spheres=np.zeros(0, np.int64), rattlers=np.zeros(0, np.int64),
        load_contacts=np.zeros(0, np.int64), ends=np.full((m, 2), -1), frame=frame,
        x_jammed=np.zeros(3 * m), force_scale=1.0, mass=np.zeros(0), radius=np.zeros(0),
        meta={"packing_fn": np.zeros(m), "packing_ft": np.zeros((m, 3))})
