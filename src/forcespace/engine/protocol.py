"""The paper's packing protocol: loose start, compression until jammed, static solve.

1. Radii uniform in [radius_min, radius_max]; random sequential placement of
   non-overlapping disks at ``box.initial_packing_fraction``
   (:mod:`forcespace.engine.bodies`; random streams: :mod:`forcespace.streams`).
2. Contact dynamics under the scene's loads (top-plate force, gravity) until at rest
   (:func:`forcespace.engine.compress.compress`).
3. Static solve on the frozen configuration (:func:`forcespace.engine.static.static_solve`).
4. A static solve that ends above ``jamming.static_tolerance`` means the configuration
   only looked at rest (a slow creep that paused for a window): the compression goes on,
   the rest criterion suspended for ``config.UNSETTLE_WINDOWS`` windows, and the static
   solve is tried again, up to ``config.STATIC_RETRIES`` times (counted in
   ``meta["static_retries"]``; a run resumed from its checkpoint keeps its count, and
   ``meta["compress_seconds"]`` and ``meta["wall_seconds"]`` include the time the run
   took in the processes before). A packing whose first static solve succeeds is
   unchanged by this. If the last one fails too, the configuration's exact certificate
   decides (:func:`~forcespace.engine.static.restart_from_exact_point`): a static network
   exists and NLGS restarts from it (``meta["static_restart"] = "exact point"``), or S
   is empty ("S empty"; the packing is refused below): NLGS from the dynamics' forces
   can stall on a configuration that is static. The cases behind both steps:
   studies/field_notes.md.
5. The packing is refused (NumericalError) if it keeps an overlap above
   ``jamming.max_overlap`` or its static residual above ``jamming.static_tolerance``.

Ctrl-C is honoured between kernel calls (:mod:`forcespace.engine.interrupts`): the
checkpoint is saved and :class:`~forcespace.engine.interrupts.Interrupted` raised.
"""
from __future__ import annotations

import time

import numpy as np

from .. import config
from ..errors import NumericalError
from ..io.checkpoint import remove_checkpoint
from ..model.packing import Packing
from ..model.sphere_packing import SpherePacking
from ..model.scene import Scene
from ..model.setup import Setup
from .bodies import (Bodies, SphereBodies, check_setup, loose_start,  # noqa: F401 (API)
                     loose_start3, make_bodies, make_sphere_bodies, random_radii, row_order)
from .compress import compress, start_run, unsettle
from .interrupts import deferred_sigint
from .static import (certificate_stats, certified_solve, restart_from_exact_point,
                     static_solve)
from ..streams import placement_rng

__all__ = ["Bodies", "Setup", "build_packing", "compress", "jam", "loose_start",
           "make_bodies", "random_radii", "row_order", "static_solve"]


def start_bodies(setup: Setup) -> Bodies | SphereBodies:
    """The loose start of a setup: radii, positions and densities from the placement
    stream of its seed, as kernel bodies (disks, or spheres when ``setup.dim`` is 3)."""
    rng = placement_rng(setup.seed)
    if setup.dim == 3:
        pos, r, height = loose_start3(setup, rng)
        return make_sphere_bodies(setup, pos, r, height, _densities(setup, rng, r.size))
    x, y, r, height = loose_start(setup, rng)
    return make_bodies(setup, x, y, r, height, _densities(setup, rng, r.size))


def _densities(setup: Setup, rng, n: int):
    """Per-grain densities log-uniform in [density, density*ratio] (drawn after the
    placement), or None when all grains are alike."""
    grains = setup.grains
    if grains.density_ratio == 1.0:
        return None
    return grains.density * grains.density_ratio ** rng.uniform(0, 1, n)


def build_packing(scene: Scene | Setup, show_progress=True,
                  checkpoint=None) -> Packing | SpherePacking:
    """Run the whole protocol for ``scene`` and return the static packing.

    The scene is turned into records (:class:`~forcespace.model.setup.Setup`) here, once;
    everything below runs on them. ``checkpoint``: file for resumable compression (see
    :func:`compress`); removed once the packing is built. Raises NumericalError (not
    jammed, static solve or overlap out of tolerance), Interrupted (Ctrl-C; the
    checkpoint is saved first).
    """
    setup = scene if isinstance(scene, Setup) else Setup.from_scene(scene)
    check_setup(setup)
    seed = setup.seed
    bodies = start_bodies(setup)
    t0 = time.perf_counter()
    tol = setup.jamming.static_tolerance
    with deferred_sigint() as interrupt:
        run = start_run(setup, bodies, checkpoint)
        meta = compress(setup, bodies, seed, show_progress, checkpoint=checkpoint,
                        interrupt=interrupt, run=run)
        packing, static = static_network(setup, bodies, seed, show_progress, interrupt)
        # a resumed run brings its retries and earlier compression time (checkpoint)
        seconds = run.seconds_before + meta["compress_seconds"]
        while not static["static_residual"] <= tol and run.retries < config.STATIC_RETRIES:
            run.retries += 1
            unsettle(setup, run, config.UNSETTLE_WINDOWS)
            meta = compress(setup, bodies, seed, show_progress, checkpoint=checkpoint,
                            interrupt=interrupt, run=run)
            seconds += meta["compress_seconds"]
            packing, static = static_network(setup, bodies, seed, show_progress, interrupt)
        restart = ""
        if not static["static_residual"] <= tol:
            stalled = static["static_residual"]
            exact = restart_from_exact_point(setup, bodies, seed, show_progress, interrupt)
            restart = "S empty" if exact is None else "exact point"
            if exact is not None:
                packing, static = exact
    packing.solver_log = np.array(run.log, dtype=float).reshape(-1, 5)
    retries = run.retries
    meta.update(static, compress_seconds=seconds, static_retries=retries,
                static_restart=restart)
    meta["wall_seconds"] = time.perf_counter() - t0 + run.seconds_before
    meta["rotation"] = bool(setup.physics.rotation)
    if not static["static_residual"] <= tol:
        raise NumericalError(
            f"static solve stopped at residual {static['static_residual']:.3g} > "
            f"jamming.static_tolerance after {static['static_sweeps']} sweeps"
            + (f", also after {retries} further compressions of {config.UNSETTLE_WINDOWS}+ "
               "windows"
               if retries else "")
            + ("; the exact certificate (interior point) finds no static network of this "
               "configuration (S is empty)" if restart == "S empty" else
               f"; restarted from an exact point of S (the certificate's) after stalling at "
               f"{stalled:.3g}"))
    check_overlap(setup, packing)
    packing.meta = meta
    if checkpoint:
        remove_checkpoint(checkpoint)
    return packing


def static_network(setup: Setup, bodies: Bodies, seed: int, show_progress=True,
                   interrupt=None):
    """The static network of a jammed configuration as the setup asks: by its
    certificate (:func:`~forcespace.engine.static.certified_solve`) when
    ``jamming.certificate_speed`` > 0 and the configuration admits one (spheres: only
    where the sweeps from the dynamics' forces stall), else by
    :func:`~forcespace.engine.static.static_solve` from the dynamics' forces. Returns
    (packing, statistics) as static_solve; ``static_network`` says which was used."""
    cert = None
    if setup.jamming.certificate_speed > 0 and setup.dim == 3:
        # spheres: the certificate ends the jam; the network is found as paper3d finds it
        # (sweeps from the dynamics' forces: in the same geometry the least-change network
        # had more force-bearing contacts, z +0.04 at mu = 0.01, 100 spheres), the
        # certificate's only where those stall
        packing, stats = static_solve(setup, bodies, seed, show_progress, interrupt)
        if stats["static_residual"] <= setup.jamming.static_tolerance:
            return packing, dict(stats, static_network="sweeps")
    if setup.jamming.certificate_speed > 0:
        done, cert = certified_solve(setup, bodies, seed, show_progress, interrupt)
        if done is not None:
            return done[0], dict(done[1], static_network="certificate")
    packing, stats = static_solve(setup, bodies, seed, show_progress, interrupt)
    return packing, dict(stats, static_network="sweeps",
                         **(certificate_stats(cert) if cert is not None else {}))


def check_overlap(setup: Setup, packing: Packing) -> None:
    """NumericalError if the packing keeps an overlap above ``jamming.max_overlap``: its
    contacts then do not describe rigid disks (e.g. a plate so light, or a step so long,
    that the plate ran into the disks between contact detections)."""
    worst = packing.max_overlap()
    limit = setup.jamming.max_overlap
    top = setup.boundary.top
    if worst > limit:
        plate = (f"plates.top_mass = {top.mass:g} and " if top is not None else "")
        raise NumericalError(
            f"the jammed packing keeps an overlap of {worst:.3g} R > jamming.max_overlap = "
            f"{limit:g} R ({worst / setup.solver.overlap_slop:.0f} x solver.overlap_slop): "
            f"not a packing of rigid disks; check {plate}solver.dt = {setup.solver.dt:g} "
            "(a light plate or a long step overruns the contact margin), or raise "
            "jamming.max_overlap")


def jam(scene, progress: bool = False, checkpoint=None,
        **overrides) -> Packing | SpherePacking:
    """Jam a packing by the scene's protocol and return it (a :class:`Packing` of disks,
    or a :class:`SpherePacking` for a scene with ``box.dimension = 3``).

    ``scene``: a :class:`~forcespace.model.scene.Scene`, the path of a scene file or the
    name of a bundled scene; ``overrides``: scene keys with dots replaced by double
    underscores, e.g. ``jam("quick", physics__mu=0.3, disks__n=30)``. ``checkpoint``:
    a file to resume an interrupted compression from.
    """
    from ..model.scene import load_scene

    sc = scene if isinstance(scene, Scene) else load_scene(scene)
    if overrides:
        sc = sc.with_overrides(**{k.replace("__", "."): v for k, v in overrides.items()})
    return build_packing(sc, show_progress=progress, checkpoint=checkpoint)
