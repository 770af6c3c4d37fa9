"""Run directories: export a packing for a DEM code, run it, import the soft network.

A run directory holds ``rigid.h5`` (a copy of the rigid packing), ``run.json``
(code, options, problem) and the code's own files. LIGGGHTS: the deck of
:mod:`.liggghts`. pymunk: ``result.h5`` (soft network) after ``run``.
The soft network file (``import``) has the packing schema with
``file_kind = "soft_network"`` and the run's parameters as root attributes.
"""
from __future__ import annotations

import json
import os
import shutil
from dataclasses import asdict, fields
from pathlib import Path

import numpy as np

from forcespace.errors import InputError
from forcespace import Packing, SpherePacking
from forcespace.extend import (check_output_dir, check_output_file, probe_writable,
                               recording_new_entries, writing_run_dir)
from forcespace import read_packing, write_packing

from . import liggghts, liggghts3d
from .problem import soft_problem
from .pymunk_sim import PymunkOptions, simulate

CODES = ("liggghts", "pymunk")


def _write_json(path: Path, obj):
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(obj, indent=1))
    os.replace(tmp, path)


def _run_json(directory) -> dict:
    d = Path(directory)
    try:
        return json.loads((d / "run.json").read_text())
    except FileNotFoundError:
        raise InputError(d, "run.json", "missing: not a run directory (use forcespace export)") from None


def make_options(code: str, options=None, **kw):
    """The options object of ``code``: ``options`` may be a :class:`LiggghtsOptions` /
    :class:`PymunkOptions`, a dict of their fields, or None (defaults); keywords override
    fields. Unknown fields and bad values are an InputError naming the field. Units:
    stiffness kn in <Fn>/R, tolerances in <Fn>, pymunk dt in sqrt(m_min R/<Fn>)."""
    if code not in CODES:
        raise InputError("options", "code", f"must be one of {CODES}", got=code)
    cls = liggghts.LiggghtsOptions if code == "liggghts" else PymunkOptions
    if options is None:
        base = {}
    elif isinstance(options, cls):
        base = asdict(options)
    elif isinstance(options, dict):
        base = dict(options)
    else:
        raise InputError("options", "options", f"must be a {cls.__name__}, a dict of its "
                         "fields or None", got=type(options).__name__)
    base.update(kw)
    allowed = {f.name for f in fields(cls)}
    unknown = sorted(set(base) - allowed)
    if unknown:
        raise InputError("options", unknown[0], f"unknown {code} option; allowed: "
                         + ", ".join(sorted(allowed)))
    opt = cls(**base)
    opt.validate("options")
    return opt


def export(code: str, packing, directory, options=None, y_range=None,
           top: str = "plate", **option_kw) -> Path:
    """Write a run directory for ``code`` ("liggghts" or "pymunk") from ``packing`` (a
    packing file path, a :class:`~forcespace.Packing` or a
    :class:`~forcespace.SpherePacking`: spheres export to LIGGGHTS' 3-D deck,
    :mod:`.liggghts3d`; pymunk is 2-D) and return it.

    ``options``: options object, dict or None, ``option_kw`` override its fields (see
    :func:`make_options`), e.g. ``export("liggghts", "p.h5", "deck", kn=1e6)``.
    ``y_range``: (y0, y1) simulates only the disks with centres in it (pymunk only).
    ``top``: "plate" (load-controlled top plate, default) or "loads" (the plate's rigid
    forces as fixed dead loads; unstable for real packings).
    """
    opt = make_options(code, options, **option_kw)
    if isinstance(packing, (Packing, SpherePacking)):
        rigid, source = packing, "packing"
    else:
        rigid, source = read_packing(packing), packing
    spheres = getattr(rigid, "dim", 2) == 3
    if spheres:
        _check_sphere_export(code, y_range, top, source)
    else:
        prob = soft_problem(rigid, y_range, top=top, source=source)
    d = check_output_dir(directory)

    def run_files(folder: Path) -> None:
        if isinstance(packing, (Packing, SpherePacking)):
            write_packing(rigid, folder / "rigid.h5")
        else:
            shutil.copyfile(packing, folder / "rigid.h5")
        _write_json(folder / "run.json", {
            "code": code, "options": asdict(opt), "top": top,
            "units": "kn in <Fn>/R, tolerances in <Fn>, pymunk dt in sqrt(m_min R/<Fn>)",
            "y_range": list(y_range) if y_range is not None else None,
            "packing": str(Path(packing).resolve())
            if not isinstance(packing, (Packing, SpherePacking))
            else None})

    if spheres:
        liggghts3d.write_deck3(rigid, d, opt, source=source, also=run_files)
    elif code == "liggghts":
        if y_range is not None:
            raise InputError(source, "slice", "LIGGGHTS export supports the full packing "
                             "only (slice loads need per-atom torques); use pymunk")
        liggghts.write_deck(prob, d, opt, source=source, also=run_files)
    else:
        with writing_run_dir(d) as folder:        # all of it at once, or nothing
            run_files(folder)
    return d


def _check_sphere_export(code: str, y_range, top: str, source) -> None:
    """InputError for what a sphere packing cannot be exported as: pymunk is a 2-D engine,
    and the 3-D deck runs the full packing under its load-controlled plate only."""
    if code != "liggghts":
        raise InputError(source, "code", "pymunk is a 2-D physics engine (disks only): "
                         "export a sphere packing to liggghts", got=code)
    if y_range is not None or top != "plate":
        raise InputError(source, "y_range / top", "the 3-D LIGGGHTS deck runs the full "
                         "sphere packing under its load-controlled top plate only",
                         got=(y_range, top))


def run(code: str, directory, binary=None, timeout=None, progress=None,
        show_progress: bool = False) -> dict:
    """Run ``code`` on a run directory made by :func:`export`; returns its status dict
    (``converged``, ``steps``, ...). ``binary``/``timeout``: LIGGGHTS executable and
    seconds; ``progress(step, residual)``: pymunk progress callback; ``show_progress``:
    LIGGGHTS' steps and residual as a progress bar on stderr."""
    meta = _run_json(directory)
    if meta["code"] != code:
        raise InputError(directory, "run.json code", f"this directory is for {meta['code']}", got=code)
    import math
    if timeout is not None and not (isinstance(timeout, (int, float))
                                    and math.isfinite(timeout) and 0 < timeout <= 1e9):
        raise InputError("options", "timeout", "must be a number of seconds in (0, 1e9]",
                         got=timeout)
    d = Path(directory)
    probe_writable(d, d, "DIRECTORY")          # written into, never replaced
    if code == "liggghts":
        return liggghts.run_deck(d, binary=binary, timeout=timeout, show_progress=show_progress)
    rigid = read_packing(d / "rigid.h5")
    prob = soft_problem(rigid, meta["y_range"], top=meta.get("top", "plate"), source=d / "rigid.h5")
    soft, info = simulate(prob, PymunkOptions(**meta["options"]), progress)
    with recording_new_entries(d):
        write_packing(soft, d / "result.h5", kind="soft_network", extra_attrs=_attrs(soft))
        _write_json(d / "status.json", info)
    return info


def load_soft(code: str, directory) -> tuple[Packing, Packing]:
    """(soft network, rigid packing) of a finished run directory."""
    meta = _run_json(directory)
    if meta["code"] != code:
        raise InputError(directory, "run.json code", f"this directory is for {meta['code']}", got=code)
    d = Path(directory)
    rigid = read_packing(d / "rigid.h5")
    if code == "liggghts" and getattr(rigid, "dim", 2) == 3:
        soft, _ = liggghts3d.read_result3(d, rigid)
    elif code == "liggghts":
        soft, _ = liggghts.read_result(d, rigid)
    else:
        if not (d / "result.h5").exists():
            raise InputError(d, "result.h5", "missing; run it first (forcespace run pymunk DIR)")
        soft = read_packing(d / "result.h5", kind="soft_network")
    return soft, rigid


def _attrs(soft: Packing) -> dict:
    out = {}
    for k, v in soft.meta.items():
        if isinstance(v, (bool, np.bool_)):
            out[f"run_{k}"] = bool(v)
        elif isinstance(v, (int, float, str, np.number)):
            out[f"run_{k}"] = v
    return out


def import_run(code: str, directory, out_path=None) -> Packing:
    """The soft network of a finished run (a :class:`Packing` whose ``meta`` holds the
    run's parameters and status), also written to ``out_path`` if given."""
    if out_path is not None:
        check_output_file(out_path)
    soft, _ = load_soft(code, directory)
    if out_path is not None:
        write_packing(soft, out_path, kind="soft_network", extra_attrs=_attrs(soft))
    return soft
