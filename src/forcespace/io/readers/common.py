"""What every reader of a measured frame shares: file records, one-line errors, the
geometric checks of a contact list, and the assembly of the :class:`Packing`.

Every check runs before any analysis and raises :class:`~forcespace.errors.InputError`
naming the file, the field (a row or an id where it helps) and what is allowed.
"""
from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from ... import config
from ...errors import InputError
from ...model.measurement import Measurement
from ...model.packing import Packing
from ...model.walls import WALL
from ..h5 import code_version



def source_file(path, what: str) -> Path:
    """``path`` as an existing regular file, else InputError (missing, a directory)."""
    p = Path(path)
    if not p.exists():
        raise InputError(p, "(file)", f"does not exist (the {what})")
    if not p.is_file():
        raise InputError(p, "(file)", f"is not a regular file (the {what})")
    return p


def file_record(path) -> dict:
    """{name, sha256, bytes} of a source file (its name only: no path of this machine)."""
    data = Path(path).read_bytes()
    return {"name": Path(path).name, "sha256": hashlib.sha256(data).hexdigest(),
            "bytes": len(data)}


def provenance(fmt: str, files, units: dict, conventions: str, **extra) -> dict:
    """The provenance record of a measured packing (see :mod:`forcespace.model.measurement`)."""
    return {"format": fmt, "files": [file_record(f) for f in files], "units": units,
            "conventions": conventions, "reader": code_version(), **extra}


def check_mu(mu, wall_mu, source):
    """(mu, wall_mu) as floats in [0, 1e6]; wall_mu defaults to mu."""
    for name, v in (("mu", mu), ("wall_mu", wall_mu)):
        if name == "wall_mu" and v is None:
            continue
        try:
            ok = v is not None and np.isfinite(float(v)) and 0 <= float(v) <= 1e6
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise InputError(source, name, "must be given: the Coulomb coefficient of the "
                             "contacts, a number in [0, 1e6] (the data do not carry it)", got=v)
    return float(mu), float(mu if wall_mu is None else wall_mu)


def check_particles(source, ids, x, y, r, label="id"):
    """Unique ids, finite positions, radii > 0."""
    ids = np.asarray(ids)
    if ids.size == 0:
        raise InputError(source, "(rows)", "no particle in the file")
    uniq, counts = np.unique(ids, return_counts=True)
    if np.any(counts > 1):
        raise InputError(source, label, "particle ids must be unique",
                         got=uniq[counts > 1][0].item())
    for name, v in (("x", x), ("y", y), ("r", r)):
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise InputError(source, f"{name} of {label} {ids[bad[0]]}", "must be a finite "
                             "number (found NaN/inf)")
    bad = np.flatnonzero(np.asarray(r) <= 0)
    if bad.size:
        raise InputError(source, f"r of {label} {ids[bad[0]]}", "radius must be > 0",
                         got=float(r[bad[0]]))


def index_of(source, ids, wanted, field):
    """Indices into ``ids`` of the ids ``wanted``; InputError naming the first unknown one."""
    ids = np.asarray(ids)
    order = np.argsort(ids, kind="stable")
    pos = np.searchsorted(ids[order], wanted)
    pos = np.minimum(pos, ids.size - 1)
    found = ids[order][pos] == np.asarray(wanted)
    if not np.all(found):
        k = int(np.flatnonzero(~found)[0])
        raise InputError(source, f"{field} (row {k + 1})", "must be the id of a particle in "
                         "the particle file", got=np.asarray(wanted)[k].item())
    return order[pos]


def check_forces(source, fn, ft, known, rows=None):
    """Finite fn, ft wherever the force is known."""
    for name, v in (("fn", fn), ("ft", ft)):
        bad = np.flatnonzero(known & ~np.isfinite(v))
        if bad.size:
            k = bad[0] if rows is None else rows[bad[0]]
            raise InputError(source, f"{name} (contact row {k + 1})", "must be a finite number "
                             "(both fn and ft empty: force unknown)")


def check_pairs(source, ci, cj, rows=None):
    """No contact of a particle with itself; each pair listed once."""
    ci, cj = np.asarray(ci), np.asarray(cj)
    where = lambda k: k + 1 if rows is None else rows[k] + 1  # noqa: E731
    self_ = np.flatnonzero(ci == cj)
    if self_.size:
        raise InputError(source, f"contact row {where(self_[0])}", "joins a particle with "
                         "itself", got=int(ci[self_[0]]))
    pair = ci >= 0
    key = np.stack([np.minimum(ci, cj), np.maximum(ci, cj)], axis=1)[pair]
    if key.size:
        _, first, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
        if np.any(counts > 1):
            k = np.flatnonzero(pair)[first[np.flatnonzero(counts > 1)[0]]]
            raise InputError(source, f"contact row {where(k)}", "each pair of particles must "
                             "be listed once (this pair appears again)")


def check_touching(source, x, y, r, ci, cj, image, width, gap_tol, ids=None):
    """Every disk-disk contact touches: |gap| <= gap_tol x the smaller radius."""
    pair = np.flatnonzero((ci >= 0) & (cj >= 0))
    if pair.size == 0:
        return
    i, j = ci[pair], cj[pair]
    dx = x[j] + image[pair] * (width or 0.0) - x[i]
    gap = np.hypot(dx, y[j] - y[i]) - r[i] - r[j]
    rel = np.abs(gap) / np.minimum(r[i], r[j])
    bad = np.flatnonzero(rel > gap_tol)
    if bad.size:
        k = bad[np.argmax(rel[bad])]
        name = (lambda v: v) if ids is None else (lambda v: ids[v].item())
        raise InputError(source, f"contact {name(i[k])}-{name(j[k])}",
                         f"the two particles do not touch: |gap| / smaller radius must be <= "
                         f"{gap_tol:g} ({'gap' if gap[k] > 0 else 'overlap'} of "
                         f"{abs(gap[k]):.3g} length units; {bad.size} such contact(s); raise "
                         "gap_tol if the data are that coarse)", got=round(float(rel[k]), 4))


def check_normals(source, given, geometric, rows):
    """Given unit normals agree with the centres' direction within
    config.CONTACT_NORMAL_TOL [rad]."""
    norm = np.hypot(given[:, 0], given[:, 1])
    bad = np.flatnonzero(~np.isfinite(norm) | (np.abs(norm - 1.0) > 1e-3))
    if bad.size:
        raise InputError(source, f"nx, ny (contact row {rows[bad[0]] + 1})", "must be a unit "
                         "vector (|n| = 1 within 1e-3)", got=float(norm[bad[0]]))
    if geometric is None:
        return given / norm[:, None]
    diff = np.hypot(*(given / norm[:, None] - geometric).T)
    bad = np.flatnonzero(diff > config.CONTACT_NORMAL_TOL)
    if bad.size:
        raise InputError(source, f"nx, ny (contact row {rows[bad[0]] + 1})", "must point from "
                         "particle i to particle j (along the centres within "
                         f"{config.CONTACT_NORMAL_TOL} rad); reversed or in another frame?",
                         got=tuple(round(float(v), 4) for v in given[bad[0]]))
    return given / norm[:, None]


def assemble(source, *, x, y, r, ci, cj, fn, ft, known, mu, wall_mu, provenance,
             wall_normal=None, image=None, width=None, sigma=None, boundary=None,
             external=None, frame=None, gap_tol=config.CONTACT_GAP_TOL, ids=None,
             scene_name="measured") -> Packing:
    """The measured :class:`Packing` of a frame from checked arrays.

    ci, cj (Nc,): particle indices (0..n-1); ``ci == WALL`` marks a wall contact (its
    normal in ``wall_normal`` (Nc, 2), from the wall into disk cj). fn, ft (Nc,) [force
    unit]: force fn n + ft t on cj, n from ci to cj, t = (-ny, nx); unknown where
    ``known`` is False (stored as 0). ``width``: the period along x (None: not
    periodic); ``image`` (Nc,): cj's periodic image. Checks that every disk-disk contact
    touches (``gap_tol``)."""
    x, y, r = (np.asarray(v, float) for v in (x, y, r))
    ci, cj = np.asarray(ci, np.int64), np.asarray(cj, np.int64)
    nc = ci.size
    image = np.zeros(nc, np.int64) if image is None else np.asarray(image, np.int64)
    if width is None and np.any(image != 0):
        raise InputError(source, "image", "a periodic image needs the period (width)")
    check_touching(source, x, y, r, ci, cj, image, width, gap_tol, ids)
    known = np.asarray(known, bool)
    fn = np.where(known, fn, 0.0)
    ft = np.where(known, ft, 0.0)
    meas = Measurement(known=known, sigma=None if sigma is None else np.asarray(sigma, float),
                       boundary=None if boundary is None else np.asarray(boundary, bool),
                       frame=None if frame is None else tuple(float(v) for v in frame),
                       provenance=provenance)
    return Packing.from_arrays(
        x, y, r, ci, cj, fn, ft, width=width, periodic_x=width is not None,
        image=image if width is not None else None, mu=mu, plate_mu=wall_mu,
        scene_name=scene_name, wall_normal=wall_normal, external=external,
        measurement=meas)


__all__ = ["assemble", "check_particles", "check_pairs", "check_forces", "check_normals",
           "check_mu", "index_of", "provenance", "source_file", "file_record", "WALL"]
