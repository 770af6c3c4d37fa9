"""Scene files: what a simulation contains and which physics it switches on.

A scene is a TOML file (see ``inputs/``). Every key is listed in ``SCHEMA``
with its type, default, allowed range and meaning; unknown keys, wrong types
and out-of-range values are rejected with one line naming the file, the key
and what is allowed. The physics a scene declares decides what the engine
runs: friction (``physics.mu``, ``physics.plate_mu``), rotation, gravity,
plates and periodic x. Nothing else is simulated.
"""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

from ..errors import InputError


def _num(x, integer=False) -> str:
    """A bound as text: integers in full, other numbers short (1e6, not 1e+06)."""
    if x is None:
        return ""
    if integer:
        return str(int(x))
    return f"{x:g}".replace("e+0", "e").replace("e+", "e").replace("e-0", "e-")


@dataclass(frozen=True)
class Range:
    """An allowed interval, readable as data: ``lo``/``hi`` (None: unbounded), each end
    open or closed, ``integer`` for whole numbers, ``why`` the reason for a bound.

    Called as ``check(value, scene_values)`` it returns None or the error text."""

    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    integer: bool = False
    why: str = ""

    @property
    def text(self) -> str:
        """The interval in words: ``> 0``, ``an integer >= 1``, ``in (0, 1e6]``, ..."""
        kind = "an integer " if self.integer else ""
        lo, hi = _num(self.lo, self.integer), _num(self.hi, self.integer)
        if self.hi is None:
            return f"{kind}{'>' if self.lo_open else '>='} {lo}"
        if self.lo is None:
            return f"{kind}{'<' if self.hi_open else '<='} {hi}"
        lb, rb = "(" if self.lo_open else "[", ")" if self.hi_open else "]"
        return f"{kind}in {lb}{lo}, {hi}{rb}"

    def __call__(self, v, _scene=None):
        ok = ((self.lo is None or (v > self.lo if self.lo_open else v >= self.lo))
              and (self.hi is None or (v < self.hi if self.hi_open else v <= self.hi)))
        return None if ok else f"must be {self.text}" + (f" ({self.why})" if self.why else "")

    def as_dict(self) -> dict:
        return {"kind": "range", "min": self.lo, "max": self.hi, "min_open": self.lo_open,
                "max_open": self.hi_open, "integer": self.integer, "text": self.text,
                "why": self.why}


@dataclass(frozen=True)
class OneOf:
    """One of a fixed set of values (strings), readable as data."""

    choices: tuple
    why: str = ""

    @property
    def text(self) -> str:
        q = [f'"{c}"' for c in self.choices]
        return "one of " + ", ".join(q) if len(q) > 2 else " or ".join(q)

    def __call__(self, v, _scene=None):
        if v in self.choices:
            return None
        q = [f'"{c}"' for c in self.choices]
        return "must be " + (", ".join(q[:-1]) + " or " + q[-1] if len(q) > 1 else q[0]) + \
            (f" ({self.why})" if self.why else "")

    def as_dict(self) -> dict:
        return {"kind": "choice", "choices": list(self.choices), "text": self.text,
                "why": self.why}


@dataclass(frozen=True)
class Relation:
    """A bound that depends on other keys: ``text`` states it (read as data), ``test``
    (value, scene_values) -> None or the error text applies it."""

    text: str
    test: object
    keys: tuple = ()

    def __call__(self, v, scene):
        return self.test(v, scene)

    def as_dict(self) -> dict:
        return {"kind": "relation", "text": self.text, "depends_on": list(self.keys)}


@dataclass(frozen=True)
class Key:
    """One scene key: its type, default, allowed values (``check``: a :class:`Range`,
    :class:`OneOf` or :class:`Relation`, all readable as data; None: any value of the
    type), meaning and unit; ``dims``: the dimensions whose scene text writes it (a key
    of 3-D scenes only is left out of a 2-D scene's text, where it has its default);
    ``quiet_default``: a key added after scenes were stored, left out of the text at its
    default, so that the texts (and the checkpoint identities built from them) of the
    scenes that do not set it stay as they were."""

    type: type
    default: object
    check: object
    doc: str
    unit: str = ""
    dims: tuple = (2, 3)
    quiet_default: bool = False     # at its default, left out of the scene text

    @property
    def meaning(self) -> str:
        """The meaning with its unit, as error messages quote it."""
        return self.doc + (f" [{self.unit}]" if self.unit else "")

    @property
    def allowed(self) -> str:
        """The allowed values in words."""
        if self.check is None:
            return "any " + {bool: "true/false", str: "text"}.get(self.type, "value")
        return getattr(self.check, "text", "see the key's meaning")

    def as_dict(self) -> dict:
        """type, default, range (as data), unit and meaning: what ``scene --schema`` prints."""
        rng = self.check.as_dict() if hasattr(self.check, "as_dict") else None
        return {"type": self.type.__name__, "default": self.default, "unit": self.unit,
                "allowed": self.allowed, "range": rng, "meaning": self.doc}


def _positive(why=""):
    return Range(0.0, None, lo_open=True, why=why)


def _nonneg(why=""):
    return Range(0.0, None, why=why)


def _int_at_least(lo, why=""):
    return Range(lo, None, integer=True, why=why)


def _int_in(lo, hi, why=""):
    return Range(lo, hi, integer=True, why=why)


def _in_range(lo, hi, why=""):
    """(lo, hi]"""
    return Range(lo, hi, lo_open=True, why=why)


def _closed(lo, hi, why=""):
    return Range(lo, hi, why=why)


MAX_RADIUS_RATIO = 1000.0


def _radius_max(v, d):
    lo = d["disks.radius_min"]
    if not lo <= v <= MAX_RADIUS_RATIO * lo:
        return (f"must be in [disks.radius_min, {MAX_RADIUS_RATIO:g} * disks.radius_min] = "
                f"[{lo:g}, {MAX_RADIUS_RATIO * lo:g}]")
    return None


def _width(v, d):
    rmax = d["disks.radius_max"]
    if v > 1e6 * d["disks.radius_min"]:
        return f"must be <= 1e6 * disks.radius_min = {1e6 * d['disks.radius_min']:g}"
    if not d["box.periodic_x"] and d["box.dimension"] == 2:
        return None if v >= 2.0 * rmax else f"must be >= 2 * disks.radius_max = {2 * rmax:g}"
    need = 4.0 * rmax + 2.0 * d["solver.contact_margin"]
    return None if v >= need else (f"must be >= 4 * disks.radius_max + 2 * solver.contact_margin "
                                   f"= {need:g} with periodic x (minimum-image convention)")


def _periodic_x(v, d):
    if d["box.dimension"] == 3 and not v:
        return ("must be true with box.dimension = 3 (a 3-D box is periodic in x and y; "
                "side walls exist in 2-D only)")
    return None


def _certificate_speed(v, d):
    if not v >= 0:
        return "must be >= 0 (0: never)"
    return None


def _depth(v, d):
    """box.depth: 0 (the width) or a periodic extent, as box.width with periodic x."""
    if v == 0:
        return None
    need = 4.0 * d["disks.radius_max"] + 2.0 * d["solver.contact_margin"]
    if not need <= v <= 1e6 * d["disks.radius_min"]:
        return (f"must be 0 (the width) or in [4 * disks.radius_max + 2 * "
                f"solver.contact_margin, 1e6 * disks.radius_min] = [{need:g}, "
                f"{1e6 * d['disks.radius_min']:g}] (periodic along y, minimum-image "
                "convention)")
    return None


def _median(v, d):
    lo, hi = d["disks.radius_min"], d["disks.radius_max"]
    if v == 0 or lo <= v <= hi:
        return None
    return f"must be 0 (the geometric mean of the radius range) or in [{lo:g}, {hi:g}]"


# Bump when a default or the meaning of a key changes, so that a stored scene is never
# re-read with other defaults silently (packing files record the version they used).
# 2: bounded ranges for every number, disks.density_ratio, dt in the unit of the load.
# 3: radius distributions (disks.distribution and its parameters; the default "uniform"
#    draws the same radii as version 2); strings without control characters.
SCHEMA_VERSION = 3

MU_RANGE = _closed(0.0, 1e6)
DISTRIBUTIONS = ("uniform", "bidisperse", "lognormal")

SCHEMA: dict[str, Key] = {
    "scene.name": Key(str, "", None, "short name of the scene (one line, no control "
                      "characters)"),
    "scene.description": Key(str, "", None, "free text (no control characters but tab and "
                             "newline)"),
    "scene.seed": Key(int, 1, _int_in(0, 2**31 - 1),
                      "random seed (radii, start positions, solver order)"),
    "disks.n": Key(int, 200, _int_in(1, 1_000_000, "larger packings do not fit the solver's "
                                     "memory and time budget"), "number of disks"),
    "disks.radius_min": Key(float, 1.0, _in_range(0.0, 1e6), "smallest radius", "R"),
    "disks.radius_max": Key(float, 2.0, Relation(
        f"in [disks.radius_min, {MAX_RADIUS_RATIO:g} * disks.radius_min]", _radius_max,
        ("disks.radius_min",)), "largest radius", "R"),
    "disks.distribution": Key(str, "uniform", OneOf(DISTRIBUTIONS),
                              "how radii are drawn (forcespace.model.radii): uniform in "
                              "[radius_min, radius_max]; bidisperse: radius_min and radius_max "
                              "only, a fraction disks.small_fraction of small ones; lognormal: "
                              "ln r normal (median disks.lognormal_median, standard deviation "
                              "disks.lognormal_sigma) truncated to [radius_min, radius_max]"),
    "disks.small_fraction": Key(float, 0.5, _closed(0.0, 1.0),
                                "bidisperse: number fraction of disks of radius_min (rounded "
                                "to whole disks); unused otherwise"),
    "disks.lognormal_sigma": Key(float, 0.25, _in_range(0.0, 10.0),
                                 "lognormal: standard deviation of ln r; unused otherwise"),
    "disks.lognormal_median": Key(float, 0.0, Relation(
        "0 (the geometric mean sqrt(radius_min * radius_max)) or in [disks.radius_min, "
        "disks.radius_max]", _median, ("disks.radius_min", "disks.radius_max")),
        "lognormal: median radius before truncation; unused otherwise", "R"),
    "disks.density": Key(float, 1.0, _in_range(0.0, 1e12),
                         "density; a disk's mass is density*pi*r^2 (box.dimension = 2), "
                         "a sphere's density*4/3*pi*r^3 (3)", "rho"),
    "disks.density_ratio": Key(float, 1.0, _closed(1.0, 1e9),
                               "densities log-uniform in [density, density*ratio] "
                               "(1: all disks alike)"),
    "box.width": Key(float, 42.0, Relation(
        ">= 2 * disks.radius_max (side walls) or >= 4 * disks.radius_max + 2 * "
        "solver.contact_margin (periodic x), and <= 1e6 * disks.radius_min", _width,
        ("disks.radius_min", "disks.radius_max", "box.periodic_x", "solver.contact_margin")),
        "box width along x", "R"),
    "box.periodic_x": Key(bool, True, Relation(
        "true or false (box.dimension = 2); true (3: periodic in x and y)", _periodic_x,
        ("box.dimension",)), "periodic along x (else fixed side walls; 2-D only)"),
    "box.dimension": Key(int, 2, _int_in(2, 3), "2: disks in a plane (x lateral, y "
                         "vertical); 3: spheres (x and y lateral and periodic, z vertical); "
                         "the disks.* keys then describe spheres", dims=(3,)),
    "box.depth": Key(float, 0.0, Relation(
        "0 (the width) or in [4 * disks.radius_max + 2 * solver.contact_margin, 1e6 * "
        "disks.radius_min]", _depth, ("disks.radius_min", "disks.radius_max",
                                      "solver.contact_margin")),
        "3-D: box extent along y (periodic); 0: the width (a square base)", "R", dims=(3,)),
    "box.initial_packing_fraction": Key(float, 0.35, Range(0.0, 0.8, True, True,
                                                           why="a loose random start"),
                                        "area fraction of the random loose start"),
    "physics.mu": Key(float, 0.0, MU_RANGE, "disk-disk Coulomb friction coefficient"),
    "physics.plate_mu": Key(float, 0.0, MU_RANGE, "disk-wall Coulomb friction coefficient"),
    "physics.gravity": Key(float, 0.0, _closed(0.0, 1e12),
                           "gravitational acceleration along the vertical (-y in 2-D, -z in "
                           "3-D)", "F0/(rho R^(dim+1))"),
    "physics.rotation": Key(str, "auto", OneOf(("auto", "on", "off")),
                            "integrate disk rotation: auto = only when any friction is present"),
    "plates.bottom": Key(str, "fixed", OneOf(("fixed", "none")),
                         '"fixed" lower plate or "none"'),
    "plates.top": Key(str, "load", OneOf(("load", "none")),
                      '"load": upper plate under constant force; "none"'),
    "plates.top_force": Key(float, 1.0, _in_range(0.0, 1e100),
                            "downward force on the top plate", "F0"),
    "plates.top_mass": Key(float, 10.0, _in_range(0.0, 1e100), "mass of the top plate",
                           "rho R^dim"),
    "solver.dt": Key(float, 0.02, _in_range(0.0, 1e6),
                     "time step, F the top-plate load (without a top plate "
                     "rho*gravity*R^2): scaling every load leaves the run unchanged",
                     "sqrt(rho R^3 / F)"),
    "solver.tolerance": Key(float, 1e-6, Range(0.0, 1.0, True, True),
                            "relative force change per sweep that ends a time step's NLGS"),
    "solver.max_sweeps": Key(int, 1000, _int_at_least(1), "sweep cap per time step"),
    "solver.overlap_correction": Key(float, 0.2, _closed(0.0, 1.0),
                                     "fraction of an overlap's excess over the slop removed "
                                     "per step (0: Unger's rule, overlaps never pushed apart)"),
    "solver.overlap_slop": Key(float, 2e-7, _nonneg(),
                               "overlap tolerated without correction", "R"),
    "solver.relaxation": Key(float, 1.0, Range(0.0, 2.0, True, True),
                             "NLGS over-relaxation omega (1: plain Gauss-Seidel; the "
                             "converged forces do not depend on it)"),
    "solver.sweep_block": Key(int, 0, _int_at_least(0),
                              "NLGS sweep order: 0 = every sweep a fresh random order of "
                              "single contacts (the paper's); B > 0 = runs of B contacts in "
                              "spatial order, the runs shuffled (disks numbered row by row)"),
    "solver.tolerance_moving": Key(float, 0.0, Range(0.0, 1.0, hi_open=True),
                                   "NLGS tolerance while the top plate moves faster than "
                                   "solver.moving_speed (0: solver.tolerance throughout)"),
    "solver.moving_speed": Key(float, 0.0, _nonneg(),
                               "top-plate speed, relative to sqrt(F0 rbar/mbar) as "
                               "jamming.velocity_tol, above which solver.tolerance_moving "
                               "applies"),
    "solver.max_sweeps_moving": Key(int, 0, _int_at_least(0),
                                    "sweep cap per step while solver.tolerance_moving applies "
                                    "(0: solver.max_sweeps)"),
    "solver.relaxation_fallback": Key(float, 0.5, Range(0.0, 1.0, lo_open=True),
                                      "fraction of solver.max_sweeps after which an "
                                      "unconverged over-relaxed solve continues with omega = 1 "
                                      "(1: never)"),
    "solver.dt_compacting": Key(float, 0.0, _nonneg(),
                                "time step of a window that follows a window whose mean speed "
                                "exceeded solver.compacting_speed (the packing still "
                                "compacting; 0: solver.dt throughout)", "sqrt(rho R^3 / F)",
                                quiet_default=True),
    "solver.compacting_speed": Key(float, 0.0, _nonneg(),
                                   "window mean speed, relative to sqrt(F0 rbar/mbar) as "
                                   "jamming.velocity_tol, above which the next window steps by "
                                   "solver.dt_compacting (the first window always does)",
                                   quiet_default=True),
    "solver.contact_margin": Key(float, 0.1, _positive(),
                                 "pairs closer than this gap enter the contact list", "R"),
    "jamming.velocity_tol": Key(float, 1e-7, _positive(),
                                "largest mean speed of a loaded disk or the plate over a "
                                "window, relative to sqrt(F0 rbar/mbar) (F0: top-plate load "
                                "or mean disk weight), below which the packing is at rest"),
    "jamming.certificate_speed": Key(float, 0.0, Relation(
        ">= 0 (0: never)", _certificate_speed, ("box.dimension",)),
                                     "a window whose mean speed (as jamming.velocity_tol) is "
                                     "at most this ends the jam if its configuration admits a "
                                     "static network (an exact interior-point certificate); "
                                     "the static network is then found the same way"),
    "jamming.window": Key(int, 200, _int_at_least(1), "steps both must stay below tolerance"),
    "jamming.max_steps": Key(int, 400000, _int_at_least(1), "give up after this many steps"),
    "jamming.static_tolerance": Key(float, 1e-10, Range(0.0, 1.0, True, True),
                                    "relative equilibrium residual of the final static solve"),
    "jamming.static_max_sweeps": Key(int, 2000000, _int_at_least(1),
                                     "sweep cap of the final static solve"),
    "jamming.contact_gap_tol": Key(float, 1e-6, _positive(),
                                   "gap below which a pair is a contact of the packing", "R"),
    "jamming.max_overlap": Key(float, 1e-4, _positive(),
                               "largest overlap a finished packing may keep; above it the "
                               "run ends with a non-convergence report", "R"),
    "analysis.slice_height": Key(float, 0.0, _nonneg("0: no slice recorded"),
                                 "height of the middle slice analysed as in the paper", "R"),
}


def schema_table() -> list[dict]:
    """Every scene key as data: ``[{"key", "type", "default", "unit", "allowed", "range",
    "meaning"}, ...]`` in schema order (``forcespace scene --schema --json``)."""
    return [{"key": k, **spec.as_dict()} for k, spec in SCHEMA.items()]


@dataclass(frozen=True)
class Scene:
    """A validated scene: ``values`` maps every SCHEMA key to its value."""

    values: dict
    source: str
    text: str

    def __getitem__(self, key):
        return self.values[key]

    @property
    def name(self) -> str:
        return self.values["scene.name"] or Path(self.source).stem

    @property
    def dim(self) -> int:
        """Spatial dimension: 2 (disks) or 3 (spheres), ``box.dimension``."""
        return self["box.dimension"]

    @property
    def frictional(self) -> bool:
        """True when any contact can carry a tangential force."""
        return self["physics.mu"] > 0 or (self["physics.plate_mu"] > 0 and self.has_walls)

    @property
    def has_walls(self) -> bool:
        return (self["plates.bottom"] != "none" or self["plates.top"] != "none"
                or not self["box.periodic_x"])

    @property
    def rotation(self) -> bool:
        """Whether disk rotation is integrated (needs a tangential force to matter)."""
        mode = self["physics.rotation"]
        return self.frictional if mode == "auto" else mode == "on"

    def to_toml(self) -> str:
        """The complete effective scene (every key, defaults filled in; a ``quiet_default``
        key only when it differs from its default) as TOML.

        This is what packing files store, so a packing can be rebuilt exactly. Keys that
        apply to 3-D scenes only (``box.dimension``, ``box.depth``: :attr:`Key.dims`) are
        written for 3-D scenes only; a 2-D scene's text reads back to their defaults (and
        is the text it was before spheres existed).
        """
        lines = [f"# effective scene resolved from {self.source} (scene schema version "
                 f"{SCHEMA_VERSION})"]
        section = None
        for key, value in self.values.items():
            if self.dim not in SCHEMA[key].dims:     # a 3-D key in a 2-D scene
                continue
            if SCHEMA[key].quiet_default and value == SCHEMA[key].default:
                continue
            sec, name = key.split(".")
            if sec != section:
                lines.append(f"\n[{sec}]")
                section = sec
            if isinstance(value, bool):
                text = "true" if value else "false"
            elif isinstance(value, str):
                text = '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
            else:
                text = repr(value)
            lines.append(f"{name} = {text}")
        return "\n".join(lines) + "\n"

    def scaled_to(self, n: int) -> tuple["Scene", str]:
        """The scene with ``n`` disks in a box of the same shape and the same dynamics
        per unit width: width and slice height scale by f = sqrt(n / n0) (the
        packing's height follows by itself); with a load-controlled top plate its
        load and mass scale by f too (same pressure, same plate mass per width), and
        since time and speed are measured in units built from the plate load,
        ``solver.dt`` scales by sqrt(f) and ``jamming.velocity_tol`` (and a non-zero
        ``jamming.certificate_speed``) by 1/sqrt(f) (the same physical step and rest
        criterion; a non-zero ``solver.dt_compacting`` and its ``solver.compacting_speed``
        likewise). Spheres (3-D): lengths (width, a set depth, slice height) scale by
        f = (n / n0)^(1/3), the plate's load and mass by its area factor g = f^2, dt by
        sqrt(g) and velocity_tol by 1/sqrt(g).
        Returns (scene, one-line description of what was scaled)."""
        msg = SCHEMA["disks.n"].check(n, self.values) if _type_ok(n, int) else \
            "must be an integer"
        if msg:
            raise InputError(f"{self.source} (scaled to n disks)", "disks.n", msg, got=n)
        n0 = self["disks.n"]
        if self.dim == 2:
            f = g = math.sqrt(n / n0)
            law = f"f = sqrt({n}/{n0})"
        else:
            f = (n / n0) ** (1.0 / 3.0)
            g = f * f
            law = f"f = ({n}/{n0})^(1/3)"
        keys = ["box.width", "analysis.slice_height"]
        new = {"disks.n": n, "box.width": self["box.width"] * f,
               "analysis.slice_height": self["analysis.slice_height"] * f}
        if self.dim == 3 and self["box.depth"] > 0:
            keys.append("box.depth")
            new["box.depth"] = self["box.depth"] * f
        if self["plates.top"] == "load":
            keys += ["plates.top_force", "plates.top_mass", "solver.dt", "jamming.velocity_tol"]
            new.update({"plates.top_force": self["plates.top_force"] * g,
                        "plates.top_mass": self["plates.top_mass"] * g,
                        "solver.dt": self["solver.dt"] * math.sqrt(g),
                        "jamming.velocity_tol": self["jamming.velocity_tol"] / math.sqrt(g)})
            if self["solver.dt_compacting"] > 0:     # a time step and a speed, as above
                keys += ["solver.dt_compacting", "solver.compacting_speed"]
                new.update({"solver.dt_compacting": self["solver.dt_compacting"] * math.sqrt(g),
                            "solver.compacting_speed": (self["solver.compacting_speed"]
                                                        / math.sqrt(g))})
            if self["jamming.certificate_speed"] > 0:     # a speed like velocity_tol
                keys.append("jamming.certificate_speed")
                new["jamming.certificate_speed"] = (self["jamming.certificate_speed"]
                                                    / math.sqrt(g))
        sc = self.with_overrides(**new)
        what = (f"n {n0} -> {n} ({law} = {f:.4g}): "
                + ", ".join(f"{k} {self[k]:g} -> {sc[k]:.6g}" for k in keys))
        return sc, what

    def with_overrides(self, **overrides) -> "Scene":
        """A re-validated copy with ``{"physics.mu": 0.5, ...}`` replaced (None = keep)."""
        data = {k: v for k, v in overrides.items() if v is not None}
        text = self.text
        if data:
            text += "\n# command-line overrides: " + ", ".join(f"{k}={v}" for k, v in data.items())
        return validate({**self.values, **data}, f"{self.source} (with overrides)", text)


def _type_ok(value, want) -> bool:
    if want is float:
        return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if want is int:
        return isinstance(value, int) and not isinstance(value, bool)
    return isinstance(value, want)


_TYPE_NAMES = {float: "a finite number", int: "an integer", bool: "true or false", str: "a string"}


def _string_problem(key: str, v: str) -> str | None:
    """Why a scene string cannot be used, or None. HDF5 attributes (where packing files
    store the scene) cannot hold a NUL character, so such a name is refused here, before
    any simulation, and with it every control character (a name is one line; a
    description may hold tabs and newlines)."""
    allowed = "" if key == "scene.name" else "\t\n"
    for i, ch in enumerate(v):
        if (ord(ch) < 32 and ch not in allowed) or ord(ch) == 127:
            return (f"must not contain control characters (found {ch!r} at position {i}); "
                    + ("a name is one line of text" if key == "scene.name" else
                       "text, tabs and newlines are allowed"))
    return None


def validate(flat: dict, source: str, text: str = "") -> Scene:
    """Check a flat ``{"section.key": value}`` mapping against SCHEMA."""
    for key in flat:
        if key not in SCHEMA:
            section = key.split(".")[0]
            near = sorted(k for k in SCHEMA if k.startswith(section + "."))
            allowed = ("allowed keys here: " + ", ".join(near)) if near else \
                ("allowed sections: " + ", ".join(sorted({k.split('.')[0] for k in SCHEMA})))
            raise InputError(source, key, f"unknown key; {allowed}")
    values = {k: flat.get(k, spec.default) for k, spec in SCHEMA.items()}
    for key, spec in SCHEMA.items():
        v = values[key]
        if not _type_ok(v, spec.type):
            raise InputError(source, key, f"must be {_TYPE_NAMES[spec.type]} ({spec.meaning})",
                             got=v)
        if spec.type is float:
            values[key] = v = float(v)
        if spec.type is str and (msg := _string_problem(key, v)):
            raise InputError(source, key, msg, got=v)
    for key, spec in SCHEMA.items():  # range checks after types: they may read other keys
        msg = spec.check(values[key], values) if spec.check else None
        if msg:
            raise InputError(source, key, f"{msg} ({spec.meaning})", got=values[key])
    if values["plates.top"] == "none" and values["physics.gravity"] == 0:
        raise InputError(source, "plates.top", 'with physics.gravity = 0 a "load" top plate is '
                         "needed to compress the disks", got="none")
    if values["physics.gravity"] > 0 and values["plates.bottom"] == "none":
        raise InputError(source, "plates.bottom", 'must be "fixed" when gravity is on', got="none")
    return Scene(values=values, source=str(source), text=text)


def _flatten(data: dict, source: str) -> dict:
    flat = {}
    for section, body in data.items():
        if not isinstance(body, dict):
            raise InputError(source, section, "must be a [section] table; sections: "
                             + ", ".join(sorted({k.split('.')[0] for k in SCHEMA})))
        for key, value in body.items():
            if isinstance(value, dict):
                raise InputError(source, f"{section}.{key}", "nested tables are not allowed")
            flat[f"{section}.{key}"] = value
    return flat


SCENES_PACKAGE = "forcespace.scenes"   # the top-level inputs/ folder, installed as package data


def scenes() -> dict[str, str]:
    """The scenes shipped with forcespace: {name: its ``scene.description``}."""
    from importlib.resources import files

    out = {}
    for f in sorted(files(SCENES_PACKAGE).iterdir(), key=lambda f: f.name):
        if f.name.endswith(".toml"):
            data = tomllib.loads(f.read_text(encoding="utf-8"))
            out[f.name[:-5]] = str(data.get("scene", {}).get("description", ""))
    return out


def _scene_source(name_or_path):
    """(text, source label) of a scene given as a file path or a bundled name."""
    from importlib.resources import files

    p = Path(name_or_path)
    try:
        found = p.is_file()
    except OSError as exc:            # e.g. a name longer than the filesystem takes
        raise InputError(p, "(file)", f"cannot be looked up ({exc.strerror})") from None
    if not found and p.suffix in ("", ".toml") and p.parent == Path("."):
        bundled = files(SCENES_PACKAGE) / (p.stem + ".toml")
        if bundled.is_file():
            return bundled.read_text(encoding="utf-8"), f"{p.stem}.toml (bundled scene)"
    if not found:
        raise InputError(p, "(file)", "does not exist or is not a file; a scene is a TOML "
                         "file or the name of a bundled scene: " + ", ".join(scenes()))
    try:
        return p.read_text(encoding="utf-8"), str(p)
    except UnicodeDecodeError as exc:
        raise InputError(p, "(file)", f"is not a UTF-8 text file (byte {exc.start}): a scene "
                         "is a TOML text file, e.g. inputs/quick.toml") from None
    except OSError as exc:
        raise InputError(p, "(file)", f"cannot be read ({exc.strerror})") from None


def load_scene(scene) -> Scene:
    """Read and validate a scene: a TOML file path or the name of a bundled scene
    (``"quick"``, ``"paper"``: see :func:`scenes`). Every problem is an :class:`InputError`,
    an empty scene (no key at all) included."""
    text, source = _scene_source(scene)
    return parse_scene_text(text, source)


def parse_scene_text(text: str, source: str = "<packing scene>") -> Scene:
    """Validate scene TOML held in memory (e.g. the copy stored in a packing file).

    A scene that sets no key at all (an empty file, or comments only) is refused: it
    would silently run the 200-disk default scene, and an empty scene file is far more
    often a truncated file or a failed redirection than a wish for every default. Any
    scene that sets at least one key gets the documented defaults for the rest."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(source, "(syntax)", f"is not valid TOML: {exc}") from None
    flat = _flatten(data, source)
    if not flat:
        raise InputError(source, "(scene)", "is empty (no key set): a scene declares what is "
                         "simulated; start from a bundled one (forcespace scene paper > "
                         "my.toml) or set at least one key (defaults: forcespace scene "
                         "--schema)")
    return validate(flat, source, text)
