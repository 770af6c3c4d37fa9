"""Small hand-built jammed packings for tests and demonstrations.

``two_row_packing``: a periodic row of unit disks on the bottom plate with
a second row resting in its grooves and the top plate on the second row.
Its frictionless force state (computed in closed form) is admissible for
any friction coefficient.
"""
from __future__ import annotations

import numpy as np

from forcespace.model.walls import BOTTOM, TOP
from forcespace.model.packing import Packing


def two_row_packing(n_cols: int = 5, spacing: float = 1.2, load: float = 1.0,
                    mu: float = 0.1, seed: int = 0) -> Packing:
    """2*n_cols disks, lower row radius 1 at x = 2*s*i + s, upper row at x = 2*s*j.

    ``spacing`` s (1 < s < 2) sets the gap between lower disks (2s - 2);
    ``load`` [F0] is the top-plate force per upper disk (total n_cols*load).
    """
    s = float(spacing)
    if not 1.0 < s < 2.0:
        raise ValueError("spacing must lie in (1, 2)")
    W = 2 * s * n_cols
    xl = 2 * s * np.arange(n_cols) + s
    yl = np.ones(n_cols)
    ru = np.ones(n_cols)
    xu = 2 * s * np.arange(n_cols)
    yu = 1.0 + np.sqrt((1.0 + ru) ** 2 - s**2)
    x = np.concatenate([xl, xu])
    y = np.concatenate([yl, yu])
    r = np.concatenate([np.ones(n_cols), ru])
    y_top = float(yu.max() + ru[np.argmax(yu)])
    a, b, img, nrm, pts, fn = [], [], [], [], [], []
    tops = [j for j in range(n_cols) if abs(yu[j] + ru[j] - y_top) < 1e-12]
    P = load * n_cols / len(tops)
    for i in range(n_cols):                       # bottom plate contacts
        a.append(BOTTOM); b.append(i); img.append(0); nrm.append((0.0, 1.0))
        pts.append((xl[i], 0.0)); fn.append(np.nan)
    for j in range(n_cols):                       # upper j rests on lower j-1 and lower j
        for i, shift in ((j - 1, 0), (j, 0)):
            ii = i % n_cols
            # lower disk ii at xl[ii]; upper at xu[j] + image*W relative to ii
            image = 1 if i < 0 else 0
            d = np.array([xu[j] + image * W - xl[ii], yu[j] - yl[ii]])
            nv = d / np.linalg.norm(d)
            a.append(ii); b.append(n_cols + j); img.append(image); nrm.append(tuple(nv))
            pts.append(tuple(np.array([xl[ii], yl[ii]]) + nv))
            fn.append(np.nan)
    for j in tops:
        a.append(n_cols + j); b.append(TOP); img.append(0); nrm.append((0.0, 1.0))
        pts.append((xu[j], y_top)); fn.append(np.nan)
    a = np.array(a); b = np.array(b); nrm = np.array(nrm)
    # closed-form frictionless forces: each loaded upper disk j carries Pj
    Pj = np.zeros(n_cols)
    Pj[tops] = P
    fn = np.zeros(len(a))
    down = np.zeros(n_cols)
    for k in range(len(a)):
        if b[k] == TOP:
            fn[k] = P
        elif a[k] >= 0 and b[k] >= n_cols:
            j = b[k] - n_cols
            # two supports of upper j, normals n1, n2: solve f1 n1 + f2 n2 = (0, Pj)
            ks = [q for q in range(len(a)) if b[q] == b[k] and a[q] >= 0]
            A = np.column_stack([nrm[q] for q in ks])
            f = np.linalg.solve(A, np.array([0.0, Pj[j]]))
            fn[k] = f[ks.index(k)]
            down[a[k]] += fn[k] * nrm[k][1]
    for k in range(len(a)):
        if a[k] == BOTTOM:
            fn[k] = down[b[k]]
    return Packing(x=x, y=y, r=r, width=W, periodic_x=True, y_bottom=0.0, y_top=y_top,
                   top_force=load * n_cols, gravity=0.0, density=1.0, mu=mu, plate_mu=0.0,
                   a=a, b=b, normal=nrm, point=np.array(pts), image=np.array(img),
                   gap=np.zeros(len(a)), fn=fn, ft=np.zeros(len(a)), seed=seed,
                   scene_name="two_row_toy", meta={"builder": "forcespace_adapters.toy"})
