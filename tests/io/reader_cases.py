"""Bad inputs of the measured-frame readers: one case each, written from a small valid frame.

``CASES``: (reader, case, how to spoil the valid files, a fragment of the one-line message).
Every case is read by ``tests/io/test_readers.py``; the table of the issue-41 note is
printed from the same list (``python tests/io/reader_cases.py``).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

import forcespace as fs
from forcespace.io.readers import (read_csv_pair, read_lammps_dump, read_pegs, read_pegs2,
                                   write_csv_pair, write_lammps_dump, write_pegs, write_pegs2)
from forcespace.model.walls import BOTTOM, TOP

SCALE = 0.05


def small_frame():
    """Four disks in a row on a floor, periodic box: three pair contacts and one wall
    contact, all touching, with forces; mu = 0.5."""
    x = np.array([1.0, 3.0, 5.0, 7.0])
    y = np.full(4, 1.0)
    r = np.ones(4)
    a = np.array([0, 1, 2, BOTTOM])
    b = np.array([1, 2, 3, 0])
    return fs.Packing.from_arrays(x, y, r, a, b, fn=[1.0, 1.0, 1.0, 0.5], ft=[0.1, 0.0, -0.1, 0.0],
                                  width=20.0, periodic_x=True, y_bottom=0.0, mu=0.5,
                                  plate_mu=0.5)


def write_all(d: Path) -> dict:
    """The valid files of every format in ``d``; returns their paths."""
    p = small_frame()
    csv_parts, csv_cont = write_csv_pair(p, d / "csv")
    pegs = write_pegs(p, d / "pegs", pixel_scale=SCALE)["paths"]
    pegs2 = write_pegs2(p, d / "pegs2", pixel_scale=SCALE)["paths"]
    atoms, cont = write_lammps_dump(p, d / "lammps")
    return {"particles": csv_parts, "contacts": csv_cont, "pegs": pegs, "pegs2": pegs2,
            "atoms": atoms, "dump": cont}


def read(fmt: str, f: dict, **kw):
    if fmt == "csv":
        return read_csv_pair(f["particles"], f["contacts"], **{"mu": 0.5, "width": 20.0, **kw})
    if fmt == "pegs":
        return read_pegs(f["pegs"]["particles"], **{"pixel_scale": SCALE, "mu": 0.5,
                                                      "edge_column": 4, **kw})
    if fmt == "pegs2":
        return read_pegs2(f["pegs2"]["adjacency"], f["pegs2"]["positions"],
                          **{"pixel_scale": SCALE, "mu": 0.5, **kw})
    return read_lammps_dump(f["atoms"], f["dump"], **{"mu": 0.5, **kw})


def _edit(path, old, new, count=1):
    text = Path(path).read_text()
    assert old in text, (path, old)
    Path(path).write_text(text.replace(old, new, count))


def _lines(path, fn):
    lines = Path(path).read_text().splitlines()
    Path(path).write_text("\n".join(fn(lines)) + "\n")


def _matrix(path, fn):
    m = np.loadtxt(path, delimiter=",", ndmin=2)
    fn(m)
    np.savetxt(path, m, delimiter=",", fmt="%.17g")


def _row(path, k, col, value):
    def edit(lines):
        parts = lines[k].split(",")
        parts[col] = value
        lines[k] = ",".join(parts)
        return lines
    _lines(path, edit)


CASES = [
    # ---- CSV pair
    ("csv", "missing file", lambda f: f["particles"].unlink(), "does not exist"),
    ("csv", "empty file", lambda f: f["contacts"].write_text(""), "is empty"),
    ("csv", "missing column", lambda f: _edit(f["particles"], "id,x,y,r", "id,x,y,radius"),
     "must name the columns"),
    ("csv", "not a number", lambda f: _row(f["particles"], 2, 1, "abc"), "x (line 3)"),
    ("csv", "NaN position", lambda f: _row(f["particles"], 2, 2, "nan"), "finite"),
    ("csv", "negative radius", lambda f: _row(f["particles"], 2, 3, "-1.0"), "radius must be > 0"),
    ("csv", "duplicate id", lambda f: _row(f["particles"], 2, 0, "0"), "unique"),
    ("csv", "contact id not a particle", lambda f: _row(f["contacts"], 1, 1, "99"),
     "must be the id of a particle"),
    ("csv", "contact with itself", lambda f: _row(f["contacts"], 1, 1, "0"), "itself"),
    ("csv", "pair listed twice", lambda f: _lines(f["contacts"], lambda l: l + [l[1]]),
     "listed once"),
    ("csv", "non-touching disks", lambda f: _row(f["particles"], 4, 1, "5.9"), "do not touch"),
    ("csv", "only fn given", lambda f: _row(f["contacts"], 1, 3, ""), "give both"),
    ("csv", "NaN force", lambda f: _row(f["contacts"], 1, 2, "nan"), "finite"),
    ("csv", "wall without normal", lambda f: (_row(f["contacts"], 4, 4, ""),
                                             _row(f["contacts"], 4, 5, "")), "unit normal"),
    ("csv", "normal reversed", lambda f: _row(f["contacts"], 1, 4, "-1.0"), "reversed"),
    ("csv", "mu not given", "mu", "must be given"),
    # ---- PeGS
    ("pegs", "missing matrix", lambda f: f["pegs"]["tan"].unlink(), "does not exist"),
    ("pegs", "not numbers", lambda f: f["pegs"]["norm"].write_text("a,b\n"), "comma-separated"),
    ("pegs", "matrix size", lambda f: np.savetxt(f["pegs"]["binary"], np.zeros((3, 3)),
                                                 delimiter=","), "must be 4 x 4"),
    ("pegs", "binary not 0/1", lambda f: _matrix(f["pegs"]["binary"],
                                                 lambda m: m.__setitem__((0, 1), 2.0)),
     "must be 0 or 1"),
    ("pegs", "force without contact", lambda f: _matrix(f["pegs"]["norm"],
                                                        lambda m: m.__setitem__((0, 3), 1.0)),
     "does not touch"),
    ("pegs", "normal without tangential", lambda f: _matrix(
        f["pegs"]["tan"], lambda m: m.__setitem__((0, 1), np.nan)), "come together"),
    ("pegs", "id not an integer", lambda f: _row(f["pegs"]["particles"], 1, 0, "2.5"),
     "integers >= 1"),
    ("pegs", "negative radius", lambda f: _row(f["pegs"]["particles"], 1, 3, "-20"),
     "radius must be > 0"),
    ("pegs", "non-touching disks", lambda f: _row(f["pegs"]["particles"], 3, 1, "119"),
     "do not touch"),
    ("pegs", "wall contact without edge flag", lambda f: _row(f["pegs"]["particles"], 0, 4, "0"),
     "needs its edge flag"),
    ("pegs", "no pixel scale", "pixel_scale", "length units per pixel"),
    # ---- PeGS2's own files
    ("pegs2", "missing positions", lambda f: f["pegs2"]["positions"].unlink(), "does not exist"),
    ("pegs2", "adjacency columns", lambda f: _lines(f["pegs2"]["adjacency"], lambda l: [
        x.rsplit(",", 1)[0] for x in l]), "frame, id1, id2, fTan, fNorm"),
    ("pegs2", "positions columns", lambda f: _lines(f["pegs2"]["positions"], lambda l: [
        x.rsplit(",", 1)[0] for x in l]), "frame, id, x, y, r, edge"),
    ("pegs2", "two frames, none chosen", lambda f: _lines(f["pegs2"]["adjacency"], lambda l: l + [
        "2" + l[0][1:]]), "say which"),
    ("pegs2", "frame not in the file", "frame=7", "is not in the file"),
    ("pegs2", "contact id not a particle", lambda f: _row(f["pegs2"]["adjacency"], 0, 2, "99"),
     "must be the id of a particle"),
    ("pegs2", "id not an integer", lambda f: _row(f["pegs2"]["adjacency"], 0, 1, "1.5"),
     "integer >= 1"),
    ("pegs2", "estimate listed twice", lambda f: _lines(f["pegs2"]["adjacency"], lambda l: l + [
        l[0]]), "listed once"),
    ("pegs2", "NaN force", lambda f: _row(f["pegs2"]["adjacency"], 0, 4, "NaN"), "finite"),
    ("pegs2", "negative radius", lambda f: _row(f["pegs2"]["positions"], 1, 4, "-20"),
     "radius must be > 0"),
    ("pegs2", "non-touching disks", lambda f: _row(f["pegs2"]["positions"], 3, 2, "119"),
     "do not touch"),
    ("pegs2", "wall contact without edge flag", lambda f: _row(f["pegs2"]["positions"], 0, 5,
                                                               "0"), "needs its edge flag"),
    ("pegs2", "edge flag not a wall", lambda f: _row(f["pegs2"]["positions"], 0, 5, "3"),
     "must be 0, +-1 or +-2"),
    # ---- LAMMPS dump
    ("lammps", "missing file", lambda f: f["dump"].unlink(), "does not exist"),
    ("lammps", "atom dump given twice", lambda f: f["dump"].write_text(f["atoms"].read_text()),
     "expected 'ITEM: ENTRIES"),
    ("lammps", "missing radius", lambda f: _edit(f["atoms"], " radius ", " rad "), "radius"),
    ("lammps", "wrong column count", lambda f: _edit(f["dump"], "c_cpg[13]\n", "c_cpg[13]\n9 9\n"
                                                    ) or _lines(f["dump"], lambda l: l[:-1]),
     "the same number of numbers"),
    ("lammps", "contact id not an atom", lambda f: _lines(
        f["dump"], lambda l: l[:-1] + ["1 99" + l[-1][3:]]), "must be the id of a particle"),
    ("lammps", "NaN force", lambda f: _lines(f["dump"], lambda l: l[:-1] + [l[-1].rsplit(" ", 1)[0]
                                                                          + " nan"]),
     "finite"),
    ("lammps", "periodic y", lambda f: _edit(f["atoms"], "BOUNDS pp ff pp", "BOUNDS pp pp pp"),
     "y must not be periodic"),
    ("lammps", "different timesteps", lambda f: _edit(f["dump"], "TIMESTEP\n0", "TIMESTEP\n5"),
     "no timestep is in both"),
]


def spoil_and_read(d: Path, fmt: str, spoil):
    """Write the valid files into ``d``, spoil them, read: the InputError it raises."""
    f = write_all(d)
    kw = {}
    if isinstance(spoil, str):          # a keyword: NAME (not given) or NAME=VALUE
        name, _, value = spoil.partition("=")
        kw = {name: float(value) if value else None}
    else:
        spoil(f)
    return read(fmt, f, **kw)


if __name__ == "__main__":           # the table of the issue-41 note
    import tempfile

    from forcespace.errors import InputError
    print("| reader | bad input | message (one line) |\n| --- | --- | --- |")
    for fmt, case, spoil, _ in CASES:
        with tempfile.TemporaryDirectory() as tmp:
            try:
                spoil_and_read(Path(tmp), fmt, spoil)
                msg = "(no error)"
            except InputError as exc:
                msg = str(exc).replace(tmp + "/", "")
        print(f"| {fmt} | {case} | `{msg}` |")
