"""The paper's point-force experiment: how deep does a local rearrangement reach?

A layer settled under gravity (free surface, frictional floor). A downward force
F on the centre of a surface disk (the highest one):

1. ``max_point_force``: the largest F for which the rigid contact network still
   has an admissible force network (one LP over S of the whole layer with the
   load growing along F; :func:`forcespace.polytope.max_load_factor`). Below it
   rigid disks need not move; above it they must.
2. ``push``: contact dynamics from the settled state with F applied (and, as a
   control, without it), until the layer is at rest again.
3. ``rearrangement_depth``: the disks displaced by more than ``threshold`` R; the
   depth is the vertical distance from the loaded disk's centre down to the
   lowest displaced disk's centre [R].

Units: lengths in R, forces in F0 (the scene's force unit), as everywhere.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import InputError
from .packing import Packing

DISPLACED = 0.1         # a disk moved by more than this [R] took part in the rearrangement


def surface_disk(packing: Packing) -> int:
    """The disk whose top (y + r) is highest: a disk of the free surface."""
    return int(np.argmax(np.asarray(packing.y) + np.asarray(packing.r)))


def max_point_force(packing: Packing, disk: int) -> float:
    """Largest downward force on ``disk``'s centre the frozen network can carry [F0]
    (inf: any force; see the module docstring)."""
    from .polytope import max_load_factor
    from .statics import full_problem

    prob = full_problem(packing)
    where = np.flatnonzero(prob.disks == disk)
    if where.size == 0:
        raise InputError("point force", "disk", "must be a load-bearing disk of the layer "
                         "(not a rattler)", got=disk)
    d = np.zeros(prob.A.shape[0])
    d[3 * int(where[0]) + 1] = 1.0
    return max_load_factor(prob, d)


@dataclass(frozen=True)
class PushResult:
    """A push: displacement (n,) [R] of every disk (centre, periodic unwrapped) at the
    end, whether the layer came to rest within ``max_steps``, the packing at rest
    afterwards (None if not at rest) and the dynamics' statistics."""

    displacement: np.ndarray
    at_rest: bool
    after: Packing | None
    stats: dict


def push(packing: Packing, disk: int, force: float, seed: int = 0,
         max_steps: int = 100_000) -> PushResult:
    """Contact dynamics of ``packing``'s scene from its state with an extra downward
    ``force`` [F0] on ``disk``'s centre, until at rest (the scene's jamming criteria)
    or ``max_steps`` steps (then ``at_rest`` is False: the disk keeps moving, e.g.
    creeping through the layer, and the displacements are those reached)."""
    from .errors import NumericalError
    from .jamming import compress, force_unit, make_bodies, static_solve
    from .scene import parse_scene_text

    if not packing.scene_text:
        raise InputError("packing", "scene_text", "is empty: the packing does not record "
                         "the scene that made it")
    scene = parse_scene_text(packing.scene_text).with_overrides(
        **{"jamming.max_steps": int(max_steps)})
    if scene["plates.top"] == "load":
        raise InputError("packing", "plates.top", 'must be "none" (a free surface) for a '
                         "point force")
    x0, y0 = np.array(packing.x, float), np.array(packing.y, float)
    bodies = make_bodies(scene, x0.copy(), y0.copy(), np.asarray(packing.r, float), 0.0,
                         packing.density if np.ndim(packing.density) else None)
    bodies.fy_ext[disk] -= force / force_unit(scene)
    after = None
    try:
        stats = compress(scene, bodies, seed, show_progress=False)
    except NumericalError as exc:
        if not np.all(np.isfinite(bodies.y)):
            raise
        stats = {"steps": int(max_steps), "not_at_rest": str(exc)}
    else:
        after, static = static_solve(scene, bodies, seed, show_progress=False)
        stats.update(static)
    dx = bodies.x[:packing.n_disks] - x0
    if scene["box.periodic_x"]:
        dx -= scene["box.width"] * np.round(dx / scene["box.width"])
    disp = np.hypot(dx, bodies.y[:packing.n_disks] - y0)
    return PushResult(displacement=disp, at_rest=after is not None, after=after, stats=stats)


def rearrangement_depth(packing: Packing, disk: int, displacement, threshold: float = DISPLACED):
    """(depth [R], number of displaced disks): from ``disk``'s centre down to the
    lowest centre among the disks displaced by more than ``threshold`` R."""
    moved = np.flatnonzero(np.asarray(displacement) > threshold)
    if moved.size == 0:
        return 0.0, 0
    y = np.asarray(packing.y)
    return float(max(y[disk] - y[moved].min(), 0.0)), int(moved.size)
