"""Figures of packings and force networks (matplotlib, PNG and PDF)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .h5io import atomic_path
from .packing import Packing


def figure_targets(path) -> list[Path]:
    """The files a figure path produces: itself, and a PDF twin beside a PNG."""
    path = Path(path)
    return [path] + ([path.with_suffix(".pdf")] if path.suffix.lower() == ".png" else [])


def branch_segments(p: Packing, values=None):
    """Segments (Nc, 2, 2) from centre to centre (walls: to the contact point), and values.

    Segments crossing the periodic boundary are drawn from a's centre toward b's image.
    """
    seg = np.empty((p.n_contacts, 2, 2))
    for k in range(p.n_contacts):
        a, b = p.a[k], p.b[k]
        if a >= 0:
            pa = np.array([p.x[a], p.y[a]])
        else:
            pa = p.point[k]
        if b >= 0:
            pb = np.array([p.x[b] + p.image[k] * p.width, p.y[b]])
        else:
            pb = p.point[k]
        if a < 0:
            pa = pb - (p.r[b]) * p.normal[k]
        if b < 0:
            pb = pa + (p.r[a]) * p.normal[k]
        seg[k] = pa, pb
    return seg, (p.fn if values is None else values)


def draw_packing(p: Packing, path, title: str | None = None, values=None,
                 signed: bool = False, dpi: int = 150):
    """Draw disks and the force network; line width proportional to |value| (default fn).

    ``signed=True`` colours positive and negative values differently (for the
    difference of two admissible networks). Writes ``path`` (its suffix picks
    the format); ``.png`` also gets a ``.pdf`` twin.
    """
    from matplotlib.collections import LineCollection, PatchCollection
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle

    seg, val = branch_segments(p, values)
    height = (p.y_top - p.y_bottom) if np.isfinite(p.y_top) else (p.y + p.r).max()
    # a Figure without pyplot: no backend is selected or switched for the caller
    fig = Figure(figsize=(6, 6 * max(height, 1) / p.width + 0.6))
    ax = fig.add_subplot()
    shifts = [-1, 0, 1] if p.periodic_x else [0]
    patches = [Circle((x + s * p.width, y), r) for s in shifts for x, y, r in zip(p.x, p.y, p.r)]
    rat = np.tile(p.rattlers(), len(shifts))
    pc = PatchCollection(patches, facecolor=np.where(rat[:, None], [[0.93, 0.93, 0.93, 1]],
                                                     [[0.8, 0.85, 0.95, 1]]),
                         edgecolor="0.4", linewidth=0.4)
    ax.add_collection(pc)
    scale = np.abs(val).max() if val.size and np.abs(val).max() > 0 else 1.0
    widths = 4.0 * np.abs(val) / scale
    colors = np.where((val >= 0)[:, None], [[0.8, 0.1, 0.1, 1]], [[0.1, 0.3, 0.9, 1]]) \
        if signed else "k"
    for s in shifts:
        lc = LineCollection(seg + np.array([s * p.width, 0]), linewidths=widths, colors=colors)
        ax.add_collection(lc)
    for yy in (p.y_bottom, p.y_top):
        if np.isfinite(yy):
            ax.axhline(yy, color="0.2", lw=2)
    ax.set_xlim(0, p.width)
    lo = p.y_bottom if np.isfinite(p.y_bottom) else (p.y - p.r).min()
    ax.set_ylim(lo - 0.5, lo + height + 0.5)
    ax.set_aspect("equal")
    ax.set_xlabel("x [R]")
    ax.set_ylabel("y [R]")
    ax.set_title(title or f"{p.scene_name}: n={p.n_disks}, mu={p.mu:g}, z={p.coordination():.3f}")
    fig.tight_layout()
    save_figure(fig, path, dpi)


def save_figure(fig, path, dpi=150):
    """Save ``fig`` at ``path``; a PNG also gets a PDF twin. Atomic via temp + rename."""
    for t in figure_targets(path):
        with atomic_path(t) as tmp:
            fig.savefig(tmp, dpi=dpi, format=t.suffix.lstrip(".").lower() or "png")
