"""Figures of packings and force networks (matplotlib, PNG and PDF)."""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .io.h5 import atomic_path

if TYPE_CHECKING:      # annotations only: figures never import the model
    from .model.packing import Packing


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


def new_axes(p: Packing):
    """A fresh Axes sized for the packing, on a Figure made without pyplot (no
    backend is selected or switched for the caller)."""
    from matplotlib.figure import Figure

    height = (p.y_top - p.y_bottom) if np.isfinite(p.y_top) else (p.y + p.r).max()
    fig = Figure(figsize=(6, 6 * max(height, 1) / p.width + 0.6))
    return fig.add_subplot()


def plot_packing(p: Packing, ax=None, values=None, signed: bool = False,
                 highlight=None, title: str | None = None):
    """Draw disks and a force network on ``ax`` (a new one if None); returns the Axes.

    ``values`` (Nc,) per packing contact (default fn [F0]); line width is
    proportional to |value|. ``signed=True`` colours positive red and negative
    blue (the difference of two admissible networks). ``highlight``: list of
    disk-index arrays (e.g. indeterminacy domains), each outlined in its own
    colour. Rattlers are drawn pale.
    """
    from matplotlib.collections import LineCollection, PatchCollection
    from matplotlib.patches import Circle

    ax = new_axes(p) if ax is None else ax
    seg, val = branch_segments(p, values)
    val = np.asarray(val, float)
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
        ax.add_collection(LineCollection(seg + np.array([s * p.width, 0]), linewidths=widths,
                                         colors=colors))
    for q, disks in enumerate(highlight or []):
        outline(ax, p, disks, f"C{q % 10}")
    for yy in (p.y_bottom, p.y_top):
        if np.isfinite(yy):
            ax.axhline(yy, color="0.2", lw=2)
    height = (p.y_top - p.y_bottom) if np.isfinite(p.y_top) else (p.y + p.r).max()
    lo = p.y_bottom if np.isfinite(p.y_bottom) else (p.y - p.r).min()
    ax.set_xlim(0, p.width)
    ax.set_ylim(lo - 0.5, lo + height + 0.5)
    ax.set_aspect("equal")
    ax.set_xlabel("x [R]")
    ax.set_ylabel("y [R]")
    ax.set_title(title or f"{p.scene_name}: n={p.n_disks}, mu={p.mu:g}, z={p.coordination():.3f}")
    return ax


def outline(ax, p: Packing, disks, colour, linestyle="-", linewidth=1.6):
    """Outline the disks ``disks`` (packing indices) on ``ax`` (periodic images too)."""
    from matplotlib.collections import PatchCollection
    from matplotlib.patches import Circle

    shifts = [-1, 0, 1] if p.periodic_x else [0]
    ax.add_collection(PatchCollection(
        [Circle((p.x[i] + s * p.width, p.y[i]), p.r[i]) for s in shifts for i in disks],
        facecolor="none", edgecolor=colour, linewidth=linewidth, linestyle=linestyle))


def plot_difference(packing: Packing, problem, x1, x2, domains=None, ax=None,
                    title: str | None = None, clusters=None):
    """The signed difference x2 - x1 of two networks of ``problem`` (each (2m,) [F0]):
    normal-force differences red (+) / blue (-), width by magnitude, with the
    disks of each domain (:class:`forcespace.measures.Domain`) outlined, and the
    elementary clusters (:class:`forcespace.clusters.Cluster` with ``elementary``)
    inside them dashed in black. Returns the Axes."""
    d = np.zeros(packing.n_contacts)
    diff = np.asarray(x2, float) - np.asarray(x1, float)
    d[problem.contacts] = diff[0::2]
    ax = plot_packing(packing, ax, values=d, signed=True,
                      highlight=[g.disks for g in (domains or [])],
                      title=title or "difference of two admissible networks (fn)")
    for c in clusters or []:
        if c.elementary:
            outline(ax, packing, c.disks, "k", linestyle="--", linewidth=0.9)
    return ax


def draw_packing(p: Packing, path, title: str | None = None, values=None,
                 signed: bool = False, dpi: int = 150):
    """:func:`plot_packing` written to ``path`` (its suffix picks the format; a
    ``.png`` also gets a ``.pdf`` twin)."""
    ax = plot_packing(p, None, values=values, signed=signed, title=title)
    ax.figure.tight_layout()
    save_figure(ax.figure, path, dpi)


def save_figure(fig, path, dpi=150):
    """Save ``fig`` at ``path``; a PNG also gets a PDF twin. Atomic via temp + rename."""
    for t in figure_targets(path):
        with atomic_path(t) as tmp:
            fig.savefig(tmp, dpi=dpi, format=t.suffix.lstrip(".").lower() or "png")
