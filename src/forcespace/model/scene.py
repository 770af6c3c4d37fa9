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


@dataclass(frozen=True)
class Key:
    type: type
    default: object
    check: object  # callable(value, scene_dict) -> None or error text
    doc: str


def _positive(v, _):
    return None if v > 0 else "must be > 0"


def _nonneg(v, _):
    return None if v >= 0 else "must be >= 0"


def _int_at_least(lo):
    return lambda v, _: None if v >= lo else f"must be an integer >= {lo}"


def _fraction(v, _):
    return None if 0 < v < 0.8 else "must be in (0, 0.8) (a loose random start)"


def _small_tol(v, _):
    return None if 0 < v < 1 else "must be in (0, 1)"


def _int_in(lo, hi, why=""):
    return lambda v, _: None if lo <= v <= hi else \
        f"must be an integer in [{lo}, {hi}]" + (f" ({why})" if why else "")


def _in_range(lo, hi, why=""):
    return lambda v, _: None if lo < v <= hi else \
        f"must be in ({lo:g}, {hi:g}]" + (f" ({why})" if why else "")


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
    if not d["box.periodic_x"]:
        return None if v >= 2.0 * rmax else f"must be >= 2 * disks.radius_max = {2 * rmax:g}"
    need = 4.0 * rmax + 2.0 * d["solver.contact_margin"]
    return None if v >= need else (f"must be >= 4 * disks.radius_max + 2 * solver.contact_margin "
                                   f"= {need:g} with periodic x (minimum-image convention)")


def _slice(v, d):
    return None if v >= 0 else "must be >= 0 (0: no slice recorded)"


def _top_mode(v, _):
    return None if v in ("load", "none") else 'must be "load" or "none"'


def _bottom_mode(v, _):
    return None if v in ("fixed", "none") else 'must be "fixed" or "none"'


# Bump when a default or the meaning of a key changes, so that a stored scene is never
# re-read with other defaults silently (packing files record the version they used).
# 2: bounded ranges for every number, disks.density_ratio, dt in the unit of the load.
SCHEMA_VERSION = 2

SCHEMA: dict[str, Key] = {
    "scene.name": Key(str, "", None, "short name of the scene"),
    "scene.description": Key(str, "", None, "free text"),
    "scene.seed": Key(int, 1, _int_in(0, 2**31 - 1),
                      "random seed (radii, start positions, solver order)"),
    "disks.n": Key(int, 200, _int_in(1, 1_000_000, "larger packings do not fit the solver's "
                                     "memory and time budget"), "number of disks"),
    "disks.radius_min": Key(float, 1.0, _in_range(0.0, 1e6), "smallest radius [R]"),
    "disks.radius_max": Key(float, 2.0, _radius_max, "largest radius [R]; radii uniform in [min, max]"),
    "disks.density": Key(float, 1.0, _in_range(0.0, 1e12),
                         "2-D density; disk mass = density*pi*r^2"),
    "disks.density_ratio": Key(float, 1.0, lambda v, _: None if 1.0 <= v <= 1e9 else
                               "must be in [1, 1e9]",
                               "densities log-uniform in [density, density*ratio] "
                               "(1: all disks alike)"),
    "box.width": Key(float, 42.0, _width, "box width along x [R]"),
    "box.periodic_x": Key(bool, True, None, "periodic along x (else fixed side walls)"),
    "box.initial_packing_fraction": Key(float, 0.35, _fraction,
                                        "area fraction of the random loose start"),
    "physics.mu": Key(float, 0.0, lambda v, _: None if 0 <= v <= 1e6 else "must be in [0, 1e6]",
                      "disk-disk Coulomb friction coefficient"),
    "physics.plate_mu": Key(float, 0.0, lambda v, _: None if 0 <= v <= 1e6 else
                            "must be in [0, 1e6]", "disk-wall Coulomb friction coefficient"),
    "physics.gravity": Key(float, 0.0, lambda v, _: None if 0 <= v <= 1e12 else
                           "must be in [0, 1e12]", "gravitational acceleration along -y"),
    "physics.rotation": Key(str, "auto", lambda v, _: None if v in ("auto", "on", "off") else
                            'must be "auto", "on" or "off"',
                            "integrate disk rotation: auto = only when any friction is present"),
    "plates.bottom": Key(str, "fixed", _bottom_mode, '"fixed" lower plate or "none"'),
    "plates.top": Key(str, "load", _top_mode, '"load": upper plate under constant force; "none"'),
    "plates.top_force": Key(float, 1.0, _in_range(0.0, 1e100),
                            "downward force on the top plate [F0]"),
    "plates.top_mass": Key(float, 10.0, _in_range(0.0, 1e100), "mass of the top plate [rho R^2]"),
    "solver.dt": Key(float, 0.02, _in_range(0.0, 1e6),
                     "time step [sqrt(rho R^3 / F)], F the top-plate load (without a top "
                     "plate rho*gravity*R^2): scaling every load leaves the run unchanged"),
    "solver.tolerance": Key(float, 1e-6, _small_tol,
                            "relative force change per sweep that ends a time step's NLGS"),
    "solver.max_sweeps": Key(int, 1000, _int_at_least(1), "sweep cap per time step"),
    "solver.overlap_correction": Key(float, 0.2, lambda v, _: None if 0 <= v <= 1 else
                                     "must be in [0, 1]",
                                     "fraction of an overlap's excess over the slop removed "
                                     "per step (0: Unger's rule, overlaps never pushed apart)"),
    "solver.overlap_slop": Key(float, 2e-7, _nonneg,
                               "overlap [R] tolerated without correction"),
    "solver.relaxation": Key(float, 1.0, lambda v, _: None if 0 < v < 2 else
                             "must be in (0, 2)",
                             "NLGS over-relaxation omega (1: plain Gauss-Seidel; the "
                             "converged forces do not depend on it)"),
    "solver.sweep_block": Key(int, 0, _int_at_least(0),
                              "NLGS sweep order: 0 = every sweep a fresh random order of "
                              "single contacts (the paper's); B > 0 = runs of B contacts in "
                              "spatial order, the runs shuffled (disks numbered row by row)"),
    "solver.tolerance_moving": Key(float, 0.0, lambda v, _: None if 0 <= v < 1 else
                                   "must be in [0, 1)",
                                   "NLGS tolerance while the top plate moves faster than "
                                   "solver.moving_speed (0: solver.tolerance throughout)"),
    "solver.moving_speed": Key(float, 0.0, _nonneg,
                               "top-plate speed, relative to sqrt(F0 rbar/mbar) as "
                               "jamming.velocity_tol, above which solver.tolerance_moving "
                               "applies"),
    "solver.max_sweeps_moving": Key(int, 0, _int_at_least(0),
                                    "sweep cap per step while solver.tolerance_moving applies "
                                    "(0: solver.max_sweeps)"),
    "solver.relaxation_fallback": Key(float, 0.5, lambda v, _: None if 0 < v <= 1 else
                                      "must be in (0, 1]",
                                      "fraction of solver.max_sweeps after which an "
                                      "unconverged over-relaxed solve continues with omega = 1 "
                                      "(1: never)"),
    "solver.contact_margin": Key(float, 0.1, _positive,
                                 "pairs closer than this gap [R] enter the contact list"),
    "jamming.velocity_tol": Key(float, 1e-7, _positive,
                                "largest mean speed of a loaded disk or the plate over a "
                                "window, relative to sqrt(F0 rbar/mbar) (F0: top-plate load "
                                "or mean disk weight), below which the packing is at rest"),
    "jamming.window": Key(int, 200, _int_at_least(1), "steps both must stay below tolerance"),
    "jamming.max_steps": Key(int, 400000, _int_at_least(1), "give up after this many steps"),
    "jamming.static_tolerance": Key(float, 1e-10, _small_tol,
                                    "relative equilibrium residual of the final static solve"),
    "jamming.static_max_sweeps": Key(int, 2000000, _int_at_least(1),
                                     "sweep cap of the final static solve"),
    "jamming.contact_gap_tol": Key(float, 1e-6, _positive,
                                   "gap [R] below which a pair is a contact of the packing"),
    "jamming.max_overlap": Key(float, 1e-4, _positive,
                               "largest overlap [R] a finished packing may keep; above it "
                               "the run ends with a non-convergence report"),
    "analysis.slice_height": Key(float, 0.0, _slice,
                                 "height [R] of the middle slice analysed as in the paper"),
}


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
        """The complete effective scene (every key, defaults filled in) as TOML.

        This is what packing files store, so a packing can be rebuilt exactly.
        """
        lines = [f"# effective scene resolved from {self.source} (scene schema version "
                 f"{SCHEMA_VERSION})"]
        section = None
        for key, value in self.values.items():
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
        ``solver.dt`` scales by sqrt(f) and ``jamming.velocity_tol`` by 1/sqrt(f)
        (the same physical step and rest criterion).
        Returns (scene, one-line description of what was scaled)."""
        n0 = self["disks.n"]
        f = math.sqrt(n / n0)
        keys = ["box.width", "analysis.slice_height"]
        new = {"disks.n": n, "box.width": self["box.width"] * f,
               "analysis.slice_height": self["analysis.slice_height"] * f}
        if self["plates.top"] == "load":
            keys += ["plates.top_force", "plates.top_mass", "solver.dt", "jamming.velocity_tol"]
            new.update({"plates.top_force": self["plates.top_force"] * f,
                        "plates.top_mass": self["plates.top_mass"] * f,
                        "solver.dt": self["solver.dt"] * math.sqrt(f),
                        "jamming.velocity_tol": self["jamming.velocity_tol"] / math.sqrt(f)})
        sc = self.with_overrides(**new)
        what = (f"n {n0} -> {n} (f = sqrt({n}/{n0}) = {f:.4g}): "
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
            raise InputError(source, key, f"must be {_TYPE_NAMES[spec.type]} ({spec.doc})", got=v)
        if spec.type is float:
            values[key] = v = float(v)
    for key, spec in SCHEMA.items():  # range checks after types: they may read other keys
        msg = spec.check(values[key], values) if spec.check else None
        if msg:
            raise InputError(source, key, f"{msg} ({spec.doc})", got=values[key])
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
    if not p.is_file() and p.suffix in ("", ".toml") and p.parent == Path("."):
        bundled = files(SCENES_PACKAGE) / (p.stem + ".toml")
        if bundled.is_file():
            return bundled.read_text(encoding="utf-8"), f"{p.stem}.toml (bundled scene)"
    if not p.is_file():
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
    (``"quick"``, ``"paper"``: see :func:`scenes`). Every problem is an :class:`InputError`."""
    text, source = _scene_source(scene)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(source, "(syntax)", f"is not valid TOML: {exc}") from None
    return validate(_flatten(data, source), source, text)


def parse_scene_text(text: str, source: str = "<packing scene>") -> Scene:
    """Validate scene TOML held in memory (e.g. the copy stored in a packing file)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(source, "(syntax)", f"is not valid TOML: {exc}") from None
    return validate(_flatten(data, source), source, text)
