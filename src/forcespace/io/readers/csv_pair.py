"""The plain CSV pair: ``particles.csv`` and ``contacts.csv`` of one frame.

``particles.csv`` (a header row, then one row per particle; lines starting with ``#``
are comments)::

    id, x, y, r [, boundary] [, fx, fy, torque]

* ``id``: an integer, unique; ``x, y``: centre, ``r``: radius (> 0), in one length unit
  (say which: ``length_unit``); y points up (a right-handed frame; image data with y
  down: negate y, or use the PeGS reader);
* ``boundary`` (optional, 0 or 1): 1 marks a particle the data know to lie at the
  frame's edge (it touches particles outside it): the first rim layer;
* ``fx, fy, torque`` (optional, default 0): an external force [force unit] and torque
  [force unit x length unit, counter-clockwise positive] on the particle besides its
  contacts (gravity, a pin, an intruder).

``contacts.csv`` (a header row, then one row per contact)::

    i, j, fn, ft [, nx, ny] [, px, py] [, sigma_fn, sigma_ft] [, image]

* ``i, j``: particle ids; ``i`` may be ``wall`` for a contact of particle j with a
  wall (then ``nx, ny`` are required); each pair once;
* the unit normal n points from i to j (for a wall: from the wall into j); the force
  ``fn n + ft t`` acts on j (and its negative on i), t = (-ny, nx) is n turned
  counter-clockwise by 90 degrees; ``fn > 0`` is compression; so ``ft > 0`` turns both
  particles clockwise (torque -r ft on each);
* ``fn, ft`` both empty: the force is not known (geometry only);
* ``nx, ny`` (optional for particle pairs): checked against the centres (within 0.05
  rad), which define the normal; ``px, py`` (optional): the contact point, checked
  against the geometry;
* ``sigma_fn, sigma_ft`` (optional, >= 0): the standard uncertainty of fn, ft;
* ``image`` (optional, integer): j's periodic image along x (its centre at
  x_j + image x width), only with a period ``width``.

Units: any consistent pair (``length_unit``, ``force_unit``, recorded); S scales
linearly with the loads.
"""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ... import config
from ...errors import InputError
from ...model.packing import Packing
from ...model.walls import WALL
from ..h5 import atomic_path
from .common import (assemble, check_forces, check_mu, check_normals, check_pairs,
                     check_particles, index_of, provenance, source_file)

PARTICLE_COLUMNS = ("id", "x", "y", "r")
PARTICLE_OPTIONAL = ("boundary", "fx", "fy", "torque")
CONTACT_COLUMNS = ("i", "j", "fn", "ft")
CONTACT_OPTIONAL = ("nx", "ny", "px", "py", "sigma_fn", "sigma_ft", "image")
CONVENTIONS = ("n from i to j (from the wall into j); force fn n + ft t on j, t = (-ny, nx); "
               "fn > 0 compressive; torque -r ft on each particle; y up")


def _table(path, required, optional, what):
    """(header -> column of strings, data line numbers) of a CSV file, checked."""
    p = source_file(path, what)
    try:
        text = p.read_text()
    except UnicodeDecodeError:
        raise InputError(p, "(file)", "is not a text (CSV) file") from None
    lines = [(k + 1, ln) for k, ln in enumerate(text.splitlines())
             if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise InputError(p, "(file)", f"is empty: a header row {', '.join(required)} and one "
                         "row per entry expected")
    rows = list(csv.reader([ln for _, ln in lines], skipinitialspace=True))
    header = [h.strip() for h in rows[0]]
    missing = [c for c in required if c not in header]
    if missing:
        raise InputError(p, "header", f"must name the columns {', '.join(required)} "
                         f"(optional: {', '.join(optional)}); missing {', '.join(missing)}",
                         got=",".join(header))
    unknown = [c for c in header if c not in required + optional]
    if unknown or len(set(header)) != len(header):
        raise InputError(p, "header", f"columns must be among {', '.join(required + optional)}"
                         ", each once", got=",".join(header))
    body = rows[1:]
    if not body:
        raise InputError(p, "(rows)", f"no row after the header (the {what})")
    for (num, _), row in zip(lines[1:], body):
        if len(row) != len(header):
            raise InputError(p, f"line {num}", f"must have {len(header)} fields like the "
                             "header", got=len(row))
    cols = {h: [row[k].strip() for row in body] for k, h in enumerate(header)}
    return p, cols, [num for num, _ in lines[1:]]


def _numbers(p, cols, name, lines, empty=None, integer=False):
    """Column ``name`` as floats (ints); ``empty``: the value of an empty cell (None: an
    empty cell is an error)."""
    out = []
    for v, num in zip(cols[name], lines):
        if v == "" and empty is not None:
            out.append(empty)
            continue
        try:
            x = float(v) if not integer else int(v)
        except ValueError:
            kind = "an integer" if integer else "a number"
            raise InputError(p, f"{name} (line {num})", f"must be {kind}", got=v) from None
        if not integer and not np.isfinite(x):
            raise InputError(p, f"{name} (line {num})", "must be a finite number (empty: "
                             "unknown where allowed)", got=v)
        out.append(x)
    return np.array(out, dtype=np.int64 if integer else float)


def _particles(path):
    p, cols, lines = _table(path, PARTICLE_COLUMNS, PARTICLE_OPTIONAL, "particle file")
    ids = _numbers(p, cols, "id", lines, integer=True)
    x, y, r = (_numbers(p, cols, k, lines) for k in ("x", "y", "r"))
    check_particles(p, ids, x, y, r)
    boundary = None
    if "boundary" in cols:
        boundary = _numbers(p, cols, "boundary", lines, empty=0.0)
        if not np.all(np.isin(boundary, (0.0, 1.0))):
            raise InputError(p, "boundary", "must be 0 or 1 (1: at the frame's edge)")
        boundary = boundary.astype(bool)
    external = None
    if any(k in cols for k in ("fx", "fy", "torque")):
        external = np.column_stack([_numbers(p, cols, k, lines, empty=0.0) if k in cols
                                    else np.zeros(ids.size) for k in ("fx", "fy", "torque")])
    return p, ids, x, y, r, boundary, external


def _optional_pair(p, cols, lines, a, b, rows):
    """(k, 2) of columns a, b on ``rows`` (both given, or neither on a row), NaN where
    absent."""
    if a not in cols and b not in cols:
        return None
    if (a in cols) != (b in cols):
        raise InputError(p, "header", f"columns {a} and {b} come together")
    va, vb = (_numbers(p, cols, k, lines, empty=np.nan) for k in (a, b))
    half = np.flatnonzero(np.isnan(va) != np.isnan(vb))
    if half.size:
        raise InputError(p, f"{a}, {b} (line {lines[half[0]]})", "give both or neither")
    return np.column_stack([va, vb])[rows]


def _contacts(path, ids, width):
    p, cols, lines = _table(path, CONTACT_COLUMNS, CONTACT_OPTIONAL, "contact file")
    wall = np.array([v.lower() == "wall" for v in cols["i"]])
    ci = np.full(wall.size, WALL, np.int64)
    cols_i = dict(cols, i=["0" if w else v for v, w in zip(cols["i"], wall)])
    raw_i = _numbers(p, cols_i, "i", lines, integer=True)
    raw_j = _numbers(p, cols, "j", lines, integer=True)
    ci[~wall] = index_of(p, ids, raw_i[~wall], "i")
    cj = index_of(p, ids, raw_j, "j")
    fn = _numbers(p, cols, "fn", lines, empty=np.nan)
    ft = _numbers(p, cols, "ft", lines, empty=np.nan)
    given = ~np.isnan(fn) | ~np.isnan(ft)
    half = np.flatnonzero(np.isnan(fn) != np.isnan(ft))
    if half.size:
        raise InputError(p, f"fn, ft (line {lines[half[0]]})", "give both, or leave both "
                         "empty (force unknown)")
    check_forces(p, fn, ft, given)
    rows = np.arange(wall.size)
    normal = _optional_pair(p, cols, lines, "nx", "ny", rows)
    if wall.any() and (normal is None or np.isnan(normal[wall]).any()):
        k = np.flatnonzero(wall & (np.ones(wall.size, bool) if normal is None
                                   else np.isnan(normal[:, 0])))[0]
        raise InputError(p, f"nx, ny (line {lines[k]})", "a wall contact needs its unit "
                         "normal (from the wall into particle j)")
    sigma = _optional_pair(p, cols, lines, "sigma_fn", "sigma_ft", rows)
    if sigma is not None and (np.isnan(sigma).any() or (sigma < 0).any()):
        k = np.flatnonzero(np.isnan(sigma).any(axis=1) | (sigma < 0).any(axis=1))[0]
        raise InputError(p, f"sigma_fn, sigma_ft (line {lines[k]})", "must be numbers >= 0 "
                         "on every row when the columns are given")
    image = np.zeros(wall.size, np.int64)
    if "image" in cols:
        image = _numbers(p, cols, "image", lines, empty=0.0).astype(np.int64)
        if width is None and np.any(image != 0):
            raise InputError(p, "image", "a periodic image needs the period: give width")
    check_pairs(p, ci, cj)
    return p, dict(ci=ci, cj=cj, fn=fn, ft=ft, known=given, normal=normal, sigma=sigma,
                   image=image, point=_optional_pair(p, cols, lines, "px", "py", rows),
                   lines=lines)


def read_csv_pair(particles, contacts, *, mu, wall_mu=None, length_unit: str = "",
                  force_unit: str = "", width=None, frame=None,
                  gap_tol: float = config.CONTACT_GAP_TOL) -> Packing:
    """A measured :class:`Packing` from a CSV pair (module docstring for the format).

    ``mu`` (required) and ``wall_mu`` (default mu): Coulomb coefficients; ``width``: the
    period along x (default: not periodic); ``frame`` (x0, y0, x1, y1): the field of view
    (default: the particles' bounding box); ``gap_tol``: a contact whose gap or overlap
    exceeds this x the smaller radius is refused. Every check runs before any analysis;
    a bad input raises InputError naming the file, the line or id and what is allowed.
    """
    mu, wall_mu = check_mu(mu, wall_mu, "csv pair")
    if width is not None and not (np.isfinite(width) and width > 0):
        raise InputError("csv pair", "width", "must be a finite number > 0 (the period along "
                         "x), or None", got=width)
    pp, ids, x, y, r, boundary, external = _particles(particles)
    cp, c = _contacts(contacts, ids, width)
    pair = np.flatnonzero(c["ci"] >= 0)
    wall_normal = None
    if c["normal"] is not None:
        geo = None
        if pair.size:
            i, j = c["ci"][pair], c["cj"][pair]
            d = np.column_stack([x[j] + c["image"][pair] * (width or 0.0) - x[i], y[j] - y[i]])
            geo = d / np.linalg.norm(d, axis=1)[:, None]
        given = ~np.isnan(c["normal"][:, 0])
        sel = pair[given[pair]]
        if sel.size:
            check_normals(cp, c["normal"][sel], geo[given[pair]], sel)
        walls = np.flatnonzero(c["ci"] == WALL)
        wall_normal = np.zeros((c["ci"].size, 2))
        if walls.size:
            wall_normal[walls] = check_normals(cp, c["normal"][walls], None, walls)
    prov = provenance("csv pair", [pp, cp], {"length": length_unit or "(not stated)",
                                             "force": force_unit or "(not stated)"},
                      CONVENTIONS, pixel_scale=None)
    packing = assemble(cp, x=x, y=y, r=r, ci=c["ci"], cj=c["cj"], fn=c["fn"], ft=c["ft"],
                       known=c["known"], mu=mu, wall_mu=wall_mu, provenance=prov,
                       wall_normal=wall_normal, image=c["image"], width=width,
                       sigma=c["sigma"], boundary=boundary, external=external, frame=frame,
                       gap_tol=gap_tol, ids=ids, scene_name="measured: csv pair")
    _check_points(cp, packing, c["point"], gap_tol, c["lines"])
    return packing


def _check_points(source, packing, point, gap_tol, lines):
    """Given contact points lie within gap_tol x the smaller radius of the geometric ones."""
    if point is None:
        return
    given = np.flatnonzero(~np.isnan(point[:, 0]))
    a, b = packing.a[given], packing.b[given]
    rmin = np.minimum(packing.r[b], np.where(a >= 0, packing.r[np.maximum(a, 0)], np.inf))
    off = np.hypot(*(point[given] - packing.point[given]).T) / rmin
    bad = np.flatnonzero(off > gap_tol)
    if bad.size:
        k = given[bad[0]]
        raise InputError(source, f"px, py (line {lines[k]})", "must be the contact point "
                         f"(within {gap_tol:g} x the smaller radius of the geometric one)",
                         got=tuple(round(float(v), 6) for v in point[k]))


def write_csv_pair(packing: Packing, directory, *, sigma=None) -> tuple[Path, Path]:
    """Write ``packing`` as DIRECTORY/particles.csv and contacts.csv (ids = disk index;
    every contact force known; walls with their normals; periodic images in ``image``;
    BOTTOM/TOP/LEFT/RIGHT contacts written as walls). ``sigma`` (Nc, 2): uncertainty
    columns. Returns the two paths (written atomically)."""
    p = packing
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    ext = p.external if p.external is not None else None
    head = "id,x,y,r" + (",fx,fy,torque" if ext is not None else "")
    rows = [head] + [f"{i},{float(p.x[i])!r},{float(p.y[i])!r},{float(p.r[i])!r}" + (
        "," + ",".join(repr(float(v)) for v in ext[i]) if ext is not None else "")
        for i in range(p.n_disks)]
    parts = _write(d / "particles.csv", rows)
    head = "i,j,fn,ft,nx,ny,image" + (",sigma_fn,sigma_ft" if sigma is not None else "")
    out = [head]
    for k in range(p.n_contacts):
        a, b, n = int(p.a[k]), int(p.b[k]), p.normal[k]
        fn, ft = float(p.fn[k]), float(p.ft[k])
        if a >= 0 and b < 0:          # TOP / RIGHT: the wall is b; write it as i = wall
            a, b, n, fn, ft = "wall", a, -n, fn, ft
        elif a < 0:
            a = "wall"
        line = f"{a},{b},{fn!r},{ft!r},{float(n[0])!r},{float(n[1])!r},{int(p.image[k])}"
        if sigma is not None:
            line += f",{float(sigma[k, 0])!r},{float(sigma[k, 1])!r}"
        out.append(line)
    return parts, _write(d / "contacts.csv", out)


def _write(path, lines):
    with atomic_path(path) as tmp:
        Path(tmp).write_text("\n".join(lines) + "\n")
    return Path(path)
