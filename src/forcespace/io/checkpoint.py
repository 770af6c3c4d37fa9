"""The compression checkpoint: the state of an unfinished jam in self-describing HDF5.

Written atomically (:func:`forcespace.io.h5.atomic_h5`: built in memory, then a
temporary file renamed into place), so a kill never leaves half a checkpoint. Layout::

    /        attrs: file_kind = "compression_checkpoint", forcespace_version,
                    code_version, format_version, scene (the scene it belongs to, TOML
                    without the step budget), steps, phase, v_first, and the run's
                    statistics by name (sweeps_total, ...)
    /bodies/{x, y, th, vx, vy, w}   (nb,)  body state (disks, then the 4 wall slots)
    /bodies/{pos, th, v, w}         (nb, 3) the same for spheres (3-D)
    /contacts/{keys, rn, rt}        (Nc,)  the last step's contacts (warm start; rt (Nc, 3)
                                           for spheres)
    /log                            (k, 5) one row per window (see COLUMNS)

Anything that is not such a file (garbage, another HDF5 file, a missing field) is
one :class:`~forcespace.errors.InputError` naming the file.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from .h5 import atomic_h5, open_h5, write_dataset

KIND = "compression_checkpoint"
BODY_FIELDS = {"x": ("R", "centre x (wall slots unused)"),
               "y": ("R", "centre y (wall slots: plate surfaces)"),
               "th": ("rad", "rotation"),
               "vx": ("R/T", "velocity x, T = sqrt(rho R^3 / sigma)"),
               "vy": ("R/T", "velocity y"),
               "w": ("rad/T", "angular velocity")}
# spheres (3-D): vectors as rows (nb, 3)
BODY_FIELDS_3D = {"pos": ("R", "centre x, y, z (wall slots: plate surfaces in z)"),
                  "th": ("rad", "accumulated rotation vector"),
                  "v": ("R/T", "velocity, T = sqrt(rho R^3 / sigma)"),
                  "w": ("rad/T", "angular velocity")}
CONTACT_FIELDS = {"keys": ("1", "contact key a*(n+4) + b, sorted"),
                  "rn": ("sigma", "normal force, sigma the engine's force unit"),
                  "rt": ("sigma", "tangential force")}
LOG_COLUMNS = ("step", "v_mean", "v_max", "sweeps_per_step", "max_rel_change")


def write_checkpoint(path, identity: str, state: dict) -> None:
    """Write a compression state atomically.

    ``identity``: the identity string of the scene the state belongs to
    (:attr:`forcespace.model.setup.Setup.identity`); ``state``: the
    arrays of BODY_FIELDS and CONTACT_FIELDS, ``log`` (k, 5), and scalars ``steps``,
    ``phase`` (str), ``v_first``, ``rest_after`` (the step before which the rest
    criterion is not tested), ``retries`` (static solves that sent the run back),
    ``seconds`` (wall seconds of the run so far), ``ended`` (what ended a jammed run:
    "rest" or "certificate") and ``stats`` (a dict of named numbers). rest_after,
    retries and seconds read as 0 and ended as "" when absent, as in files written
    before they existed.
    """
    with atomic_h5(path, {"file_kind": KIND}) as f:
        f.attrs["scene"] = identity
        f.attrs["steps"] = int(state["steps"])
        f.attrs["phase"] = str(state["phase"])
        f.attrs["v_first"] = float(state["v_first"])
        f.attrs["rest_after"] = int(state.get("rest_after", 0))
        f.attrs["retries"] = int(state.get("retries", 0))
        f.attrs["seconds"] = float(state.get("seconds", 0.0))
        f.attrs["ended"] = str(state.get("ended", ""))
        for k, v in state["stats"].items():
            f.attrs[f"stats.{k}"] = v
        g = f.create_group("bodies")
        for k, (units, desc) in _body_fields(state).items():
            write_dataset(g, k, np.asarray(state[k], float), units, desc)
        g = f.create_group("contacts")
        for k, (units, desc) in CONTACT_FIELDS.items():
            write_dataset(g, k, state[k], units, desc)
        write_dataset(f, "log", np.asarray(state["log"], float).reshape(-1, 5), "mixed",
                      "one row per compression window; speeds in R/T", columns=LOG_COLUMNS)


def same_scene(stored, identity: str) -> bool:
    """Does a checkpoint's scene text ``stored`` name the scene of ``identity``
    (:attr:`forcespace.model.setup.Setup.identity`)? Also when it was written before a key
    was added to the scene language: the stored text read as a scene and written again
    (every key, the new ones at their defaults, which leave a run as it was) is compared."""
    if stored == identity:
        return True
    from ..model.scene import parse_scene_text

    try:
        return parse_scene_text(str(stored)).to_toml().split("\n", 1)[1] == identity
    except (ValueError, IndexError, InputError):
        return False


def read_checkpoint(path, identity: str) -> dict | None:
    """The state saved in ``path`` for the scene of ``identity``; None if there is no
    such file.

    InputError (one line, naming the file) for a file that is not a compression
    checkpoint, lacks a field, or belongs to another scene.
    """
    path = Path(path)
    if not path.is_file():
        return None
    with open_h5(path, kind=KIND) as f:
        if not same_scene(f.attrs.get("scene"), identity):
            raise InputError(path, "scene", "checkpoint belongs to another scene; delete it "
                             "to start afresh")
        try:
            out = {k: f["bodies"][k][()] for k in _body_fields(f["bodies"])}
            out.update({k: f["contacts"][k][()] for k in CONTACT_FIELDS})
            out["log"] = f["log"][()].reshape(-1, 5)
            out["steps"] = int(f.attrs["steps"])
            out["phase"] = str(f.attrs["phase"])
            out["v_first"] = float(f.attrs["v_first"])
            out["rest_after"] = int(f.attrs.get("rest_after", 0))
            out["retries"] = int(f.attrs.get("retries", 0))
            out["seconds"] = float(f.attrs.get("seconds", 0.0))
            out["ended"] = str(f.attrs.get("ended", ""))
            out["stats"] = {k[6:]: f.attrs[k].item() for k in f.attrs if k.startswith("stats.")}
        except (KeyError, ValueError, TypeError, OSError) as exc:
            raise InputError(path, "(checkpoint)", f"is incomplete or corrupt ({exc}); delete "
                             "it to start afresh") from None
    nc = out["keys"].shape
    flat = "x" in out
    if out["rn"].shape != nc or out["rt"].shape[:1] != nc \
            or out["rt"].ndim != (1 if flat else 2) or (flat and out["x"].ndim != 1):
        raise InputError(path, "(checkpoint)", "arrays of inconsistent shapes; delete it to "
                         "start afresh")
    return out


def _body_fields(state) -> dict:
    """The body fields of a state or a file's /bodies group: 2-D (x, y, ...) or 3-D (pos,
    ...)."""
    return BODY_FIELDS if "x" in state else BODY_FIELDS_3D


def remove_checkpoint(path) -> None:
    """Delete a finished run's checkpoint (no error if it is gone)."""
    Path(path).unlink(missing_ok=True)
