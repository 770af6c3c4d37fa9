"""LIGGGHTS / LAMMPS: ``dump local`` of ``compute pair/gran/local`` with the atom dump.

Two text dump files of one run (disks as spheres in a 2-D slab, as forcespace's
LIGGGHTS adapter writes them):

* the atom dump (``dump custom``): ``ITEM: ATOMS`` with named columns ``id``, ``x``,
  ``y`` and ``radius`` (or ``diameter``); ``z``, if present, must be one value (a slab);
  per-atom wall forces of a primitive wall (``fix wall/gran ... store_force yes``) as
  columns ``NAME[1] NAME[2]`` (the wall's force on the atom), each NAME with the wall's
  unit normal into the atoms (``walls``; default: the adapter's ``f_force_wall`` bottom
  plane, normal (0, 1), and ``f_force_wallt`` top plate, (0, -1)); other columns are
  ignored;
* the contact dump (``dump local``): ``ITEM: ENTRIES`` with the columns of ``compute
  pair/gran/local`` in the order of its keywords (``keywords``, default the adapter's
  ``id force force_normal force_tangential delta``: id1 id2 periodic-flag, the force on
  atom id1 (3), its normal and tangential parts (3 + 3), the overlap). ``id`` and
  ``force`` are needed.

The box (``ITEM: BOX BOUNDS``): x periodic (``pp``) gives the period; a periodic y is
refused (forcespace knows a period along x only). The timestep: the last one present in
both files (or ``step``). Forces in forcespace's convention: n from atom id1 to id2 (the
minimum image), the force on id2 is minus the dumped force on id1: fn = F2 . n,
ft = F2 . t, t = (-ny, nx).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import config
from ...errors import InputError
from ...model.packing import Packing
from ...model.walls import WALL
from ..h5 import atomic_path
from .common import (assemble, check_mu, check_pairs, check_particles, index_of, provenance,
                     source_file)

WIDTHS = {"id": 3, "pos": 6, "vel": 6, "force": 3, "force_normal": 3, "force_tangential": 3,
          "torque": 3, "history": None, "contactArea": 1, "delta": 1, "heatFlux": 1,
          "contactPoint": 3}
KEYWORDS = ("id", "force", "force_normal", "force_tangential", "delta")
WALLS = {"f_force_wall": (0.0, 1.0), "f_force_wallt": (0.0, -1.0)}
CONVENTIONS = ("n from atom id1 to id2 (minimum image); force on id2 = minus the dumped force "
               "on id1; fn = F2.n, ft = F2.t, t = (-ny, nx); wall columns: the wall's force on "
               "the atom, fn along the wall's normal into the atom")


def _blocks(path, section):
    """{timestep: (box (3, 2) or None, periodic flags, header names, rows (k, c))}."""
    p = source_file(path, "atom dump" if section == "ATOMS" else "contact dump (dump local)")
    try:
        lines = p.read_text().splitlines()
    except UnicodeDecodeError:
        raise InputError(p, "(file)", "is not a text dump file") from None
    out, k = {}, 0
    while k < len(lines):
        if not lines[k].startswith("ITEM: TIMESTEP"):
            k += 1
            continue
        try:
            step = int(lines[k + 1])
            count = int(lines[k + 3])
            box_head = lines[k + 4].split()
            flags = box_head[3:6]
            box = np.array([[float(v) for v in lines[k + 5 + d].split()[:2]] for d in range(3)])
            head = lines[k + 8]
        except (IndexError, ValueError):
            raise InputError(p, f"line {k + 1}", "a dump block needs ITEM: TIMESTEP, NUMBER OF "
                             "..., BOX BOUNDS and the header of its rows") from None
        if not head.startswith(f"ITEM: {section}"):
            raise InputError(p, f"line {k + 9}", f"expected 'ITEM: {section} ...' (is this the "
                             f"{'atom' if section == 'ATOMS' else 'contact'} dump?)",
                             got=head[:40])
        rows = [r.split() for r in lines[k + 9:k + 9 + count]]
        try:
            table = np.array(rows, dtype=float).reshape(count, -1)
        except ValueError:
            raise InputError(p, f"lines {k + 10}-{k + 9 + count}", "every row must hold the "
                             "same number of numbers") from None
        if not np.all(np.isfinite(table)):
            bad = np.argwhere(~np.isfinite(table))[0]
            raise InputError(p, f"line {k + 10 + bad[0]}", "must be finite numbers (found "
                             "NaN/inf)")
        out[step] = (box, flags, head.split()[2:], table)
        k += 9 + count
    if not out:
        raise InputError(p, "(file)", f"holds no dump block (ITEM: TIMESTEP ... ITEM: {section})")
    return p, out


def _atoms(p, block, walls):
    box, flags, names, t = block
    need = ["id", "x", "y"]
    rad = "radius" if "radius" in names else "diameter" if "diameter" in names else None
    missing = [c for c in need if c not in names] + ([] if rad else ["radius"])
    if missing:
        raise InputError(p, "ITEM: ATOMS", "must name the columns id, x, y and radius (or "
                         "diameter)", got=" ".join(names))
    if t.shape[1] != len(names):
        raise InputError(p, "ITEM: ATOMS", f"rows must hold {len(names)} values like the header",
                         got=t.shape[1])
    col = {n: t[:, k] for k, n in enumerate(names)}
    ids = col["id"]
    if np.any(ids != np.round(ids)):
        raise InputError(p, "id", "atom ids must be integers")
    ids = ids.astype(np.int64)
    r = col[rad] / (2.0 if rad == "diameter" else 1.0)
    if "z" in col and np.ptp(col["z"]) > 1e-9 * max(float(np.max(r)), 1e-300):
        raise InputError(p, "z", "all atoms must lie in one plane (a 2-D slab of spheres)",
                         got=float(np.ptp(col["z"])))
    check_particles(p, ids, col["x"], col["y"], r)
    wall_force = {}
    for name, normal in walls.items():
        pair = [f"{name}[1]", f"{name}[2]"]
        if all(c in col for c in pair):
            wall_force[name] = (np.column_stack([col[c] for c in pair]),
                                np.asarray(normal, float))
        elif any(c in col for c in pair):
            raise InputError(p, name, f"a wall's force needs both columns {pair[0]} and {pair[1]}")
    return ids, col["x"], col["y"], r, wall_force


def _columns(keywords):
    """{keyword: slice} of the dump local columns, and their count."""
    cols, k = {}, 0
    for kw in keywords:
        w = WIDTHS.get(kw, -1)
        if w is None or w < 0:
            raise InputError("lammps", "keywords", f"must be keywords of compute pair/gran/local "
                             f"with a fixed width: {', '.join(k for k, v in WIDTHS.items() if v)}",
                             got=kw)
        cols[kw] = slice(k, k + w)
        k += w
    if "id" not in cols or "force" not in cols:
        raise InputError("lammps", "keywords", "must include id and force", got=" ".join(keywords))
    return cols, k


def _periodic(p, box, flags):
    if len(flags) < 2 or any(f not in ("pp", "ff", "fs", "fm", "ss", "sm", "ms", "mm", "sf",
                                       "mf") for f in flags[:2]):
        raise InputError(p, "ITEM: BOX BOUNDS", "must give the boundary flags (pp, ff, ...)",
                         got=" ".join(flags))
    if flags[1] == "pp":
        raise InputError(p, "ITEM: BOX BOUNDS", "y must not be periodic (forcespace knows a "
                         "period along x only)", got=" ".join(flags))
    return float(box[0, 1] - box[0, 0]) if flags[0] == "pp" else None


def read_lammps_dump(atoms, contacts, *, mu, wall_mu=None, keywords=KEYWORDS, walls=None,
                     step=None, length_unit: str = "", force_unit: str = "",
                     gap_tol: float = config.CONTACT_GAP_TOL) -> Packing:
    """A measured :class:`Packing` from an atom dump and a ``dump local`` of ``compute
    pair/gran/local`` (module docstring). ``mu`` (required), ``wall_mu`` (default mu);
    ``keywords``: the compute's keywords in order; ``walls``: {column name: normal into
    the atoms} of per-atom wall forces (default :data:`WALLS`); ``step``: the timestep
    (default the last one in both files)."""
    mu, wall_mu = check_mu(mu, wall_mu, "lammps")
    cols, width = _columns(list(keywords))
    pa, ablocks = _blocks(atoms, "ATOMS")
    pc, cblocks = _blocks(contacts, "ENTRIES")
    common = sorted(set(ablocks) & set(cblocks))
    if step is None:
        if not common:
            raise InputError(pc, "ITEM: TIMESTEP", "no timestep is in both dumps (atoms "
                             f"{sorted(ablocks)[-1]}, contacts {sorted(cblocks)[-1]})")
        step = common[-1]
    for p, blocks in ((pa, ablocks), (pc, cblocks)):
        if step not in blocks:
            raise InputError(p, "ITEM: TIMESTEP", f"has no block of step {step}",
                             got=sorted(blocks)[-5:])
    ids, x, y, r, wall_force = _atoms(pa, ablocks[step], WALLS if walls is None else walls)
    box, flags, _, table = cblocks[step]
    period = _periodic(pa, *ablocks[step][:2])
    if table.size and table.shape[1] != width:
        raise InputError(pc, "ITEM: ENTRIES", f"rows must hold {width} values for the keywords "
                         f"{' '.join(keywords)}", got=table.shape[1])
    table = table.reshape(-1, width)
    idc = table[:, cols["id"]]
    if np.any(idc[:, :2] != np.round(idc[:, :2])):
        raise InputError(pc, "id1, id2", "atom ids must be integers")
    ci = index_of(pc, ids, idc[:, 0].astype(np.int64), "id1")
    cj = index_of(pc, ids, idc[:, 1].astype(np.int64), "id2")
    check_pairs(pc, ci, cj)
    dx = x[cj] - x[ci]
    image = np.zeros(ci.size, np.int64) if period is None else -np.round(dx / period).astype(
        np.int64)
    d = np.column_stack([dx + image * (period or 0.0), y[cj] - y[ci]])
    n = d / np.maximum(np.linalg.norm(d, axis=1), 1e-300)[:, None]
    t = np.column_stack([-n[:, 1], n[:, 0]])
    F2 = -table[:, cols["force"]][:, :2]
    fn, ft = np.sum(F2 * n, axis=1), np.sum(F2 * t, axis=1)
    ci, cj, fn, ft, image, wn = _with_walls(ci, cj, fn, ft, image, wall_force)
    prov = provenance("lammps dump local", [pa, pc], {"length": length_unit or "(the run's)",
                                                      "force": force_unit or "(the run's)"},
                      CONVENTIONS, pixel_scale=None, timestep=int(step),
                      keywords=list(keywords), walls={k: list(v) for k, v in
                                                      (WALLS if walls is None else walls).items()})
    return assemble(pc, x=x, y=y, r=r, ci=ci, cj=cj, fn=fn, ft=ft,
                    known=np.ones(ci.size, bool), mu=mu, wall_mu=wall_mu, provenance=prov,
                    wall_normal=wn, image=image, width=period, gap_tol=gap_tol, ids=ids,
                    scene_name="measured: lammps dump")


def _with_walls(ci, cj, fn, ft, image, wall_force):
    """The contact arrays with one WALL contact per atom and nonzero wall-force column."""
    wn = [np.zeros((ci.size, 2))]
    for force, normal in wall_force.values():
        nrm = normal / np.linalg.norm(normal)
        tng = np.array([-nrm[1], nrm[0]])
        k = np.flatnonzero(np.any(force != 0.0, axis=1))
        ci = np.concatenate([ci, np.full(k.size, WALL)])
        cj = np.concatenate([cj, k])
        fn = np.concatenate([fn, force[k] @ nrm])
        ft = np.concatenate([ft, force[k] @ tng])
        image = np.concatenate([image, np.zeros(k.size, np.int64)])
        wn.append(np.tile(nrm, (k.size, 1)))
    return ci, cj, fn, ft, image, np.vstack(wn)


def write_lammps_dump(packing: Packing, directory, step: int = 0) -> tuple[Path, Path]:
    """Write ``packing`` as DIRECTORY/atoms.dump and contacts.dump in the LIGGGHTS
    adapter's layout (ids = disk index + 1; BOTTOM contacts in ``f_force_wall``, TOP in
    ``f_force_wallt``; for tests and round trips). Returns the two paths."""
    p = packing
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    if np.any(p.a <= -3) or np.any(p.b <= -3):
        raise InputError("write_lammps_dump", "contacts", "only BOTTOM and TOP walls map onto "
                         "the adapter's wall columns")
    F = p.contact_forces()
    n = p.n_disks
    wall = {"f_force_wall": np.zeros((n, 2)), "f_force_wallt": np.zeros((n, 2))}
    for k in np.flatnonzero((p.a < 0) | (p.b < 0)):
        if p.a[k] < 0:
            wall["f_force_wall"][p.b[k]] += F[k]
        else:
            wall["f_force_wallt"][p.a[k]] -= F[k]
    force, torque, _ = p.net_forces()
    ylo = float(np.nanmin([p.y_bottom, (p.y - p.r).min()]))
    yhi = float(np.nanmax([p.y_top, (p.y + p.r).max()]))
    box = (f"ITEM: BOX BOUNDS {'pp' if p.periodic_x else 'ff'} ff pp\n0 {p.width!r}\n"
           f"{ylo!r} {yhi!r}\n-5 5\n")
    head = "id x y radius fx fy tqz f_force_wall[1] f_force_wall[2] f_force_wallt[1] " \
           "f_force_wallt[2]"
    rows = [" ".join(repr(float(v)) if c else str(i + 1) for c, v in enumerate(
        [i + 1, p.x[i], p.y[i], p.r[i], *force[i], torque[i], *wall["f_force_wall"][i],
         *wall["f_force_wallt"][i]])) for i in range(n)]
    atoms = _write(d / "atoms.dump", f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{n}\n"
                   f"{box}ITEM: ATOMS {head}\n" + "\n".join(rows) + "\n")
    pair = np.flatnonzero((p.a >= 0) & (p.b >= 0))
    lines = []
    for k in pair:
        f1 = -F[k]
        fnv, ftv = -p.fn[k] * p.normal[k], -p.ft[k] * p.tangent[k]
        vals = [f1[0], f1[1], 0.0, fnv[0], fnv[1], 0.0, ftv[0], ftv[1], 0.0, -p.gap[k]]
        lines.append(f"{p.a[k] + 1} {p.b[k] + 1} {int(p.image[k] != 0)} "
                     + " ".join(repr(float(v)) for v in vals))
    ent = " ".join(f"c_cpg[{k}]" for k in range(1, 14))
    cont = _write(d / "contacts.dump", f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ENTRIES\n"
                  f"{pair.size}\n{box}ITEM: ENTRIES {ent}\n" + "\n".join(lines) + "\n")
    return atoms, cont


def _write(path, text):
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text)
    return Path(path)
