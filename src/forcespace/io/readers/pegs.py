"""PeGS output of one frame, in its two layouts.

**The matrices** (:func:`read_pegs`): ``PREFIX_ParticleData.dlm`` and the weighted
adjacency matrices ``PREFIX_NormWeightedAdjacencyMatrix.dlm``,
``PREFIX_TanWeightedAdjacencyMatrix.dlm``, ``PREFIX_BinaryAdjacencyMatrix.dlm``
(comma-separated numbers, as MATLAB's ``dlmwrite`` writes them):

* ParticleData: one row per particle, columns id, x, y, r (pixels; x to the right, y
  down, image coordinates); further columns are ignored (the Daniels-lab frames carry
  the particle's mean force in a fifth) except an edge flag (``edge_column``: 0 inside,
  +-1, +-2 the wall, PeGS2's flags below);
* each matrix: M x M, M the largest particle id (row and column k: particle id k), or
  M + 1 with the last column holding the contacts with the walls (PeGS2's in-memory
  matrices, adjacencyMatrix.m). Entry [i, j] comes from the fit of particle i at its
  contact with j: Binary 1 for a contact (0 or NaN: none), Norm = |f| cos(alpha), Tan =
  |f| sin(alpha) (NaN: no estimate).

**PeGS2's own files** (:func:`read_pegs2`): the adjacency list ``IMAGE_Adjacency.txt``
of one image, or ``Adjacency_list.txt`` of all (rows ``frame, id1, id2, fTan, fNorm``;
id2 = -1: the wall; one row per particle's estimate, so a contact seen from both
particles has two rows; adjacencyMatrix.m: 152-160, 214-215) and the particles
``particle_positions.txt`` (rows ``frame, id, x, y, r, edge``, particleTrack.m: 14, 90,
170) or one image's ``IMAGE_centers.txt`` (rows ``x, y, r, edge``, the ids the row
numbers, contactDetect.m: 14, 154-158); comma-separated, no header (MATLAB
``writematrix``).

What the repositories hold (read at jekollmer/PEGS 30c0792 and XD1729/PeGS2 f1e2515):
neither writes the ``.dlm`` matrices above. PEGS 1.0's PeGSForceAdjMat.m writes only
``*-joAdjacencyAbs.dlm`` (|f|, symmetrised; its Norm/Tan matrices are commented out:
149-150, 167); PeGS2 builds the (M + 1) x (M + 1) Norm and Tan matrices in
memory and writes their entries as the adjacency list. The ``.dlm`` layout is that of the
Daniels-lab frames read by Henkes' RigidLibrary (silkehenkes/RigidLibrary at ca1b63a, the
Configuration class: ReadExpdata), which reads PeGS2's list as here (ReadDataExperiment:
0-based columns 3 = fTan, 4 = fNorm; positions frame, id, x, y, r, edge).

Conventions found in the PeGS sources (file: line):

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
  opposite ones), which is what action and reaction give for a torque sense;
* a wall contact's beta is set by the particle's edge flag: +1 -> 0, -1 -> pi, +2 ->
  pi/2, -2 -> -pi/2 (contactDetect.m: 287-294), i.e. in pixel coordinates +1 the right
  wall, -1 the left, +2 the wall below on the image (y down), -2 the one above
  (particleDetect.m: 114-117: "upper - as vertical pixels are backwards from cartesian,
  actually bottom of image"; the ASCII sketch at contactDetect.m: 24-32 draws 2 at the top);
* PeGS2 rounds the radii it fits with to whole pixels (contactDetect.m: 172); the
  positions file keeps them as detected.

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
        raise InputError(p, "(table)", "must be comma-separated numbers (MATLAB dlmwrite, "
                         f"writematrix) ({str(exc).splitlines()[0][:80]})") from None
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


def _pixel_scale(pixel_scale, source) -> float:
    try:
        s = float(pixel_scale)
        ok = np.isfinite(s) and s > 0
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise InputError(source, "pixel_scale", "must be given: length units per pixel, a "
                         "finite number > 0", got=pixel_scale)
    return s


def _ids(source, ids, field):
    """Particle ids as int64, refused unless finite integers >= 1."""
    if not np.all(np.isfinite(ids)) or np.any(ids != np.round(ids)) or ids.min() < 1:
        raise InputError(source, field, "must be integers >= 1 (the matrices' row index)")
    return ids.astype(np.int64)


def read_pegs(particle_data, *, pixel_scale, mu, wall_mu=None, length_unit: str = "m",
              force_unit: str = "N", edge_column=None, y_down: bool = True,
              gap_tol: float = config.CONTACT_GAP_TOL) -> Packing:
    """A measured :class:`Packing` from one PeGS frame in the matrix layout (module
    docstring: layout, signs).

    ``particle_data``: the ``*ParticleData.dlm`` file (the three matrices beside it, same
    prefix); ``pixel_scale`` (required): length units per pixel; ``mu`` (required),
    ``wall_mu`` (default mu); ``edge_column``: the ParticleData column (0-based) of
    PeGS2's edge flag, needed when the matrices carry the wall column; ``y_down``: pixel
    y points down (images). Every check runs before any analysis.
    """
    mu, wall_mu = check_mu(mu, wall_mu, "pegs")
    s = _pixel_scale(pixel_scale, "pegs")
    files = pegs_files(particle_data)
    pp, table = _dlm(files["particles"], "PeGS particle data")
    if table.shape[1] < 4:
        raise InputError(pp, "(columns)", "must hold id, x, y, r (pixels) and optionally more",
                         got=table.shape[1])
    ids = _ids(pp, table[:, 0], "id (column 1)")
    check_particles(pp, ids, *table[:, 1:4].T)
    mpaths, B, N, T = _matrices(files, int(ids.max()))

    def edge():
        return _edge_column(pp, table, edge_column)
    return _frame(pp, mpaths, ids, table[:, 1:4], edge, (B, N, T), s=s, y_down=y_down,
                  mu=mu, wall_mu=wall_mu, gap_tol=gap_tol, fmt="pegs",
                  units={"length": length_unit, "force": force_unit},
                  edge_column=edge_column,
                  ignored_columns=int(table.shape[1] - 4 - (edge_column is not None)))


def _frame(pp, mpaths, ids, xyr_px, edge, matrices, *, s, y_down, mu, wall_mu, gap_tol, fmt,
           units, **extra) -> Packing:
    """The packing of a PeGS frame from its particles (ids, (n, 3) x, y, r in pixels,
    checked) and its (Binary, Norm, Tan) matrices (M x M or (M + 1) x (M + 1), M the
    largest id); ``edge()``: the particles' edge flags, asked for only when a wall contact
    needs them."""
    B, N, T = matrices
    sign = -1.0 if y_down else 1.0
    x, y, r = xyr_px[:, 0] * s, sign * xyr_px[:, 1] * s, xyr_px[:, 2] * s
    m = int(ids.max())
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
    wall_normal, flags = None, None
    wrow = np.flatnonzero(B[:m, m] != 0) if B.shape[0] == m + 1 else np.zeros(0, np.int64)
    if wrow.size:
        flags = edge()
        wn = _wall_normals(pp, flags, ids, index, wrow, sign)
        ci = np.concatenate([ci, np.full(wrow.size, WALL)])
        cj = np.concatenate([cj, index[wrow + 1]])
        wfn, wft, wn_est, whalf = _estimates(B, N, T, wrow, np.full(wrow.size, m))
        fn, ft = np.concatenate([fn, wfn]), np.concatenate([ft, wft])
        n_est, half = np.concatenate([n_est, wn_est]), np.vstack([half, whalf])
        wall_normal = np.vstack([np.zeros((pairs.shape[0], 2)), wn])
    check_pairs(mpaths[0], ci, cj)
    ft = ft if y_down else -ft
    prov = provenance(fmt, [pp, *mpaths], units,
                      CONVENTIONS + ("" if y_down else "; y_down=False: ft = -fTan"),
                      pixel_scale=s, y_down=bool(y_down), two_estimates=int((n_est == 2).sum()),
                      one_estimate=int((n_est == 1).sum()), no_estimate=int((n_est == 0).sum()),
                      **extra)
    return assemble(pp, x=x, y=y, r=r, ci=ci, cj=cj, fn=np.nan_to_num(fn),
                    ft=np.nan_to_num(ft), known=n_est > 0, mu=mu, wall_mu=wall_mu,
                    provenance=prov, wall_normal=wall_normal, sigma=_uncertainty(n_est, half),
                    boundary=None if flags is None else flags != 0, gap_tol=gap_tol, ids=ids,
                    scene_name=f"measured: {fmt}")


def _edge_column(pp, table, edge_column):
    """The edge flags (n,) of ParticleData's column ``edge_column``, checked."""
    if edge_column is None:
        raise InputError(pp, "edge_column", "the matrices carry the wall column: give the "
                         "ParticleData column (0-based) of PeGS2's edge flag (+-1, +-2)")
    if not (isinstance(edge_column, (int, np.integer)) and 4 <= edge_column < table.shape[1]):
        raise InputError(pp, "edge_column", f"must be a column index in 4..{table.shape[1] - 1}",
                         got=edge_column)
    return _edge_flags(pp, table[:, edge_column], f"edge flag (column {edge_column + 1})")


def _edge_flags(pp, edge, field):
    if not np.all(np.isin(edge, (0, 1, -1, 2, -2))):
        raise InputError(pp, field, "must be 0, +-1 or +-2 (PeGS2's edge directions in a "
                         "rectangular cell)")
    return edge.astype(int)


def _wall_normals(pp, edge, ids, index, wrow, sign):
    """Normals (k, 2) from the wall into each wall-contact particle (ids wrow + 1)."""
    k = index[wrow + 1]
    if np.any(k < 0):
        raise InputError(pp, f"wall contact of id {wrow[k < 0][0] + 1}", "a particle id that "
                         "is not in the particle data")
    flags = edge[k]
    if np.any(flags == 0):
        raise InputError(pp, f"edge flag of id {ids[k[flags == 0][0]]}", "a particle with a "
                         "wall contact needs its edge flag (+-1, +-2: which wall)")
    beta = np.array([EDGE_BETA[f] for f in flags])
    # the contact point lies at r (cos beta, sin beta) (pixels, y down); the normal from
    # the wall into the particle is its opposite, y mapped as the positions
    return np.column_stack([-np.cos(beta), -sign * np.sin(beta)])


# ---------------------------------------------------------------------- PeGS2's files
def _one_frame(path, table, frame):
    """The rows of ``table`` (first column: frame) of ``frame`` (None: the only one)."""
    frames = np.unique(table[:, 0])
    if frame is None:
        if frames.size > 1:
            raise InputError(path, "frame", f"the file holds {frames.size} frames "
                             f"({frames[0]:g} ... {frames[-1]:g}): say which (frame=...)")
        return table
    if not np.any(frames == frame):
        raise InputError(path, "frame", f"is not in the file (its frames: {frames[0]:g} ... "
                         f"{frames[-1]:g})", got=frame)
    return table[table[:, 0] == frame]


def _pegs2_particles(positions, frame):
    """(path, ids, (n, 3) x, y, r pixels, edge flags) of PeGS2's particle file."""
    pp, pos = _dlm(positions, "PeGS2 particle positions")
    if pos.shape[1] == 6:
        pos = _one_frame(pp, pos, frame)
        ids, xyr, edge = _ids(pp, pos[:, 1], "particle id (column 2)"), pos[:, 2:5], pos[:, 5]
    elif pos.shape[1] == 4:
        ids, xyr, edge = np.arange(1, pos.shape[0] + 1), pos[:, :3], pos[:, 3]
    else:
        raise InputError(pp, "(columns)", "must be frame, id, x, y, r, edge "
                         "(particle_positions.txt) or x, y, r, edge (*_centers.txt)",
                         got=pos.shape[1])
    return pp, ids, xyr, edge


def _pegs2_matrices(ap, adj, ids):
    """(Binary, Norm, Tan) (M + 1) x (M + 1) of PeGS2's list rows (frame, id1, id2, fTan,
    fNorm), the last column the wall, as adjacencyMatrix.m builds them."""
    m = int(ids.max())
    for col, name in ((1, "id1 (column 2)"), (2, "id2 (column 3)")):
        v = adj[:, col]
        bad = np.flatnonzero(~np.isfinite(v) | (v != np.round(v)) | ((v < 1) & (v != -1)))
        if bad.size:
            raise InputError(ap, f"{name}, row {bad[0] + 1}", "must be a particle id (an "
                             "integer >= 1; id2 = -1: the wall)", got=adj[bad[0], col].item())
        unknown = np.flatnonzero((v != -1) & ~np.isin(v, ids))
        if unknown.size:
            raise InputError(ap, f"{name}, row {unknown[0] + 1}", "must be the id of a "
                             "particle in the positions file", got=int(v[unknown[0]]))
    bad = np.flatnonzero(~np.all(np.isfinite(adj[:, 3:5]), axis=1))
    if bad.size:
        raise InputError(ap, f"fTan, fNorm (row {bad[0] + 1})", "must be finite numbers "
                         "(PeGS2 lists only contacts with an estimate)")
    i = adj[:, 1].astype(np.int64) - 1
    j = np.where(adj[:, 2] == -1, m, adj[:, 2] - 1).astype(np.int64)
    if np.any(i == j):
        k = int(np.flatnonzero(i == j)[0])
        raise InputError(ap, f"row {k + 1}", "a particle cannot touch itself",
                         got=int(adj[k, 1]))
    _, first, counts = np.unique(np.stack([i, j], 1), axis=0, return_index=True,
                                 return_counts=True)
    if np.any(counts > 1):
        k = int(first[np.flatnonzero(counts > 1)[0]])
        raise InputError(ap, f"row {k + 1}", "each (id1, id2) estimate must be listed once "
                         "(this one appears again)")
    B, N, T = np.zeros((m + 1, m + 1)), np.full((m + 1, m + 1), np.nan), np.full((m + 1, m + 1),
                                                                                 np.nan)
    B[i, j], T[i, j], N[i, j] = 1.0, adj[:, 3], adj[:, 4]
    return B, N, T


def read_pegs2(adjacency, positions, *, pixel_scale, mu, frame=None, wall_mu=None,
               length_unit: str = "m", force_unit: str = "N", y_down: bool = True,
               gap_tol: float = config.CONTACT_GAP_TOL) -> Packing:
    """A measured :class:`Packing` from one frame of PeGS2's own files (module docstring).

    ``adjacency``: ``*_Adjacency.txt`` or ``Adjacency_list.txt`` (frame, id1, id2, fTan,
    fNorm; id2 = -1 the wall); ``positions``: ``particle_positions.txt`` (frame, id, x, y,
    r, edge) or ``*_centers.txt`` (x, y, r, edge); ``frame``: which frame (default: the
    only one in the files); the rest as :func:`read_pegs`. Every check runs before any
    analysis."""
    mu, wall_mu = check_mu(mu, wall_mu, "pegs2")
    s = _pixel_scale(pixel_scale, "pegs2")
    pp, ids, xyr, edge = _pegs2_particles(positions, frame)
    ap, adj = _dlm(adjacency, "PeGS2 adjacency list")
    if adj.shape[1] != 5:
        raise InputError(ap, "(columns)", "must be frame, id1, id2, fTan, fNorm (PeGS2's "
                         "adjacency list)", got=adj.shape[1])
    adj = _one_frame(ap, adj, frame)
    check_particles(pp, ids, *xyr.T)
    matrices = _pegs2_matrices(ap, adj, ids)
    return _frame(pp, [ap], ids, xyr, lambda: _edge_flags(pp, edge, "edge (last column)"),
                  matrices, s=s, y_down=y_down, mu=mu, wall_mu=wall_mu, gap_tol=gap_tol,
                  fmt="pegs2", units={"length": length_unit, "force": force_unit},
                  frame=None if frame is None else float(frame))


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


def _pegs_arrays(p: Packing, s: float, noise):
    """(ParticleData table (n, 5): id, x, y, r pixels, edge flag; Binary, Norm, Tan
    matrices; packing contacts left out) of :func:`write_pegs` (its docstring)."""
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
    table = np.column_stack([np.arange(1, n + 1), (p.x - x0) / s, (y1 - p.y) / s, p.r / s,
                             edge])
    return table, B, N, T, np.array(left_out, np.int64)


def write_pegs(packing: Packing, directory, *, pixel_scale: float, prefix: str = "frame_",
               noise=None) -> dict:
    """Write ``packing`` as one PeGS frame in the matrix layout into ``directory`` (what
    :func:`read_pegs` reads; for tests and round trips: forcespace's own packings only).

    ids = disk index + 1; pixels x_px = (x - x0) / s, y_px = (y1 - y) / s (y down, the
    frame's top edge at 0); both estimates of a contact equal (``noise`` (Nc, 2): added to
    the second estimate of fn, ft instead); contacts across a periodic seam are left out
    (an image has no period); wall contacts go to the wall column with PeGS2's edge flag
    in ParticleData's column 5 (``edge_column=4``); a disk may touch one wall, along an
    axis. Returns {paths, left_out (packing contact indices not written)}."""
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    table, B, N, T, left_out = _pegs_arrays(packing, float(pixel_scale), noise)
    files = pegs_files(d / (prefix + SUFFIXES["particles"]))
    for key, arr in (("particles", table), ("binary", B), ("norm", N), ("tan", T)):
        _write_table(files[key], arr)
    return {"paths": files, "left_out": left_out}


def write_pegs2(packing: Packing, directory, *, pixel_scale: float, frame: int = 1,
                image: str = "frame", noise=None) -> dict:
    """Write ``packing`` as one frame of PeGS2's own files into ``directory`` (what
    :func:`read_pegs2` reads; forcespace's own packings only): ``particle_positions.txt``
    (frame, id, x, y, r, edge) and ``IMAGE_Adjacency.txt`` (frame, id1, id2, fTan, fNorm,
    one row per estimate, id2 = -1 the wall); pixels, estimates and what is left out as
    :func:`write_pegs`. Returns {paths: {positions, adjacency}, left_out}."""
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    table, B, N, T, left_out = _pegs_arrays(packing, float(pixel_scale), noise)
    n = packing.n_disks
    i, j = np.nonzero(B)
    adj = np.column_stack([np.full(i.size, frame), i + 1, np.where(j == n, -1, j + 1),
                           T[i, j], N[i, j]])
    pos = np.column_stack([np.full(n, frame), table])
    files = {"positions": d / "particle_positions.txt", "adjacency": d / f"{image}_Adjacency.txt"}
    _write_table(files["positions"], pos)
    _write_table(files["adjacency"], adj)
    return {"paths": files, "left_out": left_out}


def _write_table(path, arr):
    with atomic_path(path) as tmp:
        np.savetxt(tmp, arr, delimiter=",", fmt="%.17g")
