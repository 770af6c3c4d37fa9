"""Figures of packings and force networks (matplotlib, PNG and PDF).

Every figure is drawn on the caller's Axes (or a new Figure made without pyplot) and
follows one style: :data:`STYLE` (colours, widths), :data:`LABELS` (mathtext labels with
units), :func:`force_legend` (the line-width legend = the force scale), :func:`draw_walls`
(plates and side walls solid, periodic boundaries dotted). The studies' figures use the
same helpers.
"""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .errors import InputError, require_array
from .io.figures import save_figure

if TYPE_CHECKING:      # annotations only: figures never import the model
    from .model.packing import Packing


# One style for every figure of forcespace (and for the studies' figures: import these).
STYLE = {
    "disk": (0.80, 0.85, 0.95, 1.0),        # load-bearing disks
    "rattler": (0.93, 0.93, 0.93, 1.0),     # rattlers (carry no load)
    "disk_edge": "0.4",
    "force": "k",                           # a force network
    "increase": (0.80, 0.10, 0.10, 1.0),    # signed differences: + red, - blue
    "decrease": (0.10, 0.30, 0.90, 1.0),
    "wall": "0.15",                          # plates and side walls
    "periodic": "0.55",                      # periodic boundaries (dotted)
    "max_width": 4.0,                        # line width [pt] of the largest |value|
}

# labels with units (mathtext), shared by the figures and the studies
LABELS = {
    "x": r"$x$ [$R$]", "y": r"$y$ [$R$]", "mu": r"$\mu$",
    "eta": r"$\eta = \langle \delta F\rangle / \langle |F|\rangle$",
    "fn": r"$f_n$ [$F_0$]", "ft": r"$f_t$ [$F_0$]", "z": r"$z$",
    "K": r"$k_n R / \langle F_n\rangle$",
    "distance": r"distance to $S$ / $\langle F_n\rangle$ (rms per contact)",
}


def new_axes(p: Packing):
    """A fresh Axes sized for the packing, on a Figure made without pyplot (no
    backend is selected or switched for the caller)."""
    from matplotlib.figure import Figure

    height = (p.y_top - p.y_bottom) if np.isfinite(p.y_top) else (p.y + p.r).max()
    # no layout engine: draw_packing (or the caller) calls tight_layout, which keeps the
    # legend above the Axes inside the figure
    fig = Figure(figsize=(6.4, 6.0 * max(height, 1) / p.width + 1.2))
    return fig.add_subplot()


def force_widths(values, scale=None) -> tuple[np.ndarray, float]:
    """Line widths [pt] proportional to |values| (the largest gets STYLE["max_width"], or
    ``scale`` does), and the scale used."""
    v = np.abs(np.asarray(values, float))
    if scale is None:
        scale = float(v.max()) if v.size and v.max() > 0 else 1.0
    return STYLE["max_width"] * v / scale, scale


def force_legend(ax, scale: float, unit: str = r"F_0", signed: bool = False,
                 quantity: str = r"|f_n|", loc="upper left", extra=()):
    """A legend for line width (the force scale): three sample lines at 1/4, 1/2 and all
    of ``scale`` [unit]; with ``signed`` also the colours (+ red, - blue). ``extra``:
    further legend handles (e.g. rattler patches, domain outlines). Placed outside the
    Axes, above it, so it never covers the packing. Returns the Legend."""
    from matplotlib.lines import Line2D

    handles = []
    for frac in (0.25, 0.5, 1.0):
        colour = STYLE["increase"] if signed else STYLE["force"]
        handles.append(Line2D([], [], color=colour, lw=STYLE["max_width"] * frac,
                              label=rf"${quantity} = {frac * scale:.3g}\,{unit}$"))
    if signed:
        handles += [Line2D([], [], color=STYLE["increase"], lw=2, label="increase (+)"),
                    Line2D([], [], color=STYLE["decrease"], lw=2, label="decrease (−)")]
    handles += list(extra)
    return ax.legend(handles=handles, loc="lower left", bbox_to_anchor=(0.0, 1.01),
                     ncol=min(len(handles), 3), fontsize=7.5, frameon=False,
                     handlelength=2.5, borderaxespad=0.0)


def draw_walls(ax, p: Packing) -> None:
    """Plates (solid), side walls (solid, without periodic x) and periodic boundaries
    (dotted) on ``ax``."""
    ylo = p.y_bottom if np.isfinite(p.y_bottom) else float((p.y - p.r).min())
    yhi = p.y_top if np.isfinite(p.y_top) else float((p.y + p.r).max())
    for yy in (p.y_bottom, p.y_top):
        if np.isfinite(yy):
            ax.plot([0, p.width], [yy, yy], color=STYLE["wall"], lw=2.0, solid_capstyle="butt")
    style = dict(color=STYLE["periodic"], lw=0.8, ls=":") if p.periodic_x else \
        dict(color=STYLE["wall"], lw=2.0)
    for xx in (0.0, p.width):
        ax.plot([xx, xx], [ylo, yhi], **style)


def plot_packing(p: Packing, ax=None, values=None, signed: bool = False,
                 highlight=None, title: str | None = None, legend: bool = True,
                 scale: float | None = None, quantity: str = r"|f_n|", spread=None):
    """Draw disks and a force network on ``ax`` (a new one if None); returns the Axes.

    ``values`` (Nc,) per packing contact (default fn [F0]); line width is
    proportional to |value| (``scale``: the value drawn STYLE["max_width"] wide, default
    the largest). ``signed=True`` colours positive red and negative blue (the difference
    of two admissible networks). ``highlight``: list of disk-index arrays (e.g.
    indeterminacy domains), each outlined in its own colour. ``spread`` (Nc,) [F0]: each
    line coloured by it (an ensemble's standard deviation over the samples; NaN: not
    sampled, grey), with a colour bar. Rattlers are drawn pale;
    plates and side walls solid, periodic boundaries dotted. ``legend``: the force-width
    (and colour) legend above the Axes.
    """
    from matplotlib.collections import LineCollection, PatchCollection
    from matplotlib.patches import Circle, Patch

    ax = new_axes(p) if ax is None else ax
    if values is not None:          # a wrong-length vector drew anyway (issue 47)
        values = require_array("plot", "values", values, (p.n_contacts,),
                               "one value per contact of the packing")
    seg, val = p.branch_segments(values)
    val = np.asarray(val, float)
    shifts = [-1, 0, 1] if p.periodic_x else [0]
    patches = [Circle((x + s * p.width, y), r) for s in shifts for x, y, r in zip(p.x, p.y, p.r)]
    rat = np.tile(p.rattlers(), len(shifts))
    pc = PatchCollection(patches, facecolor=np.where(rat[:, None], [STYLE["rattler"]],
                                                     [STYLE["disk"]]),
                         edgecolor=STYLE["disk_edge"], linewidth=0.4)
    ax.add_collection(pc)
    widths, scale = force_widths(val, scale)
    colors = np.where((val >= 0)[:, None], [STYLE["increase"]], [STYLE["decrease"]]) \
        if signed else STYLE["force"]
    if spread is not None:
        colors = spread_colours(ax, p, spread)
    for s in shifts:
        ax.add_collection(LineCollection(seg + np.array([s * p.width, 0]), linewidths=widths,
                                         colors=colors, capstyle="round"))
    extra = []
    for q, disks in enumerate(highlight or []):
        outline(ax, p, disks, f"C{q % 10}")
    if highlight:
        extra.append(Patch(facecolor="none", edgecolor="C0", label="domains (outlined)"))
    if rat.any():
        extra.append(Patch(facecolor=STYLE["rattler"], edgecolor=STYLE["disk_edge"],
                           label="rattler"))
    draw_walls(ax, p)
    height = (p.y_top - p.y_bottom) if np.isfinite(p.y_top) else (p.y + p.r).max()
    lo = p.y_bottom if np.isfinite(p.y_bottom) else (p.y - p.r).min()
    ax.set_xlim(0, p.width)
    ax.set_ylim(lo - 0.5, lo + height + 0.5)
    ax.set_aspect("equal")
    ax.set_xlabel(LABELS["x"])
    ax.set_ylabel(LABELS["y"])
    if legend:
        force_legend(ax, scale, signed=signed, quantity=quantity, extra=extra)
    name = p.scene_name or (Path(p.source).stem if p.source else "packing")
    ax.set_title(title or (f"{name}: $n = {p.n_disks}$, $\\mu = {p.mu:g}$, "
                           f"$z = {p.coordination():.3f}$"), pad=52 if legend else 6,
                 fontsize=10)
    return ax


def spread_colours(ax, p: Packing, spread):
    """RGBA (Nc, 4) of each contact's ``spread`` (Nc,) >= 0 [F0] (NaN: grey, not sampled)
    on a sequential colour map, and its colour bar beside ``ax``."""
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    s = np.asarray(spread, float)
    if s.shape != (p.n_contacts,) or np.any(s[np.isfinite(s)] < 0):
        require_array("plot", "spread", np.where(np.isfinite(s), s, 0.0), (p.n_contacts,),
                      "one standard deviation >= 0 [F0] per contact (NaN: not sampled)")
        raise InputError("plot", "spread", "must be >= 0 [F0] (a standard deviation)",
                         got=float(np.nanmin(s)))
    top = float(np.nanmax(s, initial=0.0)) if np.isfinite(s).any() else 1.0
    sm = ScalarMappable(Normalize(0.0, top if top > 0 else 1.0), colormaps["plasma_r"])
    rgba = sm.to_rgba(np.where(np.isfinite(s), s, 0.0))
    rgba[~np.isfinite(s)] = (0.6, 0.6, 0.6, 1.0)
    ax.figure.colorbar(sm, ax=ax, shrink=0.6, pad=0.02,
                       label=r"s.d. of $f_n$ over the samples [$F_0$] (grey: not sampled)")
    return rgba


def plot_force_distribution(ax, distribution: dict, title: str | None = None):
    """P(f) of an ensemble against its jammed network's on ``ax`` (log density, f in units
    of <Fn>): ``distribution`` as :meth:`Ensemble.force_distribution` returns it."""
    e = np.asarray(distribution["edges"], float)
    ax.stairs(distribution["jammed"], e, color="k", lw=1.4, label="jammed network")
    ax.stairs(distribution["ensemble"], e, color=STYLE["increase"], lw=1.4,
              label="ensemble (all samples)")
    ax.set_yscale("log")
    ax.set_xlabel(r"$f = f_n / \langle F_n\rangle$")
    ax.set_ylabel(r"$P(f)$")
    ax.legend(fontsize=8, frameon=False, loc="upper right")
    if title:
        ax.set_title(title, fontsize=10)
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
                    title: str | None = None, clusters=None, slice_edges=None):
    """The signed difference x2 - x1 of two networks of ``problem`` (each (2m,) [F0]):
    normal-force differences red (+) / blue (-), width by magnitude, with the
    disks of each domain (:class:`forcespace.space.structure.Domain`) outlined, and the
    disks of each elementary cluster (:class:`forcespace.space.structure.Cluster` with
    ``elementary``) shaded in its own colour; ``slice_edges`` (y_low, y_high) [R]: the
    slice's edges, dashed. Returns the Axes."""
    from matplotlib.collections import PatchCollection
    from matplotlib.lines import Line2D
    from matplotlib.patches import Circle, Patch

    d = np.zeros(packing.n_contacts)
    diff = np.asarray(x2, float) - np.asarray(x1, float)
    d[problem.contacts] = diff[0::2]
    ax = plot_packing(packing, ax, values=d, signed=True,
                      highlight=[g.disks for g in (domains or [])], quantity=r"|\Delta f_n|",
                      title=title or r"difference of two admissible networks ($\Delta f_n$)")
    elementary = [c for c in clusters or [] if c.elementary]
    shifts = [-1, 0, 1] if packing.periodic_x else [0]
    for q, c in enumerate(elementary):   # one colour per cluster: over the disks (inside
        colour = CLUSTER_COLOURS[q % len(CLUSTER_COLOURS)]      # their outlines), under
        ax.add_collection(PatchCollection(                      # the force lines
            [Circle((packing.x[i] + s * packing.width, packing.y[i]), 0.85 * packing.r[i])
             for s in shifts for i in c.disks], facecolor=colour, edgecolor="none",
            zorder=1.5))
    extra = [Patch(facecolor=CLUSTER_COLOURS[0], label=f"{len(elementary)} elementary "
                   "clusters (one colour each)")] if elementary else []
    if slice_edges is not None:
        for y in slice_edges:
            ax.axhline(y, color=STYLE["wall"], lw=1.0, ls="--")
        extra.append(Line2D([], [], color=STYLE["wall"], lw=1.0, ls="--",
                            label=f"slice ({slice_edges[1] - slice_edges[0]:g} $R$)"))
    if extra:
        leg = ax.get_legend()
        force_legend(ax, np.abs(d).max() or 1.0, signed=True, quantity=r"|\Delta f_n|",
                     extra=list(leg.legend_handles)[5:] + extra)
    return ax


def plot_measured(packing: Packing, check, fig=None, truth=None):
    """A measured network against S (``check``: a computed
    :class:`forcespace.space.measured.Measured` of ``packing``): the measured network
    (top left) beside the nearest admissible one (top right; S empty and no admissible
    loads: the least-violating one), the analysed region's disks outlined in green;
    below, every region contact's range of fn and of ft over S (grey bars, sorted by the
    measured fn) with the measured value marked (black inside its range, red outside)
    and the nearest admissible value (blue). ``truth`` (2m,) [F0]: a known true network
    (tests, studies), marked as well. Returns the Figure."""
    from matplotlib.figure import Figure

    fig = fig or Figure(figsize=(11.0, 10.0))
    gs = fig.add_gridspec(2, 2, height_ratios=(1.35, 1.0), hspace=0.32)
    prob, x, s = check.problem, check.x, check.force_scale
    found = check.nearest is not None
    net = check.nearest if found else check.least_violating
    measured, other = (np.asarray(packing.fn, float).copy() for _ in range(2))
    measured[prob.contacts] = x[0::2]
    other[prob.contacts] = net[0::2]
    scale = float(np.abs(np.concatenate([measured, other])).max()) or 1.0
    titles = (f"measured network ({prob.n_interior} region disks outlined)",
              ("nearest admissible network" + ("" if check.loads == "measured" else
                                               " (loads adjusted)")) if found else
              "S is empty: least-violating network")
    for k, (vals, title) in enumerate(zip((measured, other), titles)):
        ax = fig.add_subplot(gs[0, k])
        plot_packing(packing, ax, values=vals, scale=scale, title=title, legend=k == 0)
        outline(ax, packing, prob.disks, "C2", linewidth=0.5)
    fig.text(0.5, 0.0, _measured_line(check), ha="center", va="top", fontsize=9.5)
    if not (found and check.fn_range is not None):
        return fig
    order = np.argsort(x[0::2])
    for k, (key, label) in enumerate((("fn_range", r"$f_n$"), ("ft_range", r"$f_t$"))):
        ax = fig.add_subplot(gs[1, k])
        _range_panel(ax, getattr(check, key)[order] / s, x[k::2][order] / s,
                     net[k::2][order] / s, check.inside[order],
                     None if truth is None else np.asarray(truth)[k::2][order] / s)
        ax.set_xlabel(r"region contact (sorted by measured $f_n$)")
        ax.set_ylabel(label + r" / $\langle F_n\rangle$")
        ax.set_title(f"range of {label} over S per contact", fontsize=10)
    return fig


def _measured_line(check) -> str:
    """One line saying what the check found (the title of :func:`plot_measured`)."""
    unit = r"$\langle F_n\rangle$"
    if check.nearest is None:
        return "S is empty and no adjustment of the loads makes it non-empty"
    text = (f"dim S = {check.dim}; distance to S = {check.distance:.3g} {unit} (rms per "
            "measured contact)")
    if not check.feasible:
        text = (f"S at the measured loads is empty (smallest total extra load "
                f"{check.relaxation_total / check.force_scale:.3g} {unit});\nat the loads "
                f"adjusted least ({check.load_adjustment:.3g} {unit} rms per load contact): "
                + text)
    return text


def _range_panel(ax, rng, measured, nearest, inside, truth=None) -> None:
    from matplotlib.lines import Line2D

    idx = np.arange(rng.shape[0])
    ax.vlines(idx, rng[:, 0], rng[:, 1], color="0.6", lw=1.6)
    ax.plot(idx, nearest, "_", ms=5, color=STYLE["decrease"])
    ax.plot(idx[inside], measured[inside], "o", ms=2.5, color="k")
    ax.plot(idx[~inside], measured[~inside], "x", ms=4, color=STYLE["increase"])
    handles = [Line2D([], [], color="0.6", lw=1.6, label="range over S"),
               Line2D([], [], marker="_", ls="", ms=6, color=STYLE["decrease"],
                      label="nearest admissible"),
               Line2D([], [], marker="o", ls="", ms=3, color="k", label="measured, inside"),
               Line2D([], [], marker="x", ls="", ms=4, color=STYLE["increase"],
                      label="measured, outside")]
    if truth is not None:
        ax.plot(idx, truth, ".", ms=2, color="C2")
        handles.append(Line2D([], [], marker=".", ls="", color="C2", label="true"))
    ax.legend(handles=handles, fontsize=7.5, loc="upper left")


# qualitative colours for elementary clusters (pale enough for the force lines on top)
CLUSTER_COLOURS = [(0.99, 0.75, 0.45), (0.60, 0.87, 0.62), (0.80, 0.70, 0.95),
                   (0.98, 0.65, 0.75), (0.55, 0.85, 0.90), (0.95, 0.90, 0.45),
                   (0.80, 0.80, 0.55), (0.70, 0.80, 0.98), (0.90, 0.75, 0.60),
                   (0.75, 0.95, 0.85)]


def draw_packing(p: Packing, path, title: str | None = None, values=None,
                 signed: bool = False, dpi: int = 150):
    """:func:`plot_packing` written to ``path`` (its suffix picks the format; a
    ``.png`` also gets a ``.pdf`` twin)."""
    ax = plot_packing(p, None, values=values, signed=signed, title=title)
    save_figure(ax.figure, path, dpi, tight=True)


# ---- spheres (3-D): a slice and a projection ----------------------------------------

def _sphere_view(ax, p, spheres, contacts, view, scale, rattler):
    """One panel: the ``spheres`` as circles (their radius) and the ``contacts`` as lines
    of width proportional to fn, projected on ``view``; plates and periodic edges."""
    from matplotlib.collections import LineCollection, PatchCollection
    from matplotlib.patches import Circle

    circles = [Circle(p.pos[i, list(view)], p.r[i]) for i in spheres]
    colours = [STYLE["rattler"] if rattler[i] else STYLE["disk"] for i in spheres]
    ax.add_collection(PatchCollection(circles, facecolor=colours, edgecolor=STYLE["disk_edge"],
                                      linewidth=0.3, alpha=0.6))
    widths, _ = force_widths(p.fn[contacts], scale)
    ax.add_collection(LineCollection(p.branch_segments(contacts, view)[0], linewidths=widths,
                                     colors=STYLE["force"], capstyle="round"))
    extent = [p.lateral[0], p.lateral[1], p.z_top]
    for axis, along in ((0, "x"), (1, "y")):
        if axis in view:
            for v in (0.0, extent[axis]):
                line = [[v, v], [p.z_bottom, p.z_top]] if view[1] == 2 else \
                    ([[v, v], [0, extent[1]]] if axis == 0 else [[0, extent[0]], [v, v]])
                ax.plot(*line, color=STYLE["periodic"], lw=0.8, ls=":")
    if view[1] == 2:
        for zz in (p.z_bottom, p.z_top):
            if np.isfinite(zz):
                ax.plot([0, extent[view[0]]], [zz, zz], color=STYLE["wall"], lw=2.0)
    names = "xyz"
    ax.set_xlabel(rf"${names[view[0]]}$ [$R$]")
    ax.set_ylabel(rf"${names[view[1]]}$ [$R$]")
    ax.set_aspect("equal")
    ax.autoscale_view()


def plot_sphere_packing(p, fig=None, thickness: float | None = None):
    """A sphere packing in two labelled panels (a new Figure if ``fig`` is None): a slice
    of ``thickness`` [R] (default 2 r_max) through the middle of the box along y, seen
    along y (spheres whose centres lie in it, contacts between them and with the
    plates), and the whole packing seen from above (along z); line widths proportional
    to fn, one scale for both. Returns the Figure."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    rattler = p.rattlers()
    bearing = np.flatnonzero(p.force_bearing())
    scale = float(p.fn[bearing].max()) if bearing.size else 1.0
    half = 0.5 * (thickness if thickness is not None else 2.0 * float(p.r.max()))
    yc = 0.5 * p.lateral[1]
    in_slice = np.abs(p.pos[:, 1] - yc) <= half
    both = [k for k in bearing if (p.a[k] < 0 or in_slice[p.a[k]])
            and (p.b[k] < 0 or in_slice[p.b[k]])]
    height = (p.z_top - p.z_bottom) if np.isfinite(p.z_top) else float(p.z.max())
    fig = fig or Figure(figsize=(11.0, 1.0 + 4.0 * max(height / p.lateral[0], 1.0)))
    side, top = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.0, 1.0]})
    _sphere_view(side, p, np.flatnonzero(in_slice), both, (0, 2), scale, rattler)
    side.set_title(f"slice {yc - half:.1f} R <= y <= {yc + half:.1f} R (centres), seen along "
                   f"y: {int(in_slice.sum())} spheres", fontsize=9)
    _sphere_view(top, p, np.argsort(p.z), bearing, (0, 1), scale, rattler)
    top.set_title(f"all {p.n_spheres} spheres seen from above (along z)", fontsize=9)
    extra = [Patch(facecolor=STYLE["disk"], edgecolor=STYLE["disk_edge"], label="sphere"),
             Patch(facecolor=STYLE["rattler"], edgecolor=STYLE["disk_edge"],
                   label="rattler (no load)")]
    legend = force_legend(side, scale, quantity="f_n", extra=extra)
    handles = legend.legend_handles
    legend.remove()
    fig.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=5,
               fontsize=8, frameon=False)
    fig.suptitle(f"{p.scene_name or 'sphere packing'}: {p.n_spheres} spheres, mu = {p.mu:g}, "
                 f"z = {p.coordination():.2f}; lines: contact forces, width ~ f_n",
                 fontsize=10)
    return fig


def draw_sphere_packing(p, path, dpi: int = 150) -> None:
    """:func:`plot_sphere_packing` written to ``path`` (a ``.png`` gets a ``.pdf`` twin)."""
    save_figure(plot_sphere_packing(p), path, dpi, tight=True)
