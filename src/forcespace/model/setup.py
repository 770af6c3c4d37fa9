"""The scene as records: what the engine runs on, read once from the scene's keys.

A :class:`~forcespace.model.scene.Scene` is what a user writes and a file stores (text
and a mapping of string keys). The engine runs on the frozen records of this module,
made once at the top of the protocol by :meth:`Setup.from_scene` (the only function that
reads the scene's keys for the engine). Boundary conditions are data, as in jax-md: the
container is a :class:`Boundary` whose plates and lateral axes are values, never string
flags tested down the call stack, and the dimension is the length of its lateral axes
(2-D disks: one lateral axis x, y vertical; 3-D spheres: two lateral axes, the last axis
vertical), not a second tree of code.

Units: lengths in R, masses in rho R^dim, forces in F0 (as the scene's keys).
"""
from __future__ import annotations

from dataclasses import dataclass, fields, replace

from ..errors import InputError
from .scene import Scene, parse_scene_text


@dataclass(frozen=True)
class Plate:
    """A load-controlled plate: ``force`` [F0] pressing it onto the grains (along -vertical),
    ``mass`` [rho R^dim]; it moves along the vertical axis only."""

    force: float
    mass: float


@dataclass(frozen=True)
class Boundary:
    """The container as data, in any dimension.

    lateral (dim-1,): extents [R] along the lateral axes (2-D: the width along x);
    periodic (dim-1,): per lateral axis, periodic (minimum image) or closed by side walls
    at 0 and the extent; bottom: a fixed lower plate at height 0 (else an open floor);
    top: the load-controlled upper :class:`Plate`, or None (a free surface).
    """

    lateral: tuple
    periodic: tuple
    bottom: bool
    top: Plate | None

    @property
    def dim(self) -> int:
        """Spatial dimension: 2 for disks, 3 for spheres."""
        return len(self.lateral) + 1

    @property
    def has_walls(self) -> bool:
        """Whether any wall (plate or side wall) can touch a grain."""
        return self.bottom or self.top is not None or not all(self.periodic)


@dataclass(frozen=True)
class Grains:
    """The grains to place (the scene's ``disks.*`` keys): ``n``; radii in
    [radius_min, radius_max] [R] by ``distribution`` with its parameters
    (:mod:`forcespace.model.radii`); ``density`` [rho], per-grain densities log-uniform
    in [density, density * density_ratio] when the ratio is not 1."""

    n: int
    radius_min: float
    radius_max: float
    distribution: str
    small_fraction: float
    lognormal_sigma: float
    lognormal_median: float
    density: float
    density_ratio: float


@dataclass(frozen=True)
class Physics:
    """What the contact dynamics switches on: Coulomb coefficients ``mu`` (grain-grain)
    and ``plate_mu`` (grain-wall), ``gravity`` [F0/(rho R^(dim+1))] along -vertical,
    ``rotation`` (grain rotation integrated; the scene's "auto" already resolved)."""

    mu: float
    plate_mu: float
    gravity: float
    rotation: bool


@dataclass(frozen=True)
class Solver:
    """The time stepper's settings (the scene's ``solver.*`` keys, same names and units:
    ``forcespace scene --schema``)."""

    dt: float
    tolerance: float
    max_sweeps: int
    overlap_correction: float
    overlap_slop: float
    relaxation: float
    sweep_block: int
    tolerance_moving: float
    moving_speed: float
    max_sweeps_moving: int
    relaxation_fallback: float
    dt_compacting: float
    compacting_speed: float
    contact_margin: float


@dataclass(frozen=True)
class Jamming:
    """The protocol's settings: the loose start's ``initial_packing_fraction`` (the scene's
    ``box.initial_packing_fraction``) and the rest criterion and static solve (the
    ``jamming.*`` keys, same names and units)."""

    initial_packing_fraction: float
    velocity_tol: float
    window: int
    max_steps: int
    static_tolerance: float
    static_max_sweeps: int
    contact_gap_tol: float
    max_overlap: float
    certificate_speed: float


@dataclass(frozen=True)
class Setup:
    """Everything the engine runs, as records: the physical system (grains, boundary,
    physics), the protocol (solver, jamming), the seed, and where it came from (the
    scene's name, source, complete TOML text, the identity a checkpoint must match, and
    the analysis' slice height [R], 0 for none)."""

    grains: Grains
    boundary: Boundary
    physics: Physics
    solver: Solver
    jamming: Jamming
    seed: int
    name: str
    source: str
    text: str
    identity: str
    slice_height: float = 0.0

    @property
    def dim(self) -> int:
        """Spatial dimension (:attr:`Boundary.dim`)."""
        return self.boundary.dim

    @property
    def force_unit(self) -> float:
        """The engine's internal force unit sigma [F0]: the top plate's load, else the
        weight scale density * gravity (rho g R^dim).

        The kernels run with every force divided by sigma, so a scene whose loads are all
        multiplied by k gives the same trajectory (positions bit for bit) and forces
        exactly k times larger. Time is therefore measured in sqrt(rho R^3 / sigma):
        ``solver.dt`` is in that unit (for the default top_force = 1 F0 the two agree).
        """
        top = self.boundary.top
        if top is not None:
            return float(top.force)
        return float(self.grains.density * self.physics.gravity)

    def with_max_steps(self, max_steps: int) -> "Setup":
        """A copy whose dynamics stop after ``max_steps`` steps (the rest of it, its
        provenance included, unchanged: the step budget is not part of a scene's identity)."""
        return replace(self, jamming=replace(self.jamming, max_steps=int(max_steps)))

    @classmethod
    def from_text(cls, text: str, source: str = "<packing scene>") -> "Setup | None":
        """The records of scene TOML held in memory (e.g. a packing file's copy), or None
        when there is no scene text or it does not validate."""
        if not (text or "").strip():
            return None
        try:
            return cls.from_scene(parse_scene_text(text, source))
        except InputError:
            return None

    @classmethod
    def from_scene(cls, scene: Scene) -> "Setup":
        """The records of a validated scene (read here once; nothing below reads the
        scene's keys)."""
        top = (Plate(scene["plates.top_force"], scene["plates.top_mass"])
               if scene["plates.top"] == "load" else None)
        lateral = (scene["box.width"],)
        periodic = (scene["box.periodic_x"],)
        depth = scene["box.depth"]
        if scene.dim == 3:      # spheres: periodic in x and y (the scene checks it)
            lateral += (depth or scene["box.width"],)
            periodic += (True,)
        boundary = Boundary(lateral=lateral, periodic=periodic,
                            bottom=scene["plates.bottom"] == "fixed", top=top)
        physics = Physics(scene["physics.mu"], scene["physics.plate_mu"],
                          scene["physics.gravity"], bool(scene.rotation))
        identity = scene.with_overrides(**{"jamming.max_steps": 1}).to_toml().split("\n", 1)[1]
        return cls(grains=_section(Grains, scene, "disks"), boundary=boundary,
                   physics=physics, solver=_section(Solver, scene, "solver"),
                   jamming=_section(Jamming, scene, "jamming", box="initial_packing_fraction"),
                   seed=scene["scene.seed"], name=scene.name, source=scene.source,
                   text=scene.to_toml(), identity=identity,
                   slice_height=scene["analysis.slice_height"])


def _section(record, scene: Scene, section: str, **other):
    """``record`` filled from the scene's keys ``section.FIELD`` (and ``other``:
    {other_section: field})."""
    where = {f.name: f"{section}.{f.name}" for f in fields(record)}
    where.update({name: f"{sec}.{name}" for sec, name in other.items()})
    return record(**{name: scene[key] for name, key in where.items()})
