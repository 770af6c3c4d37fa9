"""Files for the particle viewers granular physicists use: OVITO and ParaView.

:func:`write_viewer_files` writes a packing (positions, radii, rattler flags, walls) and
its force network (one segment per contact with fn, ft, |F|, mobilisation |ft|/(mu fn);
given an :class:`~forcespace.model.ensemble.Ensemble`, each contact's mean and spread
over the samples) into a directory, in formats both programs read natively:

OVITO (``ovito``)
    ``packing.dump``: a LAMMPS text dump (``ITEM: ATOMS id type x y z radius transparency
    rattler body``; the disks' spheres ``DISK_TRANSPARENCY`` see-through, so that OVITO's
    default view shows the bonds inside them) with the box as the simulation cell (x periodic or walled, y between the
    plates), and ``contacts.dump``: a LAMMPS *dump local* file, one row per contact, read
    into OVITO's bonds by the *Load trajectory* modifier (column names below, in
    ``OVITO_CONTACT_PROPERTIES``). Disks are particles 1..n (id = disk index + 1, type 1,
    rattlers type 2); a contact with a wall ends on a wall-contact particle (type 3, radius
    ``WALL_POINT_RADIUS``) at the contact point. x is wrapped into [0, width) for periodic
    boxes and the bonds carry their periodic image. ``load_in_ovito.py`` sets the pipeline
    up (``ovitos load_in_ovito.py`` or OVITO Pro's Python script modifier).
ParaView (``vtk``)
    VTK XML PolyData, ASCII with 17 significant digits (exact round trip):
    ``disks.vtp`` (one vertex per disk at its centre; point data radius, diameter,
    rattler, disk), ``contacts.vtp`` (one line per contact from a's centre to b's centre,
    b at its periodic image; wall contacts end on the wall; cell data as the dump-local
    columns), ``walls.vtp`` (the plates and side walls as lines spanning the box; cell
    data wall code) and ``packing.vtm``, a multiblock file that opens all three. Draw disks
    with a Glyph filter (Sphere or 2D circle, scale array ``diameter``, scale factor 1).

Spheres (3-D packings): the same files with a third coordinate (:func:`write_ovito3`,
:func:`write_vtk3`): the OVITO cell is periodic in x and y and closed by the plates in
z, bonds carry both periodic images and the tangential force vector (``ftx, fty, ftz``
beside its magnitude ``ft``); the ParaView spheres are in ``spheres.vtp`` (a Sphere
glyph scaled by ``diameter`` draws them), the plates are outlined in ``walls.vtp``.

Units: lengths R, forces F0 (the files say so in their headers/field names). Mobilisation
is |ft| / (mu_k fn) with mu_k the contact's Coulomb coefficient (plate_mu on walls); it is
0 where ft = 0 and NaN where a tangential force sits on a contact with mu_k fn = 0.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from ..model.walls import BOTTOM, LEFT, RIGHT, TOP
from .outputs import check_output_dir, writing_run_dir

FORMATS = ("ovito", "vtk")
WALL_POINT_RADIUS = 0.05      # [R] radius of the wall-contact particles in OVITO
DISK, RATTLER, WALL_POINT = 1, 2, 3       # OVITO particle types

# contacts.dump column -> OVITO bond property (Load trajectory modifier's ``columns``)
OVITO_CONTACT_PROPERTIES = {
    "id1": "Particle Identifiers.1", "id2": "Particle Identifiers.2",
    "imx": "Periodic Image.X", "imy": "Periodic Image.Y", "imz": "Periodic Image.Z",
    "contact": "Contact Index", "a": "Body A", "b": "Body B",
    "fn": "Normal Force", "ft": "Tangential Force", "force": "Force Magnitude",
    "mobilisation": "Mobilisation", "mu": "Friction Coefficient", "gap": "Gap",
    "bearing": "Force Bearing",
    "fn_mean": "Mean Normal Force", "ft_mean": "Mean Tangential Force",
    "fn_std": "Normal Force Std", "ft_std": "Tangential Force Std",
    "spread": "Force Spread", "sampled": "Sampled",
    "ftx": "Tangential Force X", "fty": "Tangential Force Y", "ftz": "Tangential Force Z",
}


def contact_table(packing, ensemble=None) -> dict:
    """The per-contact columns a viewer file carries: the packing's
    (:meth:`~forcespace.model.packing.Packing.contact_table`) and, with an ensemble, its
    statistics (:meth:`~forcespace.model.ensemble.Ensemble.contact_columns`)."""
    out = packing.contact_table()
    if ensemble is not None:
        out.update(ensemble.contact_columns(packing))
    return out


def wall_segments(packing):
    """(segments (k, 2, 2) [R], wall codes (k,)): the plates (BOTTOM, TOP) across the box
    width and, without periodic x, the side walls (LEFT at x = 0, RIGHT at x = width)
    between the plates (or the disks' extent where a plate is absent)."""
    p = packing
    ylo = p.y_bottom if np.isfinite(p.y_bottom) else float((p.y - p.r).min())
    yhi = p.y_top if np.isfinite(p.y_top) else float((p.y + p.r).max())
    seg, code = [], []
    for y, c in ((p.y_bottom, BOTTOM), (p.y_top, TOP)):
        if np.isfinite(y):
            seg.append(((0.0, y), (p.width, y)))
            code.append(c)
    if not p.periodic_x:
        seg += [((0.0, ylo), (0.0, yhi)), ((p.width, ylo), (p.width, yhi))]
        code += [LEFT, RIGHT]
    return np.array(seg, float).reshape(-1, 2, 2), np.array(code, np.int64)


def _box_y(p):
    ylo = p.y_bottom if np.isfinite(p.y_bottom) else float((p.y - p.r).min())
    yhi = p.y_top if np.isfinite(p.y_top) else float((p.y + p.r).max())
    return ylo, yhi


DISK_TRANSPARENCY = 0.6     # OVITO's Transparency of the disks' spheres (0 opaque, 1 unseen)


def _bond_ends(p, n: int, shift):
    """What the disks' and the spheres' OVITO tables share: bodies are particles 1..n, the
    q-th wall contact a particle n + q + 1 of its own at its point. ``shift`` (n,) or
    (n, 2): the periodic images the bodies were wrapped by. Returns wall (w,) the wall
    contacts' indices, owner (w,) the body each touches, body (n + w,) the body column
    (a wall particle: its wall's index), id1, id2 (Nc,) the bond ends, img (Nc,) or (Nc, 2)
    the image of id2 relative to id1 after wrapping (0 at walls)."""
    wall = np.flatnonzero((p.a < 0) | (p.b < 0))
    wall_is_a = p.a[wall] < 0
    owner = np.where(wall_is_a, p.b[wall], p.a[wall])
    pid = n + 1 + np.arange(wall.size)
    id1 = np.where(p.a >= 0, p.a + 1, 0)
    id2 = np.where(p.b >= 0, p.b + 1, 0)
    id1[wall[wall_is_a]] = pid[wall_is_a]
    id2[wall[~wall_is_a]] = pid[~wall_is_a]
    img = p.image.astype(np.int64).copy()
    both = (p.a >= 0) & (p.b >= 0)
    img[both] += (shift[p.b[both]] - shift[p.a[both]]).astype(np.int64)
    img[~both] = 0
    body = np.concatenate([np.arange(n), np.where(wall_is_a, p.a[wall], p.b[wall])])
    return wall, owner, body.astype(np.int64), id1, id2, img


def ovito_particles(packing):
    """The particles of ``packing.dump`` and the bond ends of ``contacts.dump``:
    (table dict of (n + w,) columns id, type, x, y, radius, rattler, body; id1 (Nc,),
    id2 (Nc,), image (Nc,) x-image of id2 relative to id1 after wrapping)."""
    p = packing
    n = p.n_disks
    shift = np.floor(p.x / p.width) if p.periodic_x else np.zeros(n)
    x = p.x - shift * p.width
    if p.periodic_x:
        x = np.where(x >= p.width, x - p.width, x)     # round-off at the right edge
    rat = p.rattlers()
    wall, owner, body, id1, id2, img = _bond_ends(p, n, shift)
    w = wall.size
    ids = np.arange(1, n + w + 1)
    typ = np.concatenate([np.where(rat, RATTLER, DISK), np.full(w, WALL_POINT)])
    px = np.concatenate([x, p.point[wall, 0] - shift[owner] * p.width])
    py = np.concatenate([p.y, p.point[wall, 1]])
    table = {"id": ids, "type": typ, "x": px, "y": py,
             "radius": np.concatenate([p.r, np.full(w, WALL_POINT_RADIUS)]),
             "rattler": np.concatenate([rat.astype(np.int64), np.zeros(w, np.int64)]),
             "body": body}
    return table, id1, id2, img


def _fmt_col(v) -> np.ndarray:
    v = np.asarray(v)
    if v.dtype.kind in "iub":
        return v.astype(np.int64).astype(str)
    return np.char.mod("%.17g", v.astype(float))


def _rows(columns) -> str:
    cols = [_fmt_col(c) for c in columns]
    if not cols or cols[0].size == 0:
        return ""
    return "\n".join(" ".join(row) for row in zip(*cols)) + "\n"


def write_ovito(packing, directory, ensemble=None) -> list[Path]:
    """``packing.dump``, ``contacts.dump`` and ``load_in_ovito.py`` in ``directory``
    (module docstring); returns the paths."""
    p = packing
    d = Path(directory)
    table, id1, id2, img = ovito_particles(p)
    ylo, yhi = _box_y(p)
    bounds = ("pp" if p.periodic_x else "ff") + " ff pp"
    box = f"ITEM: BOX BOUNDS {bounds}\n0 {p.width!r}\n{ylo!r} {yhi!r}\n-0.5 0.5\n"
    head = f"ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n{table['id'].size}\n{box}"
    names = ["id", "type", "x", "y", "z", "radius", "transparency", "rattler", "body"]
    table["z"] = np.zeros(table["id"].size)
    # disks half transparent: OVITO draws them as spheres, which hide the force bonds
    # between their centres in its default view (issue 47)
    table["transparency"] = np.where(table["type"] == WALL_POINT, 0.0, DISK_TRANSPARENCY)
    (d / "packing.dump").write_text(head + "ITEM: ATOMS " + " ".join(names) + "\n"
                                    + _rows([table[c] for c in names]))
    ct = contact_table(p, ensemble)
    zero = np.zeros(p.n_contacts, np.int64)
    cols = {"id1": id1, "id2": id2, "imx": img, "imy": zero, "imz": zero}
    cols.update({k: v for k, v in ct.items() if k != "image"})
    head = f"ITEM: TIMESTEP\n0\nITEM: NUMBER OF ENTRIES\n{p.n_contacts}\n{box}"
    (d / "contacts.dump").write_text(head + "ITEM: ENTRIES " + " ".join(cols) + "\n"
                                     + _rows(list(cols.values())))
    mapping = [OVITO_CONTACT_PROPERTIES[c] for c in cols]
    (d / "load_in_ovito.py").write_text(_OVITO_SCRIPT.format(columns=mapping))
    return [d / "packing.dump", d / "contacts.dump", d / "load_in_ovito.py"]


_OVITO_SCRIPT = '''"""Open this forcespace export in OVITO: ovitos load_in_ovito.py (or run it in OVITO Pro).

Particles from packing.dump (type 1 disks, 2 rattlers, 3 wall-contact points), the force
network from contacts.dump as bonds (Load trajectory modifier), bond width by normal force
(0.6 R for the largest). Units: lengths R, forces F0.
"""
from pathlib import Path

import numpy as np
from ovito.io import import_file
from ovito.modifiers import LoadTrajectoryModifier

here = Path(__file__).resolve().parent
pipeline = import_file(str(here / "packing.dump"))
bonds = LoadTrajectoryModifier()
pipeline.modifiers.append(bonds)
bonds.source.load(str(here / "contacts.dump"), columns={columns!r})


def force_width(frame, data):
    f = np.abs(np.asarray(data.particles.bonds["Normal Force"]))
    data.particles_.bonds_.create_property("Width", data=0.6 * f / max(f.max(), 1e-300))


pipeline.modifiers.append(force_width)
pipeline.add_to_scene()
'''


def _vtk_array(name, values, ncomp=1) -> str:
    """One ASCII DataArray (17 significant digits; integers as Int64). ``ncomp`` None
    leaves NumberOfComponents out (cell connectivity and offsets)."""
    v = np.asarray(values)
    if v.dtype.kind in "iub":
        kind, text = "Int64", " ".join(v.astype(np.int64).ravel().astype(str))
    else:
        kind, text = "Float64", " ".join(np.char.mod("%.17g", v.astype(float).ravel()))
    comps = "" if ncomp is None else f' NumberOfComponents="{ncomp}"'
    return f'<DataArray type="{kind}" Name="{name}"{comps} format="ascii">{text}</DataArray>'


def _vtp(points, verts=None, lines=None, point_data=None, cell_data=None) -> str:
    """A VTK XML PolyData document: points (k, 2) [R] (z = 0) or (k, 3), vertices (index arrays) or
    lines (pairs), point and cell data {name: (k,) array}."""
    pts = np.asarray(points, float).reshape(len(points), -1) if len(points) else np.zeros((0, 3))
    if pts.shape[1] == 2:          # disks: in the plane z = 0
        pts = np.column_stack([pts, np.zeros(len(pts))])
    parts = ['<?xml version="1.0"?>',
             '<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" '
             'header_type="UInt64">', "<PolyData>"]
    nv = 0 if verts is None else len(verts)
    nl = 0 if lines is None else len(lines)
    parts.append(f'<Piece NumberOfPoints="{len(pts)}" NumberOfVerts="{nv}" '
                 f'NumberOfLines="{nl}" NumberOfStrips="0" NumberOfPolys="0">')
    for tag, data in (("PointData", point_data), ("CellData", cell_data)):
        parts.append(f"<{tag}>")
        parts += [_vtk_array(k, v) for k, v in (data or {}).items()]
        parts.append(f"</{tag}>")
    parts += ["<Points>", _vtk_array("Points", pts, 3), "</Points>"]
    for tag, cells in (("Verts", verts), ("Lines", lines)):
        if cells is None:
            continue
        cells = np.asarray(cells, np.int64).reshape(len(cells), -1)
        offsets = np.arange(1, len(cells) + 1, dtype=np.int64) * cells.shape[1]
        parts += [f"<{tag}>", _vtk_array("connectivity", cells.ravel(), None),
                  _vtk_array("offsets", offsets, None), f"</{tag}>"]
    parts += ["</Piece>", "</PolyData>", "</VTKFile>"]
    return "\n".join(parts) + "\n"


def write_vtk(packing, directory, ensemble=None) -> list[Path]:
    """``disks.vtp``, ``contacts.vtp``, ``walls.vtp`` and ``packing.vtm`` in
    ``directory`` (module docstring); returns the paths."""
    p = packing
    d = Path(directory)
    rat = p.rattlers().astype(np.int64)
    (d / "disks.vtp").write_text(_vtp(
        np.column_stack([p.x, p.y]), verts=np.arange(p.n_disks)[:, None],
        point_data={"radius": p.r, "diameter": 2 * p.r, "rattler": rat,
                    "disk": np.arange(p.n_disks)}))
    seg, _ = p.branch_segments()
    ct = contact_table(p, ensemble)
    (d / "contacts.vtp").write_text(_vtp(
        seg.reshape(-1, 2), lines=np.arange(2 * p.n_contacts).reshape(-1, 2),
        cell_data=ct))
    wseg, codes = wall_segments(p)
    (d / "walls.vtp").write_text(_vtp(wseg.reshape(-1, 2),
                                      lines=np.arange(2 * len(codes)).reshape(-1, 2),
                                      cell_data={"wall": codes}))
    return multiblock(d, ("disks", "contacts", "walls"))


def multiblock(d: Path, names) -> list[Path]:
    """``packing.vtm`` in ``d``: a multiblock file that opens ``NAME.vtp`` of ``names``;
    returns those files and it."""
    blocks = "\n".join(f'<DataSet index="{i}" name="{name}" file="{name}.vtp"/>'
                       for i, name in enumerate(names))
    (d / "packing.vtm").write_text(
        '<?xml version="1.0"?>\n<VTKFile type="vtkMultiBlockDataSet" version="1.0" '
        f'byte_order="LittleEndian">\n<vtkMultiBlockDataSet>\n{blocks}\n'
        "</vtkMultiBlockDataSet>\n</VTKFile>\n")
    return [d / f"{n}.vtp" for n in names] + [d / "packing.vtm"]


def write_viewer_files(packing, directory, formats=FORMATS, ensemble=None) -> list[Path]:
    """Write ``packing`` (and the per-contact statistics of ``ensemble``, if given) for
    OVITO and/or ParaView into ``directory`` (``formats``: "ovito", "vtk"); returns the
    files written. The directory is created, or replaced while everything in it is
    forcespace's own (:func:`forcespace.io.outputs.check_output_dir`: anything else is
    refused before anything is written); files appear all at once (written to a
    temporary folder, then renamed)."""
    formats = tuple(formats)
    bad = [f for f in formats if f not in FORMATS]
    if bad or not formats:
        raise InputError("viewer export", "format", "must be one or more of "
                         + ", ".join(FORMATS), got=bad or formats)
    spheres = getattr(packing, "dim", 2) == 3
    if spheres and ensemble is not None:
        raise InputError("viewer export", "ensemble", "sphere packings have no ensembles yet "
                         "(the samplers of S run on disks)")
    if ensemble is not None:
        ensemble.contact_columns(packing)          # refuse a foreign ensemble first
    d = check_output_dir(directory)
    with writing_run_dir(d) as tmp:
        files = []
        if "ovito" in formats:
            files += (write_ovito3 if spheres else write_ovito)(packing, tmp, ensemble)
        if "vtk" in formats:
            files += (write_vtk3 if spheres else write_vtk)(packing, tmp, ensemble)
    return [d / f.name for f in files]


# ---- spheres (3-D) ---------------------------------------------------------------

def _sphere_particles(p):
    """(table of (n + w,) columns id, type, x, y, z, radius, rattler, body; id1, id2 (Nc,);
    images (Nc, 2) of id2 relative to id1 after wrapping x and y into the box): spheres
    are particles 1..n, each plate contact a wall-contact particle at its point."""
    n = p.n_spheres
    size = np.asarray(p.lateral, float)
    shift = np.floor(p.pos[:, :2] / size)
    xy = p.pos[:, :2] - shift * size
    xy = np.where(xy >= size, xy - size, xy)          # round-off at the far edges
    wall, owner, body, id1, id2, img = _bond_ends(p, n, shift)
    w = wall.size
    rat = p.rattlers()
    at_wall = np.array(p.point[wall], float)
    at_wall[:, :2] -= shift[owner] * size
    pts = np.vstack([np.column_stack([xy, p.pos[:, 2]]), at_wall])
    table = {"id": np.arange(1, n + w + 1),
             "type": np.concatenate([np.where(rat, RATTLER, DISK), np.full(w, WALL_POINT)]),
             "x": pts[:, 0], "y": pts[:, 1], "z": pts[:, 2],
             "radius": np.concatenate([p.r, np.full(w, WALL_POINT_RADIUS)]),
             "rattler": np.concatenate([rat.astype(np.int64), np.zeros(w, np.int64)]),
             "body": body}
    return table, id1, id2, img


def write_ovito3(packing, directory, ensemble=None) -> list[Path]:
    """The OVITO files of a sphere packing (as :func:`write_ovito`; the cell periodic in
    x and y over the box, z between the plates; bonds with both periodic images and the
    tangential force vector)."""
    p = packing
    d = Path(directory)
    table, id1, id2, img = _sphere_particles(p)
    zlo = p.z_bottom if np.isfinite(p.z_bottom) else float((p.z - p.r).min())
    zhi = p.z_top if np.isfinite(p.z_top) else float((p.z + p.r).max())
    box = (f"ITEM: BOX BOUNDS pp pp ff\n0 {p.lateral[0]!r}\n0 {p.lateral[1]!r}\n"
           f"{zlo!r} {zhi!r}\n")
    head = f"ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n{table['id'].size}\n{box}"
    names = ["id", "type", "x", "y", "z", "radius", "rattler", "body"]
    (d / "packing.dump").write_text(head + "ITEM: ATOMS " + " ".join(names) + "\n"
                                    + _rows([table[c] for c in names]))
    cols = {"id1": id1, "id2": id2, "imx": img[:, 0], "imy": img[:, 1],
            "imz": np.zeros(p.n_contacts, np.int64)}
    cols.update(p.contact_table())
    head = f"ITEM: TIMESTEP\n0\nITEM: NUMBER OF ENTRIES\n{p.n_contacts}\n{box}"
    (d / "contacts.dump").write_text(head + "ITEM: ENTRIES " + " ".join(cols) + "\n"
                                     + _rows(list(cols.values())))
    mapping = [OVITO_CONTACT_PROPERTIES[c] for c in cols]
    (d / "load_in_ovito.py").write_text(_OVITO_SCRIPT.format(columns=mapping))
    return [d / "packing.dump", d / "contacts.dump", d / "load_in_ovito.py"]


def write_vtk3(packing, directory, ensemble=None) -> list[Path]:
    """The ParaView files of a sphere packing (as :func:`write_vtk`): ``spheres.vtp`` holds
    the spheres (draw them with a Sphere glyph scaled by ``diameter``), ``contacts.vtp``
    one line per contact from a's centre to b's (periodic image; plate contacts end on
    the plate), ``walls.vtp`` the outlines of the two plates."""
    p = packing
    d = Path(directory)
    rat = p.rattlers().astype(np.int64)
    (d / "spheres.vtp").write_text(_vtp(
        p.pos, verts=np.arange(p.n_spheres)[:, None],
        point_data={"radius": p.r, "diameter": 2 * p.r, "rattler": rat,
                    "sphere": np.arange(p.n_spheres)}))
    seg, _ = p.branch_segments()
    (d / "contacts.vtp").write_text(_vtp(
        seg.reshape(-1, 3), lines=np.arange(2 * p.n_contacts).reshape(-1, 2),
        cell_data=p.contact_table()))
    lx, ly = p.lateral
    corners = np.array([(0, 0), (lx, 0), (lx, ly), (0, ly)], float)
    pts, codes = [], []
    for z, code in ((p.z_bottom, BOTTOM), (p.z_top, TOP)):
        if np.isfinite(z):
            for c in range(4):
                pts += [(*corners[c], z), (*corners[(c + 1) % 4], z)]
                codes.append(code)
    (d / "walls.vtp").write_text(_vtp(np.array(pts, float).reshape(-1, 3),
                                      lines=np.arange(len(pts)).reshape(-1, 2),
                                      cell_data={"wall": np.array(codes, np.int64)}))
    return multiblock(d, ("spheres", "contacts", "walls"))
