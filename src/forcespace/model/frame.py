"""The analysed region of a frame, and its statics problem (the paper's slice, generalised).

An experiment (or a window of a simulation) sees a frame, not a closed system: the
particles at its rim touch neighbours the data does not show. The analysed region is
the frame minus a rim; every contact of a region disk with a disk outside the region
(the rim, or beyond) carries a *fixed load*, its measured force, and so does every
wall contact unless the walls are taken as unknowns (supports with a wall mu). The
contacts between region disks are the unknowns; S is the set of networks the geometry
and those loads admit (:func:`frame_problem`).

Regions (:class:`Region`, or its text form for the command line, :meth:`Region.parse`):

* ``rim=K`` (default K = 1): the frame minus K rim layers. Layer 1: the particles the
  data flags at the frame's edge (``measurement.boundary``) when it has flags, else the
  disks whose surface comes within the largest radius of the frame's edge (they may
  touch a particle centred outside the frame); layer k + 1: disks touching layer k.
  The frame's edge: ``measurement.frame`` (the field of view) when given, else the
  disks' bounding box; a periodic direction has no edge. ``rim=0`` (or ``all``): every
  disk (a closed cell whose wall forces are measured).
* ``distance=D``: the frame minus the disks whose centre lies within D [R] of its edge.
* ``box=x0,y0,x1,y1``: the disks whose centres lie in the rectangle [R].
* ``slice=H``: the paper's horizontal slice of height H [R] (:func:`slice_problem`).
* ``disks``: explicit disk indices (API only).

Rattlers follow the project's convention (``Packing.rattlers``: a disk without a
force-bearing contact; where the data leave forces unknown, decided by geometry).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .packing import Packing
from .problem import StaticsProblem, build_problem, slice_problem
from .walls import WALL_CODES

KINDS = ("rim", "distance", "box", "slice", "all", "disks")
WALLS = ("loads", "unknown")
REGION_HELP = ("rim=K (frame minus K rim layers, default 1), distance=D (frame minus disks "
               "centred within D [R] of its edge), box=x0,y0,x1,y1 [R], slice=H [R], or all")


@dataclass(frozen=True)
class Region:
    """Which disks of a frame are analysed (module docstring). ``value``: K for "rim",
    D [R] for "distance", (x0, y0, x1, y1) [R] for "box", H [R] for "slice", indices
    for "disks", None for "all"."""

    kind: str = "rim"
    value: object = 1

    @classmethod
    def parse(cls, text: str, source: str = "--region") -> "Region":
        """A region from its text form (``rim=2``, ``distance=4.5``, ``box=0,0,10,20``,
        ``slice=28``, ``all``); InputError naming what is allowed."""
        text = str(text).strip()
        if text == "all":
            return cls("all", None)
        kind, sep, val = text.partition("=")
        try:
            if not sep or kind not in ("rim", "distance", "box", "slice"):
                raise ValueError
            if kind == "box":
                value = tuple(float(v) for v in val.split(","))
            elif kind == "rim":
                value = int(val)
            else:
                value = float(val)
            return cls(kind, value).checked(source)
        except ValueError:
            raise InputError("command line", source, f"must be {REGION_HELP}",
                             got=text) from None

    def checked(self, source="region") -> "Region":
        """self, or InputError naming the field and what is allowed."""
        k, v = self.kind, self.value
        ok = {"rim": lambda: isinstance(v, (int, np.integer)) and not isinstance(v, bool)
              and 0 <= v <= 10_000,
              "distance": lambda: np.isfinite(v) and v >= 0,
              "slice": lambda: np.isfinite(v) and v > 0,
              "box": lambda: len(v) == 4 and np.all(np.isfinite(v)) and v[2] > v[0]
              and v[3] > v[1],
              "all": lambda: True, "disks": lambda: np.ndim(v) == 1}
        if k not in ok:
            raise InputError(source, "region", f"kind must be one of {KINDS}", got=k)
        try:
            good = bool(ok[k]())
        except TypeError:
            good = False
        if not good:
            raise InputError(source, "region", f"must be {REGION_HELP}", got=f"{k}={v}")
        return self

    def describe(self) -> str:
        if self.kind == "all":
            return "all disks of the frame"
        if self.kind == "box":
            return "disks centred in the box x0, y0, x1, y1 = " + ", ".join(
                f"{v:g}" for v in self.value) + " R"
        if self.kind == "disks":
            return f"{len(self.value)} disks given by index"
        unit = {"rim": " layer(s)", "distance": " R", "slice": " R"}[self.kind]
        what = {"rim": "the frame minus a rim of", "distance": "the frame minus disks centred "
                "within", "slice": "the horizontal slice of height"}[self.kind]
        return f"{what} {self.value:g}{unit}"

    def mask(self, p: Packing) -> np.ndarray:
        """(n,) bool: the disks of ``p`` in the region (rattlers included; the problem
        drops them)."""
        self.checked()
        x, y = np.asarray(p.x, float), np.asarray(p.y, float)
        if self.kind == "all" or (self.kind == "rim" and self.value == 0):
            return np.ones(p.n_disks, dtype=bool)
        if self.kind == "box":
            x0, y0, x1, y1 = self.value
            return (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
        if self.kind == "disks":
            idx = np.asarray(self.value, np.int64)
            if idx.size and (idx.min() < 0 or idx.max() >= p.n_disks):
                raise InputError("region", "disks", f"indices must be in 0..{p.n_disks - 1}")
            m = np.zeros(p.n_disks, dtype=bool)
            m[idx] = True
            return m
        if self.kind == "distance":
            return edge_distance(p) >= self.value
        return ~rim_layers(p, int(self.value))


def frame_edges(p: Packing):
    """(x0, y0, x1, y1) [R] of the frame: the measurement's field of view, else the
    disks' bounding box; x0, x1 are -inf, inf when x is periodic (no edge)."""
    m = p.measurement
    if m is not None and m.frame is not None:
        x0, y0, x1, y1 = (float(v) for v in m.frame)
    else:
        x0, x1 = float((p.x - p.r).min()), float((p.x + p.r).max())
        y0, y1 = float((p.y - p.r).min()), float((p.y + p.r).max())
    if p.periodic_x:
        x0, x1 = -np.inf, np.inf
    return x0, y0, x1, y1


def edge_distance(p: Packing) -> np.ndarray:
    """(n,) distance [R] of each disk's centre from the frame's edge."""
    x0, y0, x1, y1 = frame_edges(p)
    return np.minimum.reduce([p.x - x0, x1 - p.x, p.y - y0, y1 - p.y])


def rim_layers(p: Packing, k: int) -> np.ndarray:
    """(n,) bool: the disks in the first ``k`` rim layers (module docstring)."""
    m = p.measurement
    if m is not None and m.boundary is not None:
        layer = np.asarray(m.boundary, bool).copy()
    else:
        layer = edge_distance(p) - p.r < float(np.max(p.r))
    rim = layer.copy()
    a, b = np.asarray(p.a), np.asarray(p.b)
    pair = (a >= 0) & (b >= 0)
    for _ in range(k - 1):
        touch = np.zeros(p.n_disks, dtype=bool)
        touch[b[pair & layer[np.maximum(a, 0)]]] = True
        touch[a[pair & layer[np.maximum(b, 0)]]] = True
        layer = touch & ~rim
        rim |= layer
    return rim


def frame_problem(packing: Packing, region: Region | str = Region(), walls: str = "loads",
                  wall_mu: float | None = None, gap_tol: float = np.inf, mu: float | None = None,
                  source: str = "") -> StaticsProblem:
    """S of a frame's region (module docstring): contacts between region disks unknown;
    contacts with disks outside the region fixed loads (their measured forces); wall
    contacts fixed loads (``walls="loads"``, default) or unknowns with friction
    ``wall_mu`` (default the packing's ``plate_mu``; ``walls="unknown"``).
    ``region``: a :class:`Region` or its text form. ``mu``: disk-disk friction instead of
    the packing's own."""
    src = source or packing.source or "frame"
    if isinstance(region, str):
        region = Region.parse(region)
    if walls not in WALLS:
        raise InputError(src, "walls", f"must be one of {WALLS}", got=walls)
    if region.kind == "slice":
        if walls != "loads" or wall_mu is not None:
            raise InputError(src, "walls", "the slice region has no wall contacts to vary: "
                             "leave walls='loads'", got=walls)
        prob = slice_problem(packing, float(region.value), gap_tol=gap_tol, source=source,
                             mu=mu)
    else:
        prob = build_problem(packing, region.mask(packing),
                             unknown_walls=WALL_CODES if walls == "unknown" else (),
                             kind="frame", gap_tol=gap_tol, source=source, mu=mu,
                             wall_mu=wall_mu if walls == "unknown" else None)
    _check_loads_known(packing, prob, src)
    prob.meta.update(region=region.describe(), walls=walls)
    return prob


def _check_loads_known(packing: Packing, prob: StaticsProblem, source) -> None:
    """A contact held as a fixed load must have a measured force."""
    m = packing.measurement
    if m is None or not prob.load_contacts.size:
        return
    bad = prob.load_contacts[~np.asarray(m.known, bool)[prob.load_contacts]]
    if bad.size:
        k = int(bad[0])
        a, b = int(packing.a[k]), int(packing.b[k])
        wall = a < 0 or b < 0
        raise InputError(source, f"contact {k} ({a}-{b})", "crosses the region's boundary "
                         f"(a fixed load) but its force is not measured ({bad.size} such "
                         "contacts): " + ("take the walls as unknowns (walls='unknown') or "
                                          if wall else "") + "choose a region whose boundary "
                         "contacts are measured")


__all__ = ["Region", "frame_problem", "frame_edges", "edge_distance", "rim_layers"]
