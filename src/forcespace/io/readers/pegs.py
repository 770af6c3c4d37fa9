"""PeGS / PeGS2 output of one frame: ``PREFIX_ParticleData.dlm`` and the weighted
adjacency matrices ``PREFIX_NormWeightedAdjacencyMatrix.dlm``,
``PREFIX_TanWeightedAdjacencyMatrix.dlm``, ``PREFIX_BinaryAdjacencyMatrix.dlm``.

The layout read here (comma-separated numbers, as MATLAB's ``dlmwrite`` writes them):

* ParticleData: one row per particle, columns id, x, y, r (pixels; x to the right, y
  down, image coordinates); further columns are ignored except PeGS2's edge flag
  (``edge_column``: 0 inside, +-1 at the right / left wall, +-2 at the wall at
  beta = +-pi/2, contactDetect.m of PeGS2);
* each matrix: M x M, M the largest particle id (row and column k: particle id k), or
  M + 1 with the last column holding the contacts with the walls (PeGS2's extra
  "edge" column, adjacencyMatrix.m). Entry [i, j] comes from the fit of particle i at
  its contact with j: Binary 1 for a contact (0 or NaN: none), Norm = |f| cos(alpha),
  Tan = |f| sin(alpha) (NaN: no estimate).

Conventions found in the PeGS sources (file: line, in jekollmer/PEGS at 30c0792 and
XD1729/PeGS2 at f1e2515):

* fNorm = f cos(alpha), fTan = f sin(alpha) (PEGS PeGSForceAdjMat.m: 129-130; PeGS2
  adjacencyMatrix.m: 128-129), alpha the angle of the force from the contact's inward
  normal, "0 purely normal, +-pi/2 purely tangential" (adjacencyMatrix.m: 19): fNorm >
  0 is compression;
* beta is the contact's direction from the particle's centre in pixel coordinates,
  beta = atan2(y_j - y_i, x_j - x_i) (PeGS2 contactDetect.m: 264, 270; the contact point
  is drawn at r (cos beta, sin beta), adjacencyMatrix.m: 138-139);
* force balance uses directions alpha + beta' with beta' = pi/2 - beta (forceBalance.m:
  2 and 30-31 in PeGS2, 10 and 38-39 in PEGS) and torque balance is sum f sin(alpha) = 0
  (PeGS2 forceBalance.m: 57, PEGS: 65): the force on a particle at a contact points along
  beta + pi - alpha in pixel coordinates, so fTan is the contact's torque / r on that
  particle, positive from +x towards +y of the image (clockwise on screen, y down), the
  same sense on every particle: both particles of a contact report the same fTan (not
  opposite ones), which is what action and reaction give for a torque sense.

Mapping to forcespace (``y_down=True``, the default): x = x_px s, y = -y_px s, r = r_px s
(s = ``pixel_scale``, length units per pixel), so y points up; a contact's fn is the
mean of fNorm over its estimates and ft = fTan (mean): forcespace's torque -r ft
counter-clockwise equals PeGS' r fTan clockwise. With ``y_down=False`` (coordinates
already y up) ft = -fTan. A contact with two estimates (one from each particle) gets
the uncertainty |difference| / 2 per component; one with a single estimate gets the
pooled single-estimate uncertainty rms(|difference|) / sqrt(2) of the two-estimate
contacts (none: no uncertainty stored); a contact the binary matrix marks without any
estimate is geometry only (force unknown).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import config
from ...errors import InputError
from ...model.packing import Packing
from ...model.walls import WALL
from ..h5 import atomic_path
from .common import assemble, check_mu, check_pairs, check_particles, provenance, source_file

SUFFIXES = {"particles": "ParticleData.dlm", "norm": "NormWeightedAdjacencyMatrix.dlm",
            "tan": "TanWeightedAdjacencyMatrix.dlm", "binary": "BinaryAdjacencyMatrix.dlm"}
EDGE_BETA = {1: 0.0, -1: np.pi, 2: np.pi / 2, -2: -np.pi / 2}   # PeGS2 contactDetect.m
CONVENTIONS = ("PeGS: fNorm = f cos(alpha) (compression > 0), fTan = f sin(alpha) = torque / "
               "r on the particle, positive from +x to +y of the image (y down); read with "
               "y -> -y: fn = fNorm, ft = fTan (forcespace: force fn n + ft t on b, t = n "
               "turned +90 deg, torque -r ft); two estimates of a contact averaged")


def pegs_files(particle_data) -> dict:
    """The four files of a PeGS frame, from its ``*ParticleData.dlm`` path (or the prefix)."""
    p = Path(particle_data)
    name = p.name
    prefix = name[:-len(SUFFIXES["particles"])] if name.endswith(SUFFIXES["particles"]) \
        else name
    return {k: p.with_name(prefix + s) for k, s in SUFFIXES.items()}


def _dlm(path, what):
    p = source_file(path, what)
    try:
        with open(p) as fh:
            a = np.loadtxt(fh, delimiter=",", ndmin=2)
    except (ValueError, UnicodeDecodeError) as exc:
        raise InputError(p, "(table)", f"must be comma-separated numbers (MATLAB dlmwrite) "
                         f"({str(exc).splitlines()[0][:80]})") from None
    if a.size == 0:
        raise InputError(p, "(table)", f"is empty (the {what})")
    return p, a


def _matrices(files, m):
    """(Binary, Norm, Tan) as (M', M') arrays, M' = m or m + 1, checked."""
    out, size = [], None
    for key in ("binary", "norm", "tan"):
        p, a = _dlm(files[key], f"{SUFFIXES[key]}, beside the particle data")
        if a.shape[0] != a.shape[1] or a.shape[0] not in (m, m + 1):
            raise InputError(p, "(shape)", f"must be {m} x {m} (the largest particle id) or "
                             f"{m + 1} x {m + 1} (plus the wall column)", got=a.shape)
        if size is not None and a.shape[0] != size:
            raise InputError(p, "(shape)", "must match the binary matrix's size",
                             got=a.shape)
        size = a.shape[0]
        if np.isinf(a).any():
            raise InputError(p, "(entries)", "must be finite numbers or NaN (no estimate)")
        out.append((p, a))
    (pb, B), (pn, N), (pt, T) = out
    B = np.nan_to_num(B, nan=0.0)
    if not np.all(np.isin(B, (0.0, 1.0))):
        raise InputError(pb, "(entries)", "must be 0 or 1 (1: a contact)")
    diag = np.flatnonzero(np.diag(B)[:m])
    if diag.size:
        raise InputError(pb, f"entry ({diag[0] + 1}, {diag[0] + 1})", "a particle cannot touch "
                         "itself (the diagonal must be 0)")
    N = np.where(N == 0.0, np.where(B != 0, 0.0, np.nan), N)   # 0 where there is no contact
    T = np.where(T == 0.0, np.where(B != 0, 0.0, np.nan), T)
    stray = np.flatnonzero((B == 0).ravel() & ~np.isnan(N).ravel())
    if stray.size:
        i, j = np.unravel_index(stray[0], B.shape)
        raise InputError(pn, f"entry ({i + 1}, {j + 1})", "a normal force on a pair the binary "
                         "matrix says does not touch", got=float(N[i, j]))
    half = np.flatnonzero((np.isnan(N) != np.isnan(T)).ravel() & (B != 0).ravel())
    if half.size:
        i, j = np.unravel_index(half[0], B.shape)
        raise InputError(pt, f"entry ({i + 1}, {j + 1})", "the normal and tangential "
                         "estimates of a contact come together (one of them is NaN)")
    return (pb, pn, pt), B, N, T


def _estimates(B, N, T, rows, cols):
    """Per contact (rows[k] -> cols[k] and back): (fn, ft, n_estimates, half differences)."""
    e1 = (B[rows, cols] != 0) & ~np.isnan(N[rows, cols])
    e2 = (B[cols, rows] != 0) & ~np.isnan(N[cols, rows])
    n_est = e1.astype(int) + e2
    fn = np.where(e1, N[rows, cols], 0.0) + np.where(e2, N[cols, rows], 0.0)
    ft = np.where(e1, T[rows, cols], 0.0) + np.where(e2, T[cols, rows], 0.0)
    with np.errstate(invalid="ignore"):
        fn, ft = fn / n_est, ft / n_est
    two = e1 & e2
    half = np.zeros((rows.size, 2))
    half[two, 0] = np.abs(N[rows, cols] - N[cols, rows])[two] / 2
    half[two, 1] = np.abs(T[rows, cols] - T[cols, rows])[two] / 2
    return fn, ft, n_est, half


def read_pegs(particle_data, *, pixel_scale, mu, wall_mu=None, length_unit: str = "m",
              force_unit: str = "N", edge_column=None, y_down: bool = True,
              gap_tol: float = config.CONTACT_GAP_TOL) -> Packing:
    """A measured :class:`Packing` from one PeGS frame (module docstring: layout, signs).

    ``particle_data``: the ``*ParticleData.dlm`` file (the three matrices beside it, same
    prefix); ``pixel_scale`` (required): length units per pixel; ``mu`` (required),
    ``wall_mu`` (default mu); ``edge_column``: the ParticleData column (0-based) of
    PeGS2's edge flag, needed when the matrices carry the wall column; ``y_down``: pixel
    y points down (images). Every check runs before any analysis.
    """
    mu, wall_mu = check_mu(mu, wall_mu, "pegs")
    try:
        s = float(pixel_scale)
        ok = np.isfinite(s) and s > 0
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise InputError("pegs", "pixel_scale", "must be given: length units per pixel, a "
                         "finite number > 0", got=pixel_scale)
    files = pegs_files(particle_data)
    pp, table = _dlm(files["particles"], "PeGS particle data")
    if table.shape[1] < 4:
        raise InputError(pp, "(columns)", "must hold id, x, y, r (pixels) and optionally more",
                         got=table.shape[1])
    ids = table[:, 0]
    if not np.all(np.isfinite(ids)) or np.any(ids != np.round(ids)) or ids.min() < 1:
        raise InputError(pp, "id (column 1)", "must be integers >= 1 (the matrices' row index)")
    ids = ids.astype(np.int64)
    sign = -1.0 if y_down else 1.0
    x, y, r = table[:, 1] * s, sign * table[:, 2] * s, table[:, 3] * s
    check_particles(pp, ids, x, y, r)
    m = int(ids.max())
    mpaths, B, N, T = _matrices(files, m)
    walls = B.shape[0] == m + 1
    index = -np.ones(m + 1, np.int64)
    index[ids] = np.arange(ids.size)
    pairs = np.argwhere(np.triu((B[:m, :m] != 0) | (B[:m, :m] != 0).T, 1))  # 0-based ids - 1
    orphan = [int(k) + 1 for k in np.unique(pairs) if index[k + 1] < 0]
    if orphan:
        raise InputError(mpaths[0], f"row/column {orphan[0]}", "a contact of a particle id "
                         "that is not in the particle data", got=orphan[0])
    rows, cols = pairs[:, 0], pairs[:, 1]
    ci, cj = index[rows + 1], index[cols + 1]
    fn, ft, n_est, half = _estimates(B, N, T, rows, cols)
    wall_normal, edge = None, None
    if walls:
        wrow = np.flatnonzero(B[:m, m] != 0)
        if wrow.size:
            edge, wn = _wall_normals(pp, table, ids, index, wrow, edge_column, sign)
            ci = np.concatenate([ci, np.full(wrow.size, WALL)])
            cj = np.concatenate([cj, index[wrow + 1]])
            wfn, wft, wn_est, whalf = _estimates(B, N, T, wrow, np.full(wrow.size, m))
            fn, ft = np.concatenate([fn, wfn]), np.concatenate([ft, wft])
            n_est, half = np.concatenate([n_est, wn_est]), np.vstack([half, whalf])
            wall_normal = np.vstack([np.zeros((pairs.shape[0], 2)), wn])
    check_pairs(mpaths[0], ci, cj)
    ft = ft if y_down else -ft
    sigma = _uncertainty(n_est, half)
    prov = provenance("pegs", [pp, *mpaths], {"length": length_unit, "force": force_unit},
                      CONVENTIONS + ("" if y_down else "; y_down=False: ft = -fTan"),
                      pixel_scale=s, y_down=bool(y_down), edge_column=edge_column,
                      two_estimates=int((n_est == 2).sum()),
                      one_estimate=int((n_est == 1).sum()), no_estimate=int((n_est == 0).sum()),
                      ignored_columns=int(table.shape[1] - 4 - (edge_column is not None)))
    return assemble(pp, x=x, y=y, r=r, ci=ci, cj=cj, fn=np.nan_to_num(fn),
                    ft=np.nan_to_num(ft), known=n_est > 0, mu=mu, wall_mu=wall_mu,
                    provenance=prov, wall_normal=wall_normal, sigma=sigma,
                    boundary=None if edge is None else edge != 0, gap_tol=gap_tol, ids=ids,
                    scene_name="measured: pegs")


def _wall_normals(pp, table, ids, index, wrow, edge_column, sign):
    """(edge flags (n,), normals (k, 2) from the wall into each wall-contact particle)."""
    if edge_column is None:
        raise InputError(pp, "edge_column", "the matrices carry the wall column: give the "
                         "ParticleData column (0-based) of PeGS2's edge flag (+-1, +-2)")
    if not (isinstance(edge_column, (int, np.integer)) and 4 <= edge_column < table.shape[1]):
        raise InputError(pp, "edge_column", f"must be a column index in 4..{table.shape[1] - 1}",
                         got=edge_column)
    edge = table[:, edge_column]
    if not np.all(np.isin(edge, (0, 1, -1, 2, -2))):
        raise InputError(pp, f"edge flag (column {edge_column + 1})", "must be 0, +-1 or +-2 "
                         "(PeGS2's edge directions)")
    k = index[wrow + 1]
    if np.any(k < 0):
        raise InputError(pp, f"wall contact of id {wrow[k < 0][0] + 1}", "a particle id that "
                         "is not in the particle data")
    flags = edge[k].astype(int)
    if np.any(flags == 0):
        raise InputError(pp, f"edge flag of id {ids[k[flags == 0][0]]}", "a particle with a "
                         "wall contact needs its edge flag (+-1, +-2: which wall)")
    beta = np.array([EDGE_BETA[f] for f in flags])
    # the contact point lies at r (cos beta, sin beta) (pixels, y down); the normal from
    # the wall into the particle is its opposite, y mapped as the positions
    return edge.astype(int), np.column_stack([-np.cos(beta), -sign * np.sin(beta)])


def _uncertainty(n_est, half):
    """(Nc, 2) uncertainty of fn, ft (module docstring), or None without two-estimate
    contacts."""
    two = n_est == 2
    if not two.any():
        return None
    single = np.sqrt(np.mean(half[two] ** 2, axis=0)) * np.sqrt(2.0)   # one estimate's
    floor = 1e-3 * np.maximum(single, 1e-300)
    sigma = np.where(two[:, None], np.maximum(half, floor), single)
    return np.where((n_est == 0)[:, None], 0.0, sigma)


def write_pegs(packing: Packing, directory, *, pixel_scale: float, prefix: str = "frame_",
               noise=None) -> dict:
    """Write ``packing`` as one PeGS frame into ``directory`` (the layout
    :func:`read_pegs` reads; for tests and round trips: forcespace's own packings only).

    ids = disk index + 1; pixels x_px = (x - x0) / s, y_px = (y1 - y) / s (y down, the
    frame's top edge at 0); both estimates of a contact equal (``noise`` (Nc, 2): added to
    the second estimate of fn, ft instead); contacts across a periodic seam are left out
    (an image has no period); wall contacts go to the wall column with PeGS2's edge flag
    in ParticleData's column 5 (``edge_column=4``); a disk may touch one wall, along an
    axis. Returns {paths, left_out (packing contact indices not written)}."""
    p, s = packing, float(pixel_scale)
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    n = p.n_disks
    x0, y1 = float((p.x - p.r).min()), float((p.y + p.r).max())
    walls = (p.a < 0) | (p.b < 0)
    size = n + 1 if walls.any() else n
    B, N, T = np.zeros((size, size)), np.full((size, size), np.nan), np.full((size, size),
                                                                                np.nan)
    edge = np.zeros(n)
    left_out = []
    noise = np.zeros((p.n_contacts, 2)) if noise is None else np.asarray(noise, float)
    for k in range(p.n_contacts):
        a, b, fn, ft = int(p.a[k]), int(p.b[k]), float(p.fn[k]), float(p.ft[k])
        if a >= 0 and b >= 0:
            if p.image[k] != 0:
                left_out.append(k)
                continue
            first, second = (a, b), (b, a)
        else:
            disk = b if a < 0 else a
            into = p.normal[k] if a < 0 else -p.normal[k]        # from the wall into the disk
            beta = float(np.arctan2(into[1], -into[0]))           # contact point, pixels
            flag = min(EDGE_BETA, key=lambda f: abs(np.angle(np.exp(1j * (EDGE_BETA[f] - beta)))))
            if abs(np.angle(np.exp(1j * (EDGE_BETA[flag] - beta)))) > 1e-9 or edge[disk]:
                left_out.append(k)
                continue
            edge[disk] = flag
            first, second = (disk, n), None
        B[first] = 1.0
        N[first], T[first] = fn, ft
        if second is not None:
            B[second] = 1.0
            N[second], T[second] = fn + noise[k, 0], ft + noise[k, 1]
    files = pegs_files(d / (prefix + SUFFIXES["particles"]))
    table = np.column_stack([np.arange(1, n + 1), (p.x - x0) / s, (y1 - p.y) / s, p.r / s,
                             edge])
    for key, arr in (("particles", table), ("binary", B), ("norm", N), ("tan", T)):
        with atomic_path(files[key]) as tmp:
            np.savetxt(tmp, arr, delimiter=",", fmt="%.17g")
    return {"paths": files, "left_out": np.array(left_out, np.int64)}
