"""A point force on a settled layer: contact dynamics until the layer is at rest again.

The dynamic half of the paper's point-force experiment (the static half, the
largest force the rigid network carries, is :func:`forcespace.space.loads.max_point_force`;
the depth of the rearrangement is :func:`forcespace.measures.rearrangement_depth`).
Units: lengths in R, forces in F0 (the scene's force unit), as everywhere.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, NumericalError
from ..model.packing import Packing
from ..model.setup import Setup
from .bodies import make_bodies
from .compress import Run, compress
from .static import settled_forces, static_solve


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
    """Contact dynamics of ``packing``'s setup from its state with an extra downward
    ``force`` [F0] on ``disk``'s centre, until at rest (the setup's jamming criteria)
    or ``max_steps`` steps (then ``at_rest`` is False: the disk keeps moving, e.g.
    creeping through the layer, and the displacements are those reached).

    The setup is the packing's own records (:attr:`Packing.setup`: the engine's, or
    read from the packing file's scene). The dynamics start warm, from the packing's
    own contact forces: restarted from zero forces, Gauss-Seidel needs many steps to
    rebuild a thick layer's network and the layer sags meanwhile (at mu = 1 far enough
    to set disks slipping with no push)."""
    setup = packing.setup or Setup.from_text(packing.scene_text)
    if setup is None:
        raise InputError("packing", "scene_text", "is empty or not a valid scene: the "
                         "packing does not record the scene that made it")
    if setup.dim != 2:
        raise InputError("packing", "box.dimension", "must be 2: the point-force push "
                         "runs on disks only", got=setup.dim)
    if setup.boundary.top is not None:
        raise InputError("packing", "plates.top", 'must be "none" (a free surface) for a '
                         "point force")
    if int(max_steps) < 1:
        raise InputError("push", "max_steps", "must be an integer >= 1", got=max_steps)
    setup = setup.with_max_steps(max_steps)
    x0, y0 = np.array(packing.x, float), np.array(packing.y, float)
    bodies = make_bodies(setup, x0.copy(), y0.copy(), np.asarray(packing.r, float), 0.0,
                         packing.density if np.ndim(packing.density) else None)
    bodies.fy_ext[disk] -= force / setup.force_unit
    after = None
    try:
        stats = compress(setup, bodies, seed, show_progress=False,
                         run=Run(contacts=settled_forces(packing, setup)))
    except NumericalError as exc:
        if not np.all(np.isfinite(bodies.y)):
            raise
        stats = {"steps": int(max_steps), "not_at_rest": str(exc)}
    else:
        after, static = static_solve(setup, bodies, seed, show_progress=False)
        stats.update(static)
    dx = bodies.x[:packing.n_disks] - x0
    (periodic,), (width,) = setup.boundary.periodic, setup.boundary.lateral
    if periodic:
        dx -= width * np.round(dx / width)
    disp = np.hypot(dx, bodies.y[:packing.n_disks] - y0)
    return PushResult(displacement=disp, at_rest=after is not None, after=after, stats=stats)
