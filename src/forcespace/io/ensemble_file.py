"""The ensemble file: sampled force networks of one statics problem (HDF5).

Layout::

    /            attrs: file_kind="ensemble", forcespace_version, code_version, sampler,
                        packing_file, scene_name, scene_text, problem_kind,
                        mu_override (disk-disk friction used instead of the
                        packing's own, NaN if none),
                        slice_height, fingerprint, params (JSON), units,
                        conventions, tolerance_description, diagnostics (JSON,
                        convergence of the samples so far)
    /problem/contacts  (m,)  packing contact index of each unknown contact
    /problem/disks     (n,)  packing disk index of each interior disk
    /problem/mu        (m,)  Coulomb coefficient per unknown contact
    /problem/x_jammed  (m, c) the packing's (jammed) forces fn, ft     [F0]
    /samples           (k, m, c) sampled forces fn, ft per contact      [F0]
                       (c, the components per contact, is the file's data: 2 for disks,
                       fn ft; 3 for spheres, fn f1 f2 in each contact's frame, with the
                       dataset attribute columns naming them)
    /sample_chain      (k,)  chain that produced each sample
    /sample_violation  (k,)  max violation of S, relative to <Fn>       [1]
    /sample_checksum   (k,)  64-bit BLAKE2b of each sample as written   [1]
    /setup/...         sampler set-up arrays (e.g. affine frame, rounding)
    /checkpoint/...    state to resume: arrays + attrs (rng state as JSON)

Every write goes through a temporary copy renamed into place (:mod:`forcespace.io.h5`),
so a kill leaves either the previous or the new complete file; the sampling driver
appends at growing intervals so the copying stays linear in the file size. (In-place
appends to HDF5 are not crash-safe: a kill mid-write can corrupt the file, and SWMR
mode leaves a crashed file unopenable until ``h5clear``.) Every read checks each
sample against the checksum it was written with, so a sample edited by hand is
named, never silently used.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..model.problem import StaticsProblem
from ..model.ensemble import Ensemble
from .h5 import (atomic_h5, atomic_replace_copy, code_version, missing_name, open_h5,
                 write_dataset)

KIND = "ensemble"


def _quantized(a) -> np.ndarray:
    """a to 9 significant digits of its largest entry: the same problem built with another
    BLAS thread count differs in the last bits (seen: 1e-12 absolute in b), which must
    not make a resumable file "another problem"."""
    a = np.asarray(a, float)
    top = float(np.abs(a).max(initial=0.0)) or 1.0
    return np.append(np.round(a / top, 9), float(f"{top:.9g}"))


def fingerprint(problem: StaticsProblem, sampler: str, params: dict) -> str:
    """Hash of the problem (A, b, mu, contacts) and the sampler parameters."""
    h = hashlib.sha256()
    A = problem.A.tocsr()
    for arr in (A.indptr, A.indices, _quantized(A.data), _quantized(problem.b),
                problem.mu, problem.contacts):
        h.update(np.ascontiguousarray(arr).tobytes())
    h.update(sampler.encode())
    h.update(json.dumps(params, sort_keys=True).encode())
    return h.hexdigest()[:32]


def sample_checksums(X) -> np.ndarray:
    """64-bit BLAKE2b of each sample (row of X (k, c m)), as uint64 (k,)."""
    X = np.ascontiguousarray(X, dtype=np.float64)
    return np.array([int.from_bytes(hashlib.blake2b(row.tobytes(), digest_size=8).digest(),
                                    "little") for row in X.reshape(X.shape[0], -1)],
                    dtype=np.uint64)


def provenance(problem: StaticsProblem) -> dict:
    """Root attributes that say where the samples come from (from the problem)."""
    meta = problem.meta
    return {"packing_file": str(problem.source or ""),
            "scene_name": str(meta.get("scene_name") or ""),
            "scene_text": str(meta.get("scene_text") or ""),
            "problem_kind": problem.kind,
            "slice_height": np.nan if problem.height is None else problem.height,
            "mu_override": np.nan if meta.get("mu_override") is None
            else float(meta["mu_override"])}


@dataclass
class EnsembleFile:
    """An ensemble file read into memory: the ensemble, and what resumes its run."""

    ensemble: Ensemble
    setup: dict = field(default_factory=dict)
    checkpoint: dict = field(default_factory=dict)
    checkpoint_attrs: dict = field(default_factory=dict)


def _write_state(f, group_name, arrays: dict, attrs: dict | None = None, describe=None):
    if group_name in f:
        del f[group_name]
    g = f.create_group(group_name)
    for k, v in arrays.items():
        units, desc = (describe or {}).get(k, ("1", k))
        write_dataset(g, k, np.asarray(v), units, desc)
    for k, v in (attrs or {}).items():
        g.attrs[k] = v
    return g


def create(path, problem: StaticsProblem, sampler: str, params: dict, setup: dict,
           setup_describe: dict, checkpoint: dict, checkpoint_attrs: dict,
           tolerance_description: str) -> None:
    """Write a new ensemble file with no samples yet."""
    m, c = problem.n_contacts, per_contact(problem)
    columns = COLUMNS[c]
    with atomic_h5(path, {"file_kind": KIND}) as f:
        f.attrs.update({
            "sampler": sampler, **provenance(problem),
            "fingerprint": fingerprint(problem, sampler, params),
            "params": json.dumps(params, sort_keys=True),
            "force_scale": problem.force_scale,
            "units": "forces in F0 (the packing's force unit); lengths in R",
            "conventions": CONVENTIONS[c],
            "tolerance_description": tolerance_description, "diagnostics": "{}"})
        g = f.create_group("problem")
        g.attrs["description"] = "the statics problem the samples solve " \
                                 "(see forcespace.model.problem)"
        write_dataset(g, "contacts", problem.contacts, "1", "packing contact index per unknown")
        write_dataset(g, "disks", problem.disks, "1", "packing disk index per interior disk")
        write_dataset(g, "mu", problem.mu, "1", "Coulomb coefficient per unknown contact")
        write_dataset(g, "x_jammed", problem.x_jammed.reshape(m, c), "F0",
                      "jammed (packing) forces of the unknown contacts", columns=columns)
        ds = f.create_dataset("samples", shape=(0, m, c), maxshape=(None, m, c), dtype="f8",
                              chunks=(max(1, min(64, 65536 // max(1, c * m))), m, c))
        ds.attrs.update({"units": "F0", "description": "sampled admissible force networks",
                         "columns": columns})
        for name, dt, desc in (("sample_chain", "i8", "chain index of each sample"),
                               ("sample_violation", "f8",
                                "max violation of equilibrium/Coulomb relative to <Fn>"),
                               ("sample_checksum", "u8",
                                "64-bit BLAKE2b of each sample as written")):
            d = f.create_dataset(name, shape=(0,), maxshape=(None,), dtype=dt, chunks=(1024,))
            d.attrs.update({"units": "1", "description": desc})
        _write_state(f, "setup", setup, describe=setup_describe)
        _write_state(f, "checkpoint", checkpoint, checkpoint_attrs)


def append(path, X, chains, violations, checkpoint: dict, checkpoint_attrs: dict,
           diagnostics_json: str | None = None) -> int:
    """Append samples X (k, c m) and replace the checkpoint, atomically. Returns total count."""
    X = np.asarray(X, float)
    with atomic_replace_copy(path) as f:
        ds = f["samples"]
        k0 = ds.shape[0]
        k = X.shape[0]
        if k:
            ds.resize(k0 + k, axis=0)
            ds[k0:] = X.reshape(k, -1, ds.shape[2])
            for name, vals in (("sample_chain", chains), ("sample_violation", violations),
                               ("sample_checksum", sample_checksums(X))):
                d = f[name]
                d.resize(k0 + k, axis=0)
                d[k0:] = np.asarray(vals)
        _write_state(f, "checkpoint", checkpoint, checkpoint_attrs)
        f.attrs["code_version"] = code_version()
        if diagnostics_json is not None:
            f.attrs["diagnostics"] = diagnostics_json
        return k0 + k


COLUMNS = {2: ["fn", "ft"], 3: ["fn", "f1", "f2"]}     # the components per contact
CONVENTIONS = {
    2: "samples[k, j] = (fn, ft) of unknown contact j (packing contact problem/contacts[j]); "
       "force fn*n + ft*t on body b, t = (-ny, nx)",
    3: "samples[k, j] = (fn, f1, f2) of unknown contact j (packing contact "
       "problem/contacts[j]); force fn*n + f1*t1 + f2*t2 on body b, (n, t1, t2) the "
       "contact's frame (forcespace.model.sphere_problem.tangent_frame)"}


def per_contact(problem) -> int:
    """Components per unknown contact of a problem's samples: 2 (disks), 3 (spheres)."""
    return 3 if getattr(problem, "dim", 2) == 3 else 2


def _components(f, path) -> int:
    """The components per contact a file records (its samples' last axis: 2 or 3)."""
    ds = f["samples"]
    c = int(ds.shape[2]) if ds.ndim == 3 else -1
    if c not in COLUMNS:
        raise InputError(path, "samples", "must be (k, m, 2) (disks: fn, ft) or (k, m, 3) "
                         "(spheres: fn, f1, f2)", got=ds.shape)
    return c


def _attrs(obj) -> dict:
    return {k: (v.item() if hasattr(v, "item") else v) for k, v in obj.attrs.items()}


def read_file(path, samples: bool = True) -> EnsembleFile:
    """Read an ensemble file (InputError if it is not one, or if a sample no longer
    matches its checksum); ``samples=False`` reads everything but the samples. The
    ensemble comes without its diagnostics: the sampling stage computes them
    (:func:`forcespace.sampling.diagnostics.read_ensemble`)."""
    with open_h5(path, KIND) as f:
        try:
            g = f["problem"]
            m, c = g["contacts"].shape[0], _components(f, path)
            X = f["samples"][()].reshape(-1, c * m) if samples else np.empty((0, c * m))
            attrs = _attrs(f)
            ens = Ensemble(
                sampler=str(attrs["sampler"]), samples=X,
                chains=f["sample_chain"][()] if samples else np.empty(0, np.int64),
                violations=f["sample_violation"][()] if samples else np.empty(0),
                contacts=g["contacts"][()], disks=g["disks"][()], mu=g["mu"][()],
                x_jammed=g["x_jammed"][()].reshape(-1), force_scale=float(attrs["force_scale"]),
                params=json.loads(attrs.get("params", "{}")), attrs=attrs, path=str(path),
                per_contact=c)
            if "sample_checksum" not in f:     # without it an edited sample would pass
                raise InputError(path, "sample_checksum", "missing: every ensemble file "
                                 "keeps one checksum per sample, so an edited sample is "
                                 "named; this one cannot be trusted: sample again")
            checks = f["sample_checksum"][()] if samples else None
            out = EnsembleFile(ens, setup={k: v[()] for k, v in f["setup"].items()},
                               checkpoint={k: v[()] for k, v in f["checkpoint"].items()},
                               checkpoint_attrs=_attrs(f["checkpoint"]))
        except KeyError as exc:
            raise InputError(path, missing_name(exc),
                             "missing; not a complete forcespace ensemble file") from None
        except (ValueError, TypeError, OSError) as exc:
            raise InputError(path, "(layout)", f"unreadable as a forcespace ensemble file "
                             f"({exc})") from None
    _check(ens, checks)
    return out


def _check(ens: Ensemble, checksums) -> Ensemble:
    """Shapes, finiteness and checksums of an ensemble read from disk (InputError)."""
    m = ens.contacts.size
    k = ens.n_samples
    for name, arr, shape in (("sample_chain", ens.chains, (k,)),
                             ("sample_violation", ens.violations, (k,)),
                             ("problem/mu", ens.mu, (m,)),
                             ("problem/x_jammed", ens.x_jammed, (ens.per_contact * m,))):
        if arr.shape != shape:
            raise InputError(ens.path, name, f"must have shape {shape}", got=arr.shape)
    if not np.all(np.isfinite(ens.samples)):
        raise InputError(ens.path, "samples", "must be finite (found NaN/inf)")
    if not (np.isfinite(ens.force_scale) and ens.force_scale > 0):
        raise InputError(ens.path, "force_scale", "must be a finite number > 0",
                         got=ens.force_scale)
    if checksums is not None:
        if checksums.shape != (k,):
            raise InputError(ens.path, "sample_checksum", f"must have shape ({k},)",
                             got=checksums.shape)
        bad = np.flatnonzero(sample_checksums(ens.samples) != checksums)
        if bad.size:
            raise InputError(ens.path, f"samples[{bad[0]}]", f"was changed after it was "
                             f"written ({bad.size} sample(s) no longer match their "
                             "checksum); the file cannot be trusted: sample again")
    return ens


def existing(path, problem: StaticsProblem, sampler: str, params: dict):
    """The :class:`EnsembleFile` at ``path`` if it continues this exact run, None if
    absent. InputError if it belongs to another problem/sampler/parameters."""
    from pathlib import Path

    if not Path(path).exists():
        return None
    ef = read_file(path)
    if ef.ensemble.attrs.get("fingerprint") != fingerprint(problem, sampler, params):
        raise InputError(path, "fingerprint", "belongs to another packing, slice, sampler or "
                         "parameter set; choose another output or delete it to restart")
    return ef
