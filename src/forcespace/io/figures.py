"""Figure files: where a figure path writes, and the one atomic writer of figures.

A PNG also gets a PDF twin (:func:`figure_targets`); every file is written through a
temporary name renamed into place (:func:`forcespace.io.h5.atomic_path`), so a kill
never leaves half a figure.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .h5 import atomic_path


def figure_targets(path) -> list[Path]:
    """The files a figure path produces: itself, and a PDF twin beside a PNG."""
    path = Path(path)
    return [path] + ([path.with_suffix(".pdf")] if path.suffix.lower() == ".png" else [])


def _unlog_empty_axes(fig) -> None:
    """A log axis with no positive data (e.g. no converged chain to plot) cannot be drawn:
    it goes linear and says so, instead of ending the run in a matplotlib error."""
    for ax in fig.axes:
        for name, interval in (("x", ax.dataLim.intervalx), ("y", ax.dataLim.intervaly)):
            scale = ax.get_xscale() if name == "x" else ax.get_yscale()
            hi = max(interval)
            if scale == "log" and not (np.isfinite(hi) and hi > 0):
                (ax.set_xscale if name == "x" else ax.set_yscale)("linear")
                ax.text(0.5, 0.5, f"no positive values on the {name} axis",
                        transform=ax.transAxes, ha="center", va="center", fontsize=8,
                        color="grey")


def save_figure(fig, path, dpi=150, tight: bool = False):
    """Save ``fig`` at ``path``; a PNG also gets a PDF twin. Atomic via temp + rename.
    A log axis without positive data is drawn linear with a note; ``tight``: lay the
    figure out with ``tight_layout`` first. The saved image is cropped to everything
    drawn, so a title or legend placed outside an Axes (above an equal-aspect packing,
    where ``tight_layout`` cannot make room) is never cut off."""
    _unlog_empty_axes(fig)
    if tight:
        fig.tight_layout()
    for t in figure_targets(path):
        with atomic_path(t) as tmp:
            fig.savefig(tmp, dpi=dpi, format=t.suffix.lstrip(".").lower() or "png",
                        bbox_inches="tight", pad_inches=0.1)
