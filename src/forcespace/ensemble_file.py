"""The ensemble file: sampled force networks of one statics problem (HDF5).

Layout::

    /            attrs: file_kind="ensemble", forcespace_version, sampler,
                        packing_file, scene_name, scene_text, problem_kind,
                        mu_override (disk-disk friction used instead of the
                        packing's own, NaN if none),
                        slice_height, fingerprint, params (JSON), units,
                        conventions, tolerance_description
    /problem/contacts  (m,)  packing contact index of each unknown contact
    /problem/disks     (n,)  packing disk index of each interior disk
    /problem/mu        (m,)  Coulomb coefficient per unknown contact
    /problem/x_jammed  (m, 2) the packing's (jammed) forces fn, ft     [F0]
    /samples           (k, m, 2) sampled forces fn, ft per contact      [F0]
    /sample_chain      (k,)  chain that produced each sample
    /sample_violation  (k,)  max violation of S, relative to <Fn>       [1]
    /setup/...         sampler set-up arrays (e.g. affine frame, rounding)
    /checkpoint/...    state to resume: arrays + attrs (rng state as JSON)

Every write goes through a temporary copy renamed into place (h5io), so a kill
leaves either the previous or the new complete file; appends come at growing
intervals (:func:`flush_due`) so the copying stays linear in the file size.
(In-place appends to HDF5 are not crash-safe: a kill mid-write can corrupt the
file, and SWMR mode leaves a crashed file unopenable until ``h5clear``.)
"""
from __future__ import annotations

import hashlib
import json
import time
from dataclasses import dataclass, field

import numpy as np

from .errors import InputError
from .h5io import atomic_h5, atomic_replace_copy, exists, open_h5, write_dataset
from .statics import StaticsProblem

KIND = "ensemble"
SPREAD_FLOOR = 1e-8   # rms spread of samples per contact, in <Fn>, below which S is a point


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


@dataclass
class Ensemble:
    """An ensemble file read into memory. samples: (k, 2m) in problem column order."""

    path: str
    sampler: str
    samples: np.ndarray
    chains: np.ndarray
    violations: np.ndarray
    contacts: np.ndarray
    disks: np.ndarray
    mu: np.ndarray
    x_jammed: np.ndarray
    force_scale: float
    attrs: dict = field(default_factory=dict)
    setup: dict = field(default_factory=dict)
    checkpoint: dict = field(default_factory=dict)
    checkpoint_attrs: dict = field(default_factory=dict)

    @property
    def n_samples(self) -> int:
        return int(self.samples.shape[0])

    @property
    def forces(self) -> np.ndarray:
        """Sampled forces (k, m, 2): fn, ft of each unknown contact [F0]."""
        return self.samples.reshape(self.n_samples, -1, 2)

    @property
    def eta(self) -> float:
        """The paper's force ambiguity of the samples (:func:`forcespace.measures.eta`)."""
        from .measures import eta
        return eta(self.samples)

    def distances_from_centre(self):
        """(l (k,), l0, lbar) [F0]: distances of the samples and of the jammed state
        from the samples' mean (the paper's Fig. 3)."""
        from .measures import distance_from_centre
        return distance_from_centre(self.samples, self.x_jammed)

    def plot(self, packing, sample: int = -1, ax=None, **kw):
        """Draw sample ``sample`` (default the last) as the force network of
        ``packing`` (fixed loads keep their values); returns the Axes."""
        fn = np.array(packing.fn, float)
        ft = np.array(packing.ft, float)
        fn[self.contacts] = self.forces[sample, :, 0]
        ft[self.contacts] = self.forces[sample, :, 1]
        kw.setdefault("title", f"{self.sampler} sample {sample % self.n_samples} of "
                               f"{self.n_samples}")
        return packing.plot(ax, values=fn, **kw)

    def summary(self) -> dict:
        """The numbers ``forcespace ensemble`` prints: provenance, eta, Fig. 3
        distances (no ratio when the samples differ only at the solver's
        accuracy) and, for hit-and-run, R-hat/ESS diagnostics."""
        a = self.attrs
        out = {"ensemble": self.path, "sampler": self.sampler, "n_samples": self.n_samples,
               "packing_file": a.get("packing_file"), "scene_name": a.get("scene_name"),
               "problem_kind": a.get("problem_kind"), "mu_override": a.get("mu_override"),
               "slice_height": a.get("slice_height"),
               "n_contacts": int(self.contacts.size), "force_scale": self.force_scale,
               "max_violation": float(self.violations.max(initial=0.0)),
               "max_violation_convention": "max over samples of the largest equilibrium/"
                                           "Coulomb violation divided by <Fn> (jammed mean "
                                           "normal force)",
               "tolerance": a.get("tolerance_description"),
               "forcespace_version": a.get("forcespace_version"), "eta": None}
        if self.n_samples:
            out["eta"] = self.eta
            _, l0, lbar = self.distances_from_centre()
            out["jammed_distance_from_centre"] = l0
            out["mean_sample_distance_from_centre"] = lbar
            rms_spread = lbar / (self.force_scale * np.sqrt(max(self.contacts.size, 1)))
            if rms_spread > SPREAD_FLOOR:
                out["jammed_distance_over_mean"] = l0 / lbar
            else:   # a ratio of two round-off numbers means nothing
                out["jammed_distance_over_mean"] = None
                out["jammed_distance_over_mean_reason"] = (
                    f"samples differ only at the solver's accuracy (rms spread "
                    f"{rms_spread:.1e} <Fn> <= {SPREAD_FLOOR:g}): S is numerically a point")
        if self.sampler == "hit-and-run" and self.n_samples >= 8:
            from .hit_and_run import diagnostics
            out.update(diagnostics(self.samples, self.chains))
        return out

    def __repr__(self) -> str:
        where = f", path={self.path!r}" if self.path and not self.path.startswith("<") else ""
        return (f"Ensemble(sampler={self.sampler!r}, n_samples={self.n_samples}, "
                f"n_contacts={self.contacts.size}{where})")


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


def create(path, problem: StaticsProblem, sampler: str, params: dict, packing_file: str,
           scene_name: str, scene_text: str, setup: dict, setup_describe: dict,
           checkpoint: dict, checkpoint_attrs: dict, tolerance_description: str) -> None:
    """Write a new ensemble file with no samples yet."""
    fp = fingerprint(problem, sampler, params)
    m = problem.n_contacts
    with atomic_h5(path, {"file_kind": KIND}) as f:
        f.attrs.update({
            "sampler": sampler, "packing_file": str(packing_file), "scene_name": scene_name,
            "scene_text": scene_text, "problem_kind": problem.kind,
            "slice_height": np.nan if problem.height is None else problem.height,
            "fingerprint": fp, "params": json.dumps(params, sort_keys=True),
            "force_scale": problem.force_scale,
            "mu_override": np.nan if problem.meta.get("mu_override") is None
            else float(problem.meta["mu_override"]),
            "units": "forces in F0 (the packing's force unit); lengths in R",
            "conventions": "samples[k, j] = (fn, ft) of unknown contact j (packing contact "
                           "problem/contacts[j]); force fn*n + ft*t on body b, t = (-ny, nx)",
            "tolerance_description": tolerance_description})
        g = f.create_group("problem")
        g.attrs["description"] = "the statics problem the samples solve (see forcespace.statics)"
        write_dataset(g, "contacts", problem.contacts, "1", "packing contact index per unknown")
        write_dataset(g, "disks", problem.disks, "1", "packing disk index per interior disk")
        write_dataset(g, "mu", problem.mu, "1", "Coulomb coefficient per unknown contact")
        write_dataset(g, "x_jammed", problem.x_jammed.reshape(m, 2), "F0",
                      "jammed (packing) forces of the unknown contacts", columns=["fn", "ft"])
        ds = f.create_dataset("samples", shape=(0, m, 2), maxshape=(None, m, 2), dtype="f8",
                              chunks=(max(1, min(64, 65536 // max(1, 2 * m))), m, 2))
        ds.attrs.update({"units": "F0", "description": "sampled admissible force networks",
                         "columns": ["fn", "ft"]})
        for name, dt, desc in (("sample_chain", "i8", "chain index of each sample"),
                               ("sample_violation", "f8",
                                "max violation of equilibrium/Coulomb relative to <Fn>")):
            d = f.create_dataset(name, shape=(0,), maxshape=(None,), dtype=dt, chunks=(1024,))
            d.attrs.update({"units": "1", "description": desc})
        _write_state(f, "setup", setup, describe=setup_describe)
        _write_state(f, "checkpoint", checkpoint, checkpoint_attrs)


CHECKPOINT_SECONDS = 60.0


def flush_due(n_buffered: int, n_written: int, every: int, since_last: float) -> bool:
    """Whether a sampler should append its buffered samples now.

    Every append rewrites the file (atomically, through a temporary copy), so
    the interval grows with the file: at least ``every`` samples and at least
    a tenth of those already written (total I/O linear in the final size, not
    quadratic), but never more than CHECKPOINT_SECONDS of work at risk.
    """
    if n_buffered == 0:
        return False
    return n_buffered >= max(every, n_written // 10) or since_last >= CHECKPOINT_SECONDS


class SampleWriter:
    """Buffers a sampler's samples and appends them to its ensemble file.

    ``state(n_total)`` returns the checkpoint (arrays, attrs) that resumes the
    walk after ``n_total`` samples; it is called at every append. Appends come
    when :func:`flush_due` says so, or when ``max_seconds`` since ``t_start``
    have passed (then :meth:`add` returns True: stop). Used as a context
    manager it appends whatever is buffered on exit, error or not, so finished
    samples are never lost.
    """

    def __init__(self, out, n_written: int, every: int, state, max_seconds=None,
                 t_start=None):
        self.out, self.n_written, self.every, self.state = out, n_written, every, state
        self.max_seconds = max_seconds
        self.last = time.perf_counter()
        self.t_start = self.last if t_start is None else t_start
        self._x, self._chain, self._violation = [], [], []

    @property
    def n_total(self) -> int:
        """Samples written plus buffered."""
        return self.n_written + len(self._x)

    def add(self, x, chain: int, violation: float) -> bool:
        """Buffer one sample (2m,); append when due. Returns True when time is up."""
        self._x.append(x)
        self._chain.append(chain)
        self._violation.append(violation)
        now = time.perf_counter()
        timeout = self.max_seconds is not None and now - self.t_start > self.max_seconds
        if timeout or flush_due(len(self._x), self.n_written, self.every, now - self.last):
            self.flush()
        return timeout

    def flush(self) -> None:
        if self._x:
            arrays, attrs = self.state(self.n_total)
            self.n_written = append(self.out, np.array(self._x),
                                    np.array(self._chain, np.int64), self._violation,
                                    arrays, attrs)
            self._x, self._chain, self._violation = [], [], []
        self.last = time.perf_counter()

    def __enter__(self) -> "SampleWriter":
        return self

    def __exit__(self, *exc) -> bool:
        self.flush()
        return False


def append(path, X, chains, violations, checkpoint: dict, checkpoint_attrs: dict) -> int:
    """Append samples X (k, 2m) and replace the checkpoint, atomically. Returns total count."""
    X = np.asarray(X, float)
    with atomic_replace_copy(path) as f:
        ds = f["samples"]
        k0 = ds.shape[0]
        k = X.shape[0]
        ds.resize(k0 + k, axis=0)
        ds[k0:] = X.reshape(k, -1, 2)
        for name, vals in (("sample_chain", chains), ("sample_violation", violations)):
            d = f[name]
            d.resize(k0 + k, axis=0)
            d[k0:] = np.asarray(vals)
        _write_state(f, "checkpoint", checkpoint, checkpoint_attrs)
        return k0 + k


def read(path, samples: bool = True) -> Ensemble:
    """Read an ensemble file (InputError if it is not one); ``samples=False`` reads
    everything but the samples (and their chains and violations)."""
    with open_h5(path, KIND) as f:
        try:
            g = f["problem"]
            m = g["contacts"].shape[0]
            X = f["samples"][()].reshape(-1, 2 * m) if samples else np.empty((0, 2 * m))
            return _check(Ensemble(
                path=str(path), sampler=str(f.attrs["sampler"]), samples=X,
                chains=f["sample_chain"][()] if samples else np.empty(0, np.int64),
                violations=f["sample_violation"][()] if samples else np.empty(0),
                contacts=g["contacts"][()], disks=g["disks"][()], mu=g["mu"][()],
                x_jammed=g["x_jammed"][()].reshape(-1), force_scale=float(f.attrs["force_scale"]),
                attrs={k: (v.item() if hasattr(v, "item") else v) for k, v in f.attrs.items()},
                setup={k: v[()] for k, v in f["setup"].items()},
                checkpoint={k: v[()] for k, v in f["checkpoint"].items()},
                checkpoint_attrs={k: (v.item() if hasattr(v, "item") else v)
                                  for k, v in f["checkpoint"].attrs.items()}))
        except KeyError as exc:
            raise InputError(path, str(exc.args[0]) if exc.args else "?",
                             "missing; not a complete forcespace ensemble file") from None
        except (ValueError, TypeError, OSError) as exc:
            raise InputError(path, "(layout)", f"unreadable as a forcespace ensemble file "
                             f"({exc})") from None


def _check(ens: Ensemble) -> Ensemble:
    """Shapes and finiteness of an ensemble read from disk (InputError otherwise)."""
    m = ens.contacts.size
    k = ens.n_samples
    for name, shape in (("sample_chain", (k,)), ("sample_violation", (k,)),
                        ("problem/mu", (m,)), ("problem/x_jammed", (2 * m,))):
        arr = {"sample_chain": ens.chains, "sample_violation": ens.violations,
               "problem/mu": ens.mu, "problem/x_jammed": ens.x_jammed}[name]
        if arr.shape != shape:
            raise InputError(ens.path, name, f"must have shape {shape}", got=arr.shape)
    if not np.all(np.isfinite(ens.samples)):
        raise InputError(ens.path, "samples", "must be finite (found NaN/inf)")
    if not (np.isfinite(ens.force_scale) and ens.force_scale > 0):
        raise InputError(ens.path, "force_scale", "must be a finite number > 0",
                         got=ens.force_scale)
    return ens


def existing(path, problem: StaticsProblem, sampler: str, params: dict):
    """The ensemble at ``path`` if it continues this exact run, None if absent.

    Raises InputError if the file belongs to another problem/sampler/parameters.
    """
    if not exists(path):
        return None
    p = path
    ens = read(p)
    if ens.attrs.get("fingerprint") != fingerprint(problem, sampler, params):
        raise InputError(p, "fingerprint", "belongs to another packing, slice, sampler or "
                         "parameter set; choose another output or delete it to restart")
    return ens
