"""Contact detection: cell list, minimum-image periodic x, plates and side walls.

Pure numba kernels behind one public function, :func:`detect_contacts`. Body layout
and contact convention: :mod:`forcespace.engine.records`. Normals point from a to b:
bottom->disk (0, 1), disk->top (0, 1), left->disk (1, 0), disk->right (1, 0); the
wall positions live in the body arrays (``y[n]`` lower plate, ``y[n+1]`` upper plate;
side walls at x = 0 and x = width). Spheres: :func:`detect_contacts3`, the same cell
list in three dimensions (periodic x and y, plates normal to z).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..kernels import kernel
from ..model.walls import N_WALL_SLOTS, SLOT_BOTTOM, SLOT_LEFT, SLOT_RIGHT, SLOT_TOP
from .records import Box, Box3


class Grid(NamedTuple):
    """The cell list of :func:`detect_kernel`: ncx x ncy cells of width cx [R] (height
    at least ``cell``), rows counted from ymin [R]; head (ncx*ncy,) first disk of a cell
    (-1: none), nxt (n,) next disk of the same cell, cix, ciy (n,) a disk's cell."""

    ncx: int
    ncy: int
    cx: float
    ymin: float
    head: np.ndarray
    nxt: np.ndarray
    cix: np.ndarray
    ciy: np.ndarray


def detect_contacts(x, y, r, box: Box, margin: float):
    """All pairs (disk-disk and disk-wall) whose gap is below ``margin`` [R].

    x, y: body positions [R], shape (n+4,) (the wall slots hold the plate heights);
    r: disk radii (n,) [R]; ``box``: :class:`~forcespace.engine.records.Box`.
    Returns ``ints`` (Nc, 3) int64 = (a, b, image) and ``floats`` (Nc, 3) = (nx, ny,
    gap [R]), sorted by the key a*(n+4)+b. With periodic x, b's centre is at
    x[b] + image*width (minimum image).
    """
    r = np.ascontiguousarray(r, dtype=float)
    n = r.shape[0]
    x = np.ascontiguousarray(x, dtype=float)
    y = np.ascontiguousarray(y, dtype=float)
    if x.shape != (n + N_WALL_SLOTS,) or y.shape != (n + N_WALL_SLOTS,):
        raise ValueError(f"x and y must have shape (n+{N_WALL_SLOTS},) = ({n + N_WALL_SLOTS},)")
    box = Box(float(box.width), bool(box.periodic), bool(box.has_bottom), bool(box.has_top),
              bool(box.has_sides))
    return detect_kernel(x, y, r, box, float(margin))



@kernel
def detect_kernel(x, y, r, box, margin):
    """The kernel of :func:`detect_contacts`: x, y (n+4,) [R] body positions, r (n,) [R]
    radii (float64, contiguous), box a Box record, margin [R]; the same results."""
    n = r.shape[0]
    width = box.width
    rmax = 0.0
    ymin = np.inf
    ymax = -np.inf
    for i in range(n):
        rmax = max(rmax, r[i])
        ymin = min(ymin, y[i])
        ymax = max(ymax, y[i])
    cell = 2.0 * rmax + margin
    # at most ~4n + 16 cells: a blown-up configuration (disks far apart) gets
    # larger cells, never an allocation it cannot afford (cells only need to
    # be at least ``cell`` wide for the +-1 neighbour search to be complete)
    max_cells = 4 * n + 16
    ncx = max(1, min(int(width / cell), max_cells))
    cx = width / ncx
    span = ymax - ymin
    if np.isfinite(span):
        ncy = max(1, min(int(span / cell) + 1, max_cells // ncx))
        cy = max(cell, span / ncy * (1.0 + 1e-12))
    else:            # non-finite positions: one row; the caller reports the blow-up
        ncy = 1
        cy = np.inf
    head = -np.ones(ncx * ncy, dtype=np.int64)
    nxt = -np.ones(n, dtype=np.int64)
    cix = np.empty(n, dtype=np.int64)
    ciy = np.empty(n, dtype=np.int64)
    for i in range(n):
        ix = min(max(int(x[i] / cx), 0), ncx - 1)
        iy = min(max(int((y[i] - ymin) / cy), 0), ncy - 1)
        cix[i] = ix
        ciy[i] = iy
        c = iy * ncx + ix
        nxt[i] = head[c]
        head[c] = i
    capacity = 8 * n + 16
    while True:
        buf_i = np.empty((capacity, 3), dtype=np.int64)
        buf_f = np.empty((capacity, 3))
        count = _fill(x, y, r, box, margin, Grid(ncx, ncy, cx, ymin, head, nxt, cix, ciy),
                      buf_i, buf_f)
        if count >= 0:
            break
        capacity *= 2
    return _sorted_by_key(buf_i, buf_f, count, n + N_WALL_SLOTS)


@kernel(inline="always")
def _sorted_by_key(buf_i, buf_f, count, nb):
    """The first ``count`` rows of the detection buffers (either dimension), sorted by
    the contact key a * nb + b (nb bodies)."""
    keys = np.empty(count, dtype=np.int64)
    for k in range(count):
        keys[k] = buf_i[k, 0] * nb + buf_i[k, 1]
    order = np.argsort(keys)
    return buf_i[:count][order], buf_f[:count][order]


@kernel(inline="always")
def _put(buf_i, buf_f, count, a, b, nx, ny, gap, image):
    """Store one contact at row ``count``; returns the new count, or -1 when full."""
    if count < 0 or count >= buf_i.shape[0]:
        return -1
    buf_i[count, 0] = a
    buf_i[count, 1] = b
    buf_i[count, 2] = image
    buf_f[count, 0] = nx
    buf_f[count, 1] = ny
    buf_f[count, 2] = gap
    return count + 1


@kernel(inline="always")
def _columns(c, nc, periodic, out):
    """The distinct cells c-1, c, c+1 along an axis of ``nc`` cells (wrapped when
    ``periodic``, else clipped) into ``out`` (3,); their number. Both dimensions."""
    k = 0
    for d in range(-1, 2):
        j = c + d
        if periodic:
            j = j % nc
        elif j < 0 or j >= nc:
            continue
        dup = False
        for q in range(k):
            if out[q] == j:
                dup = True
        if not dup:
            out[k] = j
            k += 1
    return k


@kernel
def _fill(x, y, r, box, margin, grid, buf_i, buf_f):
    """Write all contacts into the buffers (Nc rows of ``buf_i``, ``buf_f`` as returned by
    :func:`detect_kernel`); the count, or -1 if they do not fit."""
    n = r.shape[0]
    width = box.width
    periodic = box.periodic
    ncx, ncy, head, nxt, cix, ciy = grid.ncx, grid.ncy, grid.head, grid.nxt, grid.cix, grid.ciy
    count = 0
    cols = np.empty(3, dtype=np.int64)
    for i in range(n):
        ncol = _columns(cix[i], ncx, periodic, cols)     # distinct neighbour columns
        for dy in range(-1, 2):
            jy = ciy[i] + dy
            if jy < 0 or jy >= ncy:
                continue
            for q in range(ncol):
                j = head[jy * ncx + cols[q]]
                while j >= 0:
                    if j > i:
                        dx = x[j] - x[i]
                        image = 0
                        if periodic:
                            image = -int(np.floor(dx / width + 0.5))
                            dx += image * width
                        ddy = y[j] - y[i]
                        dist = np.sqrt(dx * dx + ddy * ddy)
                        g = dist - r[i] - r[j]
                        if g < margin:
                            count = _put(buf_i, buf_f, count, i, j,
                                         dx / dist, ddy / dist, g, image)
                    j = nxt[j]
        if box.has_bottom:
            g = y[i] - r[i] - y[n + SLOT_BOTTOM]
            if g < margin:
                count = _put(buf_i, buf_f, count, n + SLOT_BOTTOM, i,
                                            0.0, 1.0, g, 0)
        if box.has_top:
            g = y[n + SLOT_TOP] - y[i] - r[i]
            if g < margin:
                count = _put(buf_i, buf_f, count, i, n + SLOT_TOP,
                                            0.0, 1.0, g, 0)
        if box.has_sides:
            g = x[i] - r[i]
            if g < margin:
                count = _put(buf_i, buf_f, count, n + SLOT_LEFT, i,
                                            1.0, 0.0, g, 0)
            g = width - x[i] - r[i]
            if g < margin:
                count = _put(buf_i, buf_f, count, i, n + SLOT_RIGHT,
                                            1.0, 0.0, g, 0)
    return count


# ---- spheres (3-D): the same cell list with a third axis ------------------------------

class Grid3(NamedTuple):
    """The cell list of :func:`detect3_kernel`: nc (3,) cells per axis, cell sizes cs
    (3,) [R] (x and y divide the periodic extents; z at least the search distance, counted
    from zmin [R]); head (prod nc,) first sphere of a cell (-1: none), nxt (n,) next sphere
    of the same cell, ci (n, 3) a sphere's cell."""

    nc: np.ndarray
    cs: np.ndarray
    zmin: float
    head: np.ndarray
    nxt: np.ndarray
    ci: np.ndarray


def detect_contacts3(pos, r, box, margin: float):
    """All pairs (sphere-sphere and sphere-plate) whose gap is below ``margin`` [R], in 3-D.

    pos: body positions (n+4, 3) [R] (x, y wrapped into the periodic box; the wall slots
    hold the plate heights in column z); r: sphere radii (n,) [R]; ``box``:
    :class:`~forcespace.engine.records.Box3`. Returns ``ints`` (Nc, 4) int64 = (a, b,
    image_x, image_y) and ``floats`` (Nc, 4) = (nx, ny, nz, gap [R]), sorted by the key
    a*(n+4)+b; b's centre is at pos[b] + (image_x*lx, image_y*ly, 0) (minimum image).
    """
    r = np.ascontiguousarray(r, dtype=float)
    n = r.shape[0]
    pos = np.ascontiguousarray(pos, dtype=float)
    if pos.shape != (n + N_WALL_SLOTS, 3):
        raise ValueError(f"pos must have shape (n+{N_WALL_SLOTS}, 3) = ({n + N_WALL_SLOTS}, 3)")
    box = Box3(float(box.lx), float(box.ly), bool(box.has_bottom), bool(box.has_top))
    return detect3_kernel(pos, r, box, float(margin))


@kernel
def detect3_kernel(pos, r, box, margin):
    """The kernel of :func:`detect_contacts3`: pos (n+4, 3) [R], r (n,) [R] (float64,
    contiguous), box a Box3 record, margin [R]; the same results."""
    n = r.shape[0]
    rmax = 0.0
    zmin = np.inf
    zmax = -np.inf
    for i in range(n):
        rmax = max(rmax, r[i])
        zmin = min(zmin, pos[i, 2])
        zmax = max(zmax, pos[i, 2])
    cell = 2.0 * rmax + margin
    max_cells = 4 * n + 16     # as in 2-D: never more cells than the grains can use
    nc = np.ones(3, np.int64)
    cs = np.empty(3)
    nc[0] = max(1, min(int(box.lx / cell), max_cells))
    nc[1] = max(1, min(int(box.ly / cell), max(1, max_cells // nc[0])))
    cs[0] = box.lx / nc[0]
    cs[1] = box.ly / nc[1]
    span = zmax - zmin
    if np.isfinite(span):
        nc[2] = max(1, min(int(span / cell) + 1, max(1, max_cells // (nc[0] * nc[1]))))
        cs[2] = max(cell, span / nc[2] * (1.0 + 1e-12))
    else:            # non-finite positions: one layer; the caller reports the blow-up
        cs[2] = np.inf
    head = -np.ones(nc[0] * nc[1] * nc[2], dtype=np.int64)
    nxt = -np.ones(n, dtype=np.int64)
    ci = np.empty((n, 3), dtype=np.int64)
    for i in range(n):
        for d in range(3):
            rel = pos[i, d] - (zmin if d == 2 else 0.0)
            ci[i, d] = min(max(int(rel / cs[d]), 0), nc[d] - 1)
        c = (ci[i, 2] * nc[1] + ci[i, 1]) * nc[0] + ci[i, 0]
        nxt[i] = head[c]
        head[c] = i
    capacity = 12 * n + 16
    while True:
        buf_i = np.empty((capacity, 4), dtype=np.int64)
        buf_f = np.empty((capacity, 4))
        count = _fill3(pos, r, box, margin, Grid3(nc, cs, zmin, head, nxt, ci), buf_i, buf_f)
        if count >= 0:
            break
        capacity *= 2
    return _sorted_by_key(buf_i, buf_f, count, n + N_WALL_SLOTS)


@kernel(inline="always")
def _put3(buf_i, buf_f, count, a, b, image_x, image_y, d, gap):
    """Store one 3-D contact (normal d (3,)) at row ``count``; the new count, or -1 when
    full."""
    if count < 0 or count >= buf_i.shape[0]:
        return -1
    buf_i[count, 0] = a
    buf_i[count, 1] = b
    buf_i[count, 2] = image_x
    buf_i[count, 3] = image_y
    buf_f[count, 0] = d[0]
    buf_f[count, 1] = d[1]
    buf_f[count, 2] = d[2]
    buf_f[count, 3] = gap
    return count + 1


@kernel
def _fill3(pos, r, box, margin, grid, buf_i, buf_f):
    """Write all 3-D contacts into the buffers (rows as returned by
    :func:`detect3_kernel`); the count, or -1 if they do not fit."""
    n = r.shape[0]
    nc, head, nxt, ci = grid.nc, grid.head, grid.nxt, grid.ci
    count = 0
    cols = np.empty((3, 3), dtype=np.int64)
    ncol = np.empty(3, dtype=np.int64)
    d = np.empty(3)
    up = np.array([0.0, 0.0, 1.0])
    for i in range(n):
        for ax in range(3):
            ncol[ax] = _columns(ci[i, ax], nc[ax], ax < 2, cols[ax])
        for qz in range(ncol[2]):
            for qy in range(ncol[1]):
                for qx in range(ncol[0]):
                    j = head[(cols[2, qz] * nc[1] + cols[1, qy]) * nc[0] + cols[0, qx]]
                    while j >= 0:
                        if j > i:
                            d[0] = pos[j, 0] - pos[i, 0]
                            d[1] = pos[j, 1] - pos[i, 1]
                            d[2] = pos[j, 2] - pos[i, 2]
                            image_x = -int(np.floor(d[0] / box.lx + 0.5))
                            image_y = -int(np.floor(d[1] / box.ly + 0.5))
                            d[0] += image_x * box.lx
                            d[1] += image_y * box.ly
                            dist = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
                            g = dist - r[i] - r[j]
                            if g < margin:
                                d /= dist
                                count = _put3(buf_i, buf_f, count, i, j, image_x, image_y,
                                              d, g)
                        j = nxt[j]
        if box.has_bottom:
            g = pos[i, 2] - r[i] - pos[n + SLOT_BOTTOM, 2]
            if g < margin:
                count = _put3(buf_i, buf_f, count, n + SLOT_BOTTOM, i, 0, 0, up, g)
        if box.has_top:
            g = pos[n + SLOT_TOP, 2] - pos[i, 2] - r[i]
            if g < margin:
                count = _put3(buf_i, buf_f, count, i, n + SLOT_TOP, 0, 0, up, g)
    return count
