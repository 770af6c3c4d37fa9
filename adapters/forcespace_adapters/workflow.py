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
from dataclasses import asdict
from pathlib import Path

import numpy as np

from forcespace.errors import InputError
from forcespace.model.packing import Packing
from forcespace.io.outputs import check_output_dir, check_output_file, mark_run_dir
from forcespace.io.packing_file import read_packing, write_packing

from . import liggghts
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


def export(code: str, packing_path, directory, options=None, y_range=None,
           top: str = "plate") -> Path:
    """Write a run directory for ``code`` from the packing file ``packing_path``.

    ``top``: "plate" (load-controlled top plate, default for both codes) or
    "loads" (the plate's rigid forces as fixed dead loads; unstable).
    """
    if code not in CODES:
        raise InputError("export", "code", f"must be one of {CODES}", got=code)
    rigid = read_packing(packing_path)
    prob = soft_problem(rigid, y_range, top=top, source=packing_path)
    d = check_output_dir(directory)
    if code == "liggghts":
        if y_range is not None:
            raise InputError(packing_path, "slice", "LIGGGHTS export supports the full packing "
                             "only (slice loads need per-atom torques); use pymunk")
        opt = options or liggghts.LiggghtsOptions()
        liggghts.write_deck(prob, d, opt, source=packing_path)
    else:
        opt = options or PymunkOptions()
        opt.validate()
        if d.exists():           # empty, or made by forcespace (check_output_dir)
            shutil.rmtree(d)
        d.mkdir(parents=True)
        mark_run_dir(d)
    shutil.copyfile(packing_path, d / ".rigid.h5.tmp")
    os.replace(d / ".rigid.h5.tmp", d / "rigid.h5")
    _write_json(d / "run.json", {"code": code, "options": asdict(opt), "top": top,
                                 "y_range": list(y_range) if y_range is not None else None,
                                 "packing": str(Path(packing_path).resolve())})
    return d


def run(code: str, directory, binary=None, timeout=None, progress=None) -> dict:
    """Run the code on a run directory; returns its status dict."""
    meta = _run_json(directory)
    if meta["code"] != code:
        raise InputError(directory, "run.json code", f"this directory is for {meta['code']}", got=code)
    d = check_output_dir(directory)
    if code == "liggghts":
        return liggghts.run_deck(d, binary=binary, timeout=timeout)
    rigid = read_packing(d / "rigid.h5")
    prob = soft_problem(rigid, meta["y_range"], top=meta.get("top", "plate"), source=d / "rigid.h5")
    soft, info = simulate(prob, PymunkOptions(**meta["options"]), progress)
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
    if code == "liggghts":
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


def import_run(code: str, directory, out_path) -> Packing:
    """Read a finished run and write its soft network file ``out_path``."""
    check_output_file(out_path)
    soft, _ = load_soft(code, directory)
    write_packing(soft, out_path, kind="soft_network", extra_attrs=_attrs(soft))
    return soft
