"""Contact detection: cell list, minimum-image periodic x, plates and side walls.

Pure numba kernels behind one public function, :func:`detect_contacts`. Body layout
and contact convention: :mod:`forcespace.engine.records`. Normals point from a to b:
bottom->disk (0, 1), disk->top (0, 1), left->disk (1, 0), disk->right (1, 0); the
wall positions live in the body arrays (``y[n]`` lower plate, ``y[n+1]`` upper plate;
side walls at x = 0 and x = width).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..kernels import kernel
from ..model.walls import N_WALL_SLOTS, SLOT_BOTTOM, SLOT_LEFT, SLOT_RIGHT, SLOT_TOP
from .records import Box


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
    nb = n + N_WALL_SLOTS
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
        # distinct neighbour columns
        ncol = 0
        for d in range(-1, 2):
            jx = cix[i] + d
            if periodic:
                jx = jx % ncx
            elif jx < 0 or jx >= ncx:
                continue
            dup = False
            for q in range(ncol):
                if cols[q] == jx:
                    dup = True
            if not dup:
                cols[ncol] = jx
                ncol += 1
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
