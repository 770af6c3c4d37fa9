"""The packing file: a :class:`~forcespace.model.packing.Packing` in self-describing HDF5.

Layout::

    /            attrs: file_kind="packing", forcespace_version, code_version (with the
                        git commit), format_version, scene_schema_version, mu, plate_mu, seed,
                        scene_name, scene_text (the full TOML), units, conventions
    /disks       (n, 3) columns x, y, r                         [R]
    /disk_density (n,)  per-disk density, only when not uniform  [rho]
    /box         attrs: width, periodic_x, y_bottom, y_top       [R]
                        top_force [F0], gravity, density
    /contacts/bodies  (Nc, 2) int  columns a, b   (disk index or wall code)
    /contacts/image   (Nc,)   int  periodic image of b (x_b + image*width)
    /contacts/normal  (Nc, 2)      unit normal a -> b
    /contacts/point   (Nc, 2)      contact point                [R]
    /contacts/gap     (Nc,)        surface gap, negative = overlap [R]
    /forces           (Nc, 2) columns fn, ft  force on b        [F0]
    /plate_forces     (k, 2)  per-wall total force on the wall  [F0]
    /external    (n, 3)  per-disk external force fx, fy [F0], torque [F0 R] (if any)
    /measured    a measured network (read from another code or an experiment), if any:
                 known (Nc,) int8 (1: the contact's force is data), sigma (Nc, 2)
                 [F0] uncertainty of fn, ft (if given), boundary (n,) int8 (the data's
                 frame-edge flags, if given); attrs provenance (JSON: format, source files
                 and their sha256, units, pixel scale, conventions), frame (x0, y0, x1,
                 y1) [R] (if given)
    /solver_log  (k, 5)  compression history (see its attributes)
    /meta        attrs: solver statistics of the run that made the packing

A sphere packing (:class:`~forcespace.model.sphere_packing.SpherePacking`, format 3 on)
carries the root attribute ``dimension = 3`` and the 3-D form of the same layout::

    /spheres          (n, 4)  columns x, y, z, r                [R]
    /sphere_density   (n,)    per-sphere density, when not uniform [rho]
    /box              attrs: lx, ly (periodic in x and y), z_bottom, z_top [R],
                             top_force [F0], gravity (along -z), density
    /contacts/bodies  (Nc, 2) int, /contacts/image (Nc, 2) int (x and y images of b),
    /contacts/normal  (Nc, 3), /contacts/point (Nc, 3), /contacts/gap (Nc,)
    /forces           (Nc, 4) columns fn, ftx, fty, ftz: fn along n, the tangential
                              force vector (perpendicular to n) on b   [F0]
    /plate_forces     (k, 3)

Files without the attribute are disks (every file written before spheres existed).
"""
from __future__ import annotations

import json

import numpy as np

from ..errors import InputError
from ..model.scene import SCHEMA_VERSION
from ..model.setup import Setup
from .h5 import atomic_h5, missing_name, open_h5, write_dataset
from ..model.walls import BOTTOM, TOP, WALL_CODES, WALL_NAMES
from ..model.measurement import Measurement
from ..model.packing import Packing, check_force_signs, check_packing
from ..model.sphere_packing import SpherePacking, check_sphere_packing

UNITS = ("lengths in R (smallest radius of the scene's range); masses in rho*R^2 "
         "(disk mass = density*pi*r^2); forces in F0 (the scene's force unit)")
CONVENTIONS = ("contact k joins bodies a and b (disk index >= 0; walls -1 bottom, -2 top, "
               "-3 left, -4 right); normal points a->b; force fn*n + ft*t acts on b, "
               "t = (-n_y, n_x); fn > 0 compressive; torque on either disk = -r*ft")


UNITS_3D = ("lengths in R (smallest radius of the scene's range); masses in rho*R^3 "
            "(sphere mass = density*4/3*pi*r^3); forces in F0 (the scene's force unit)")
CONVENTIONS_3D = ("contact k joins bodies a and b (sphere index >= 0; walls -1 bottom, -2 "
                  "top, normal (0, 0, 1)); normal points a->b; force fn*n + ft acts on b, ft "
                  "the tangential force vector (perpendicular to n); fn > 0 compressive; "
                  "torque on either sphere = -r n x ft; x and y periodic")


def write_packing(packing: Packing | SpherePacking, path, kind: str = "packing",
                  extra_attrs: dict | None = None):
    """Write ``packing`` (disks or spheres) to ``path`` atomically (temp file, then
    rename)."""
    p = packing
    if getattr(p, "dim", 2) == 3:
        return write_sphere_packing(p, path, kind, extra_attrs)
    with atomic_h5(path, {"file_kind": kind}) as f:
        f.attrs.update({"scene_schema_version": SCHEMA_VERSION,
                        "mu": p.mu, "plate_mu": p.plate_mu, "seed": p.seed,
                        "scene_name": p.scene_name, "scene_text": p.scene_text,
                        "units": UNITS, "conventions": CONVENTIONS})
        for k, v in (extra_attrs or {}).items():
            f.attrs[k] = v
        write_dataset(f, "disks", np.column_stack([p.x, p.y, p.r]), "R",
                      "disk centres and radii", columns=["x", "y", "r"])
        box = f.create_group("box")
        box.attrs.update({"width": p.width, "periodic_x": p.periodic_x,
                          "y_bottom": p.y_bottom, "y_top": p.y_top,
                          "top_force": p.top_force, "gravity": p.gravity,
                          "density": float(np.mean(p.density)),
                          "description": "width [R] (periodic in x if periodic_x), plate "
                                         "surfaces y_bottom, y_top [R] (nan: absent), "
                                         "top_force: downward load on the top plate [F0], "
                                         "gravity along -y, density of the disks"})
        if np.ndim(p.density):
            write_dataset(f, "disk_density", np.asarray(p.density, float), "rho",
                          "2-D density of each disk (box/density is their mean)")
        c = f.create_group("contacts")
        c.attrs["description"] = CONVENTIONS
        write_dataset(c, "bodies", np.column_stack([p.a, p.b]).astype(np.int64), "1",
                      "body indices; disks >= 0, walls -1 bottom -2 top -3 left -4 right",
                      columns=["a", "b"])
        write_dataset(c, "image", p.image.astype(np.int64), "1",
                      "periodic image of b: its centre is at x_b + image*width")
        write_dataset(c, "normal", p.normal, "1", "unit normal from a to b", columns=["nx", "ny"])
        write_dataset(c, "point", p.point, "R", "contact point", columns=["x", "y"])
        write_dataset(c, "gap", p.gap, "R", "surface gap at the contact; negative = overlap")
        write_dataset(f, "forces", np.column_stack([p.fn, p.ft]), "F0",
                      "contact force on b: fn along n (>0 compressive), ft along t=(-ny,nx)",
                      columns=["fn", "ft"])
        F = p.contact_forces()
        walls = [w for w in WALL_CODES if ((p.a == w) | (p.b == w)).any()]
        pf = np.array([F[p.b == w].sum(0) - F[p.a == w].sum(0) for w in walls]).reshape(-1, 2)
        ds = write_dataset(f, "plate_forces", pf, "F0", "total contact force on each wall",
                           columns=["fx", "fy"])
        ds.attrs["walls"] = [WALL_NAMES[w] for w in walls]
        _write_solver_log(f, p)
        if p.external is not None:
            write_dataset(f, "external", np.asarray(p.external, float), "F0, F0, F0 R",
                          "external force and torque on each disk besides gravity",
                          columns=["fx", "fy", "torque"])
        if p.measurement is not None:
            _write_measurement(f, p.measurement)
        _write_meta(f, p)


def _write_solver_log(f, p) -> None:
    """The compression history (/solver_log) of either kind of packing."""
    if p.solver_log is None:
        return
    grain = "sphere" if getattr(p, "dim", 2) == 3 else "disk"
    write_dataset(f, "solver_log", p.solver_log, "mixed",
                  "compression history, one row per jamming window: step count, "
                  f"largest mean speed over the window of a loaded {grain} or the plate "
                  f"[R/time], largest instantaneous {grain} speed [R/time], mean NLGS sweeps "
                  "per step, largest final relative force change of a step's NLGS",
                  columns=["step", "mean_speed", "max_speed", "sweeps_per_step",
                           "nlgs_relative_change"])


def _write_meta(f, p) -> None:
    """The statistics of the run that made the packing (/meta), either kind."""
    m = f.create_group("meta")
    m.attrs["description"] = "statistics of the run that produced this file"
    for k, v in p.meta.items():
        m.attrs[k] = v if isinstance(v, (int, float, str, bool, np.number)) else json.dumps(v)


def _write_measurement(f, meas: Measurement) -> None:
    g = f.create_group("measured")
    g.attrs["description"] = ("a measured network: which contact forces are data, their "
                              "uncertainty, the data's frame-edge flags, provenance")
    g.attrs["provenance"] = meas.provenance_json()
    if meas.frame is not None:
        g.attrs["frame"] = np.asarray(meas.frame, float)
    write_dataset(g, "known", np.asarray(meas.known, np.int8), "1",
                  "1: the contact's force is measured data; 0: geometry only")
    if meas.sigma is not None:
        write_dataset(g, "sigma", np.asarray(meas.sigma, float), "F0",
                      "standard uncertainty of the measured fn, ft", columns=["fn", "ft"])
    if meas.boundary is not None:
        write_dataset(g, "boundary", np.asarray(meas.boundary, np.int8), "1",
                      "1: the data flags the particle at the edge of its frame")


def _read_measurement(f):
    if "measured" not in f:
        return None
    g = f["measured"]
    frame = g.attrs.get("frame")
    return Measurement(
        known=g["known"][()].astype(bool),
        sigma=g["sigma"][()] if "sigma" in g else None,
        boundary=g["boundary"][()].astype(bool) if "boundary" in g else None,
        frame=None if frame is None else tuple(float(v) for v in frame),
        provenance=json.loads(str(g.attrs["provenance"])))


def write_sphere_packing(p: SpherePacking, path, kind: str = "packing",
                         extra_attrs: dict | None = None) -> None:
    """Write a sphere packing (the 3-D layout of the module docstring) atomically."""
    with atomic_h5(path, {"file_kind": kind}) as f:
        f.attrs.update({"dimension": 3, "scene_schema_version": SCHEMA_VERSION,
                        "mu": p.mu, "plate_mu": p.plate_mu, "seed": p.seed,
                        "scene_name": p.scene_name, "scene_text": p.scene_text,
                        "units": UNITS_3D, "conventions": CONVENTIONS_3D})
        for k, v in (extra_attrs or {}).items():
            f.attrs[k] = v
        write_dataset(f, "spheres", np.column_stack([p.pos, p.r]), "R",
                      "sphere centres and radii", columns=["x", "y", "z", "r"])
        box = f.create_group("box")
        box.attrs.update({"lx": p.lateral[0], "ly": p.lateral[1], "z_bottom": p.z_bottom,
                          "z_top": p.z_top, "top_force": p.top_force, "gravity": p.gravity,
                          "density": float(np.mean(p.density)),
                          "description": "periodic extents lx, ly [R] along x and y, plate "
                                         "surfaces z_bottom, z_top [R] (nan: absent), "
                                         "top_force: downward load on the top plate [F0], "
                                         "gravity along -z, density of the spheres"})
        if np.ndim(p.density):
            write_dataset(f, "sphere_density", np.asarray(p.density, float), "rho",
                          "density of each sphere (box/density is their mean)")
        c = f.create_group("contacts")
        c.attrs["description"] = CONVENTIONS_3D
        write_dataset(c, "bodies", np.column_stack([p.a, p.b]).astype(np.int64), "1",
                      "body indices; spheres >= 0, walls -1 bottom -2 top", columns=["a", "b"])
        write_dataset(c, "image", p.image.astype(np.int64), "1", "periodic images of b: "
                      "its centre is at (x_b + ix lx, y_b + iy ly, z_b)", columns=["ix", "iy"])
        write_dataset(c, "normal", p.normal, "1", "unit normal from a to b",
                      columns=["nx", "ny", "nz"])
        write_dataset(c, "point", p.point, "R", "contact point", columns=["x", "y", "z"])
        write_dataset(c, "gap", p.gap, "R", "surface gap at the contact; negative = overlap")
        write_dataset(f, "forces", np.column_stack([p.fn, p.ft]), "F0",
                      "contact force on b: fn along n (>0 compressive) plus the tangential "
                      "force vector (perpendicular to n)", columns=["fn", "ftx", "fty", "ftz"])
        F = p.contact_forces()
        walls = [w for w in (BOTTOM, TOP) if ((p.a == w) | (p.b == w)).any()]
        pf = np.array([F[p.b == w].sum(0) - F[p.a == w].sum(0) for w in walls]).reshape(-1, 3)
        ds = write_dataset(f, "plate_forces", pf, "F0", "total contact force on each wall",
                           columns=["fx", "fy", "fz"])
        ds.attrs["walls"] = [WALL_NAMES[w] for w in walls]
        _write_solver_log(f, p)
        _write_meta(f, p)


def read_packing(path, kind: str = "packing") -> Packing | SpherePacking:
    """Read a packing file (or any file of the same schema, e.g. a soft network): a
    :class:`Packing` of disks, or a :class:`SpherePacking` for a file of dimension 3."""
    with open_h5(path, kind) as f:
        if _dimension(path, f) == 3:
            return _read_spheres(path, f)
        try:
            d = f["disks"][()]
            box = dict(f["box"].attrs)
            c = f["contacts"]
            ab = c["bodies"][()]
            forces = f["forces"][()]
            meta = {k: (v.item() if hasattr(v, "item") else v) for k, v in f["meta"].attrs.items()
                    if k != "description"}
            if d.ndim != 2 or d.shape[1] != 3:
                raise InputError(path, "disks", "must be an (n, 3) table x, y, r", got=d.shape)
            if ab.ndim != 2 or ab.shape[1] != 2:
                raise InputError(path, "contacts/bodies", "must be an (Nc, 2) table a, b",
                                 got=ab.shape)
            for name, v in (("contacts/bodies", ab), ("contacts/image", c["image"])):
                if not np.issubdtype(v.dtype, np.integer):    # 2.7 would be body 2
                    raise InputError(path, name, "must be stored as integers",
                                     got=v.dtype.name)
            p = Packing(
                x=d[:, 0].copy(), y=d[:, 1].copy(), r=d[:, 2].copy(),
                width=float(box["width"]), periodic_x=bool(box["periodic_x"]),
                y_bottom=float(box["y_bottom"]), y_top=float(box["y_top"]),
                top_force=float(box["top_force"]), gravity=float(box["gravity"]),
                density=(f["disk_density"][()] if "disk_density" in f
                         else float(box["density"])),
                mu=float(f.attrs["mu"]), plate_mu=float(f.attrs["plate_mu"]),
                a=ab[:, 0].astype(np.int64), b=ab[:, 1].astype(np.int64),
                normal=c["normal"][()].reshape(-1, 2), point=c["point"][()].reshape(-1, 2),
                image=c["image"][()].astype(np.int64), gap=c["gap"][()],
                fn=forces.reshape(-1, 2)[:, 0].copy(), ft=forces.reshape(-1, 2)[:, 1].copy(),
                seed=int(f.attrs["seed"]), scene_text=str(f.attrs["scene_text"]),
                scene_name=str(f.attrs["scene_name"]), meta=meta,
                solver_log=f["solver_log"][()] if "solver_log" in f else None,
                source=str(path), setup=Setup.from_text(str(f.attrs["scene_text"]),
                                                        f"{path} (scene_text)"),
                external=f["external"][()] if "external" in f else None,
                measurement=_read_measurement(f))
        except KeyError as exc:
            raise InputError(path, missing_name(exc),
                             "missing from the file; not a complete forcespace packing") from None
        except (ValueError, TypeError, IndexError) as exc:
            raise InputError(path, "(layout)", f"unreadable as a forcespace packing ({exc})") \
                from None
    check_packing(p, path)
    # a measured network may hold noisy tension (fn < 0): data to report, not a corrupt file
    return p if p.measurement is not None else check_force_signs(p, path)


def _dimension(path, f) -> int:
    """The file's ``dimension`` attribute: 2 (absent: every file before spheres) or 3."""
    dim = f.attrs.get("dimension", 2)
    if dim not in (2, 3):
        raise InputError(path, "dimension", "must be 2 (disks) or 3 (spheres)",
                         got=dim.item() if hasattr(dim, "item") else dim)
    return int(dim)


def _read_spheres(path, f) -> SpherePacking:
    """The sphere packing of an open file (the 3-D layout of the module docstring)."""
    try:
        d = f["spheres"][()]
        box = dict(f["box"].attrs)
        c = f["contacts"]
        ab = c["bodies"][()].reshape(-1, 2)
        forces = f["forces"][()].reshape(-1, 4)
        meta = {k: (v.item() if hasattr(v, "item") else v) for k, v in f["meta"].attrs.items()
                if k != "description"}
        if d.ndim != 2 or d.shape[1] != 4:
            raise InputError(path, "spheres", "must be an (n, 4) table x, y, z, r", got=d.shape)
        text = str(f.attrs["scene_text"])
        p = SpherePacking(
            pos=d[:, :3].copy(), r=d[:, 3].copy(),
            lateral=(float(box["lx"]), float(box["ly"])), z_bottom=float(box["z_bottom"]),
            z_top=float(box["z_top"]), top_force=float(box["top_force"]),
            gravity=float(box["gravity"]),
            density=(f["sphere_density"][()] if "sphere_density" in f
                     else float(box["density"])),
            mu=float(f.attrs["mu"]), plate_mu=float(f.attrs["plate_mu"]),
            a=ab[:, 0].astype(np.int64), b=ab[:, 1].astype(np.int64),
            normal=c["normal"][()].reshape(-1, 3), point=c["point"][()].reshape(-1, 3),
            image=c["image"][()].astype(np.int64).reshape(-1, 2), gap=c["gap"][()],
            fn=forces[:, 0].copy(), ft=forces[:, 1:].copy(), seed=int(f.attrs["seed"]),
            scene_text=text, scene_name=str(f.attrs["scene_name"]), meta=meta,
            solver_log=f["solver_log"][()] if "solver_log" in f else None,
            source=str(path), setup=Setup.from_text(text, f"{path} (scene_text)"))
    except KeyError as exc:
        raise InputError(path, str(exc.args[0]) if exc.args else "?",
                         "missing from the file; not a complete forcespace sphere packing") \
            from None
    except (ValueError, TypeError, IndexError) as exc:
        raise InputError(path, "(layout)", f"unreadable as a forcespace sphere packing ({exc})") \
            from None
    return check_force_signs(check_sphere_packing(p, path), path)
