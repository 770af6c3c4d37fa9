"""LIGGGHTS in its own dimension: a sphere packing as a 3-D deck, run, its network back.

LIGGGHTS is three-dimensional by default: no slab, no ``fix enforce2d``. The deck of a
:class:`~forcespace.SpherePacking` (full packing, rattlers left out):

    in.liggghts     input script; its header comment maps every quantity
    data.lmp        atoms: id type diameter density x y z (id = sphere index + 1)
    load_fz.txt     per-atom fixed load along z (gravity) [F0], when the packing has one
    top.stl         the load-controlled top plate: a mesh of small triangles
    deck.json       options and derived quantities (dt, gamma, tolerances), id map
    -- after ``run_deck`` (the 2-D runner, unchanged) --
    screen.txt, atoms.dump, contacts.dump, status.json

Mapping (units identical to forcespace: lengths R, forces F0, density rho; sphere mass
density 4/3 pi r^3, as in the engine): box periodic in x and y over the packing's
lateral extents, z fixed; bottom plate = primitive ``zplane`` granular wall (material
type 2, friction ``plate_mu``); top plate = servo mesh ``mesh/surface/stress/servo``
moving along z only (the 2-D deck's servo with its integral term near convergence, a
mesh of triangles ~r_min wide: a plane of two large triangles trips an assertion with
periodic boundaries); gravity as fixed per-sphere loads (``fix addforce``, ramped in).
Contacts ``hooke/stiffness`` with kn = K <Fn>/R, kt = kt_ratio kn, damping and time step
as in 2-D (:mod:`forcespace_adapters.liggghts`), with the sphere masses.

Convergence test (every ``check_every`` steps): velocities and spins zeroed, one step, so
the residual sqrt(|F|^2 + |T|^2 / r^2) of every sphere is the static imbalance; the
plate's force within tolerance * sqrt(N_top) of its target. The soft network comes
back as a :class:`~forcespace.SpherePacking` (:func:`read_result3`): sphere pairs from
``compute pair/gran/local`` (a = first atom, image by minimum image), plate contacts
from the walls' per-atom forces, fn, ft the soft force on b in the soft geometry.
"""
from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import numpy as np

from forcespace import SpherePacking
from forcespace.errors import InputError
from forcespace.extend import BOTTOM, TOP, check_output_dir, writing_run_dir

from .liggghts import (UNITS, LiggghtsOptions, LiggghtsError, deck_number, material_fixes,
                       precision_floor, read_dump_table, run_files)

DECK_VERSION_3D = 1


def plate_mesh(lx: float, ly: float, z: float, cell: float) -> str:
    """An STL plane z over [0, lx] x [0, ly] of squares about ``cell`` wide, two triangles
    each, normal -z (facing the spheres below)."""
    nx, ny = int(np.ceil(lx / cell)), int(np.ceil(ly / cell))
    xs, ys = np.linspace(0.0, lx, nx + 1), np.linspace(0.0, ly, ny + 1)
    lines = ["solid top"]
    for i in range(nx):
        for j in range(ny):
            x0, x1, y0, y1 = xs[i], xs[i + 1], ys[j], ys[j + 1]
            for tri in (((x0, y0), (x1, y1), (x1, y0)), ((x0, y0), (x0, y1), (x1, y1))):
                lines += ["facet normal 0 0 -1", "outer loop"]
                lines += [f"vertex {deck_number(a)} {deck_number(b)} {deck_number(z)}" for a, b in tri]
                lines += ["endloop", "endfacet"]
    lines.append("endsolid top")
    return "\n".join(lines) + "\n"


def deck_quantities(p: SpherePacking, opt: LiggghtsOptions, exported) -> dict:
    """The derived numbers of a 3-D deck (JSON-ready): masses, stiffness, time step,
    damping, tolerances, the servo's gains, the z shift and the box."""
    live = p.force_bearing()
    scale = float(p.fn[live].mean()) if live.any() else 1.0
    m_ref = 0.5 * float(p.mass[exported].min())
    kn = opt.kn * scale
    t_c = float(np.pi * np.sqrt(m_ref / kn))
    dt = t_c * opt.dt_fraction
    lx, ly = p.lateral
    rmax, rmin = float(p.r.max()), float(p.r.min())
    zs = float(p.z_top)                  # deck z = packing z - zs: the plate near z = 0
    extent = max(lx, ly, float(p.z_top - p.z_bottom) + 2 * rmax)
    floor = precision_floor(opt.kn, extent)
    tol_used = max(opt.tolerance, floor)
    n_top = max(1, int(((p.b == TOP) & ~p.rattlers()[np.maximum(p.a, 0)]).sum()))
    mobility = 1.0 / (n_top * kn * opt.plate_time * t_c)
    skin = 0.25 * rmin
    vmax = 0.2 * skin / dt
    kp = mobility * float(p.top_force) / vmax
    return {"force_scale": scale, "m_ref": m_ref, "kn_abs": kn, "kt": opt.kt_ratio * kn,
            "t_c": t_c, "dt": dt, "gamma": 2.0 * opt.damping_ratio * np.sqrt(kn / m_ref),
            "z_shift": zs, "extent": extent, "precision_floor": floor,
            "tolerance_used": tol_used, "tolerance_abs": tol_used * scale,
            "plate_tolerance_abs": tol_used * scale * np.sqrt(n_top), "n_top": n_top,
            "skin": skin, "vel_max": vmax, "servo_kp": kp,
            "servo_ki": kp / (opt.plate_integral_time * t_c),
            "zlo": float(p.z_bottom) - zs - 2.0 * rmax, "zhi": 4.0 * rmax}


def _script(p: SpherePacking, opt: LiggghtsOptions, q: dict, gravity: bool) -> str:
    """The input script of a 3-D deck (header comment, set-up, ramp, checked chunks,
    output)."""
    f = deck_number
    kn, kt, g = q["kn_abs"], q["kt"], q["gamma"]
    mu, wmu, T = float(p.mu), float(p.plate_mu), float(p.top_force)
    lx, ly = p.lateral
    n_ramp = 20
    ramp_len = max(1, opt.ramp_steps // n_ramp)
    ramp = "\n".join((f"fix_modify top servo/target_val {f(T * (k + 1) / n_ramp)}\n" if k else "")
                     + f"run {ramp_len} start 0 stop {ramp_len * n_ramp}" for k in range(n_ramp))
    n_chunks = max(1, (opt.max_steps - opt.ramp_steps - opt.check_every)
                   // (opt.check_every + 1))
    tol, tol_plate = q["tolerance_abs"], q["plate_tolerance_abs"]
    load = ("variable lfz atomfile load_fz.txt\nvariable az atom v_s*v_lfz\n"
            "fix load all addforce 0.0 0.0 v_az\n") if gravity else ""
    quench = "velocity all set 0.0 0.0 0.0\nset group all omegax 0.0 omegay 0.0 omegaz 0.0\n"
    dump = ("dump dc all local 1 contacts.dump " + " ".join(f"c_cpg[{k}]" for k in range(1, 14))
            + f"\ndump_modify dc format \"%.0f %.0f %.0f{' %.17g' * 10}\"\n"
            "dump da all custom 1 atoms.dump id x y z radius fx fy fz tqx tqy tqz "
            "f_force_wall[1] f_force_wall[2] f_force_wall[3] f_force_wallt[1] "
            "f_force_wallt[2] f_force_wallt[3]\n"
            f"dump_modify da format \"%d{' %.17g' * 16}\"\n")
    return f"""# forcespace -> LIGGGHTS 3.8 deck, 3-D (generated; do not edit by hand)
# packing: {p.scene_name or '?'} seed {p.seed}, {p.n_spheres} spheres, {p.n_contacts} rigid contacts
# units: lj numbers = forcespace units: lengths R, forces F0, density rho (mass rho 4/3 pi r^3)
# box: x, y periodic [0, {lx:g}) x [0, {ly:g}); z fixed; deck z = packing z - {q['z_shift']!r}
# bottom plate: wall/gran primitive zplane (packing z_bottom), friction {wmu:g} (plate_mu)
# top plate: servo mesh top.stl moving along z, target {T:g} F0 ramped in {n_ramp} steps
# contacts: hooke/stiffness kn = K <Fn>/R = {opt.kn:g} x {q['force_scale']:g} = {kn:g} F0/R,
#   kt = {opt.kt_ratio:g} kn; friction mu = {mu:g}; damping gamma = {g:g}; dt = {q['dt']:g}
#   = t_c {opt.dt_fraction:g}, t_c = pi sqrt(m_ref/kn), m_ref = {q['m_ref']:g}
# stop: every {opt.check_every} steps velocities and spins zeroed, one step; converged when
#   every sphere's static sqrt(|F|^2 + |T|^2/r^2) < {tol:g} F0 and the plate force is within
#   {tol_plate:g} F0 of its target; at most {opt.max_steps} steps
atom_style granular
atom_modify map array
boundary p p f
newton off
communicate single vel yes
units lj
read_data data.lmp
neighbor {f(q['skin'])} bin
neigh_modify delay 0

{material_fixes(kn, kt, g, mu, wmu)}

pair_style gran model hooke/stiffness tangential history limitForce on
pair_coeff * *
timestep {f(q['dt'])}

fix wall all wall/gran model hooke/stiffness tangential history primitive type 2 zplane {f(p.z_bottom - q['z_shift'])} store_force yes limitForce on
fix top all mesh/surface/stress/servo file top.stl type 2 com {f(0.5 * lx)} {f(0.5 * ly)} 0.0 ctrlPV force axis 0.0 0.0 -1.0 target_val {f(T / n_ramp)} vel_max {f(q['vel_max'])} kp {f(q['servo_kp'])}
fix wallt all wall/gran model hooke/stiffness tangential history mesh n_meshes 1 meshes top store_force yes limitForce on
fix integr all nve/sphere
compute ftop all reduce sum f_force_wallt[3]
variable ptop equal -c_ftop
variable perr equal abs(c_ftop+{f(T)})

variable s equal ramp(0.0,1.0)
{load}compute rad all property/atom radius tqx tqy tqz
variable res atom sqrt(fx*fx+fy*fy+fz*fz+(c_rad[2]^2+c_rad[3]^2+c_rad[4]^2)/c_rad[1]^2)
compute rmax all reduce max v_res
variable rmax equal c_rmax
compute cpg all pair/gran/local id force force_normal force_tangential delta

thermo_style custom step atoms ke c_rmax v_ptop
thermo_modify norm no lost error
thermo {opt.check_every}

{ramp}
variable s delete
variable s equal 1.0
run {opt.check_every}
variable pion equal 0
variable it loop {n_chunks}
label loop
velocity all zero linear
run {opt.check_every} pre no post no
{quench}run 1 pre no post no
if "${{rmax}} < {f(tol)} && ${{perr}} < {f(tol_plate)}" then "jump SELF converged"
if "${{pion}} == 0 && ${{perr}} < {f(100 * tol_plate)}" then "fix_modify top ctrlParam {f(q['servo_kp'])} {f(q['servo_ki'])} 0.0" "variable pion delete" "variable pion equal 1" "print 'FORCESPACE_PLATE_INTEGRAL on'"
next it
jump SELF loop
print "FORCESPACE_STATUS not_converged"
jump SELF final
label converged
print "FORCESPACE_STATUS converged"
label final
fix_modify top servo/integrate stop
{quench}{dump}run 0
variable zplate equal f_top[9]
print "FORCESPACE_PLATE_Z ${{zplate}}"
print "FORCESPACE_DONE"
"""


def write_deck3(packing: SpherePacking, directory, options: LiggghtsOptions | None = None,
                source="packing", also=None) -> Path:
    """Write the 3-D LIGGGHTS deck of a sphere packing into ``directory`` (replaced
    atomically, :func:`forcespace.io.outputs.writing_run_dir`; module docstring);
    ``also(folder)`` writes further files into the folder before it takes the directory's
    place. Refuses (InputError) a packing without both plates;
    both plates are material 2 with the packing's plate_mu (the engine's one wall rule)."""
    opt = options or LiggghtsOptions()
    opt.validate()
    p = packing
    if not (np.isfinite(p.z_top) and np.isfinite(p.z_bottom)):
        raise InputError(source, "plates", "the 3-D LIGGGHTS deck needs both plates (a "
                         "fixed bottom, a load-controlled top)")
    exported = np.flatnonzero(~p.rattlers())      # rattlers carry no force in S
    q = deck_quantities(p, opt, exported)
    zs = q["z_shift"]
    lx, ly = p.lateral
    gravity = p.gravity > 0
    directory = check_output_dir(directory)
    with writing_run_dir(directory) as tmp:
        rho = np.broadcast_to(np.asarray(p.density, float), p.r.shape)
        xy = np.mod(p.pos[:, :2], np.array([lx, ly]))
        rows = [f"{i + 1} 1 {deck_number(2 * p.r[i])} {deck_number(rho[i])} {deck_number(xy[i, 0])} "
                f"{deck_number(xy[i, 1])} {deck_number(p.pos[i, 2] - zs)}" for i in exported]
        (tmp / "data.lmp").write_text(
            "LAMMPS data file written by forcespace_adapters.liggghts3d\n\n"
            f"{exported.size} atoms\n2 atom types\n\n0.0 {deck_number(lx)} xlo xhi\n"
            f"0.0 {deck_number(ly)} ylo yhi\n{deck_number(q['zlo'])} {deck_number(q['zhi'])} zlo zhi\n\nAtoms\n\n"
            + "\n".join(rows) + "\n")
        if gravity:
            weight = -p.mass * p.gravity
            (tmp / "load_fz.txt").write_text(
                f"# fixed load along z on each sphere (gravity) [F0]\n{exported.size}\n"
                + "".join(f"{i + 1} {deck_number(weight[i])}\n" for i in exported))
        (tmp / "top.stl").write_text(plate_mesh(lx, ly, p.z_top - zs, float(p.r.min())))
        (tmp / "in.liggghts").write_text(_script(p, opt, q, gravity))
        meta = {"deck_version": DECK_VERSION_3D, "dimension": 3, "code": "liggghts",
                "options": asdict(opt), "units": UNITS, "n_spheres": p.n_spheres,
                "exported": exported.tolist(), "lateral": list(p.lateral),
                "rigid_xyzr": np.column_stack([p.pos, p.r]).tolist(),
                "z_bottom": float(p.z_bottom), "mu": float(p.mu), "wall_mu": float(p.plate_mu),
                "top_force": float(p.top_force), "kn": opt.kn,
                "packing": {"scene_name": p.scene_name, "seed": p.seed}, **q}
        (tmp / "deck.json").write_text(json.dumps(meta, indent=1))
        if also is not None:
            also(tmp)
    return directory


def read_result3(directory, rigid: SpherePacking | None = None):
    """The soft network of a finished 3-D run as a :class:`SpherePacking` (the rigid
    packing's box, friction and scene when given) and the run's info dict."""
    d = Path(directory)
    meta, status, screen = run_files(d)
    if meta.get("dimension") != 3:
        raise InputError(d, "deck.json dimension", "must be 3: a 2-D deck is read by "
                         "forcespace_adapters.liggghts.read_result", got=meta.get("dimension"))
    atoms = read_dump_table(d / "atoms.dump", "ATOMS").reshape(-1, 17)
    cont = read_dump_table(d / "contacts.dump", "ENTRIES")
    cont = cont.reshape(-1, 13) if cont.size else np.zeros((0, 13))
    ids = np.asarray(meta["exported"], np.int64)
    if atoms.shape[0] != ids.size:
        raise LiggghtsError(f"{d / 'atoms.dump'}: {atoms.shape[0]} atoms, expected "
                            f"{ids.size} (atoms lost?)")
    xyzr = np.asarray(meta["rigid_xyzr"], float).reshape(-1, 4)
    pos, r = xyzr[:, :3].copy(), xyzr[:, 3].copy()
    k = atoms[:, 0].astype(np.int64) - 1
    zs = float(meta["z_shift"])
    pos[k] = atoms[:, 1:4] + (0.0, 0.0, zs)
    resid = np.zeros(pos.shape[0])
    resid[k] = np.sqrt((atoms[:, 5:8] ** 2).sum(1) + (atoms[:, 8:11] ** 2).sum(1) / r[k] ** 2)
    size = np.asarray(meta["lateral"], float)
    A, B, IMG, F = [], [], [], []
    for row in cont:
        i, j = int(round(row[0])) - 1, int(round(row[1])) - 1
        sep = pos[j] - pos[i]
        image = -np.round(sep[:2] / size).astype(np.int64)
        A.append(i)
        B.append(j)
        IMG.append(image)
        F.append(-row[3:6])                              # force on b = j
    for col, a_side in ((11, False), (14, True)):       # bottom plate, top plate
        for i, f_on in zip(k, atoms[:, col:col + 3]):
            if np.any(f_on != 0.0):              # the wall's force on sphere i
                A.append(int(i) if a_side else BOTTOM)
                B.append(TOP if a_side else int(i))
                IMG.append(np.zeros(2, np.int64))
                F.append(-f_on if a_side else f_on)
    z_plate = [float(ln.split()[1]) for ln in screen if ln.startswith("FORCESPACE_PLATE_Z ")]
    F = np.asarray(F, float).reshape(-1, 3)
    soft = SpherePacking.from_arrays(
        pos, r, np.asarray(A, np.int64), np.asarray(B, np.int64), image=np.asarray(IMG),
        lateral=tuple(size), z_bottom=meta["z_bottom"],
        z_top=(z_plate[-1] + zs) if z_plate else (rigid.z_top if rigid else np.nan),
        top_force=meta["top_force"], mu=meta["mu"], plate_mu=meta["wall_mu"],
        gravity=rigid.gravity if rigid else 0.0,
        density=rigid.density if rigid else 1.0, scene_name=meta["packing"]["scene_name"])
    fn = (F * soft.normal).sum(1)
    soft = soft.with_forces(fn, F - fn[:, None] * soft.normal)
    opt = meta["options"]
    info = {"code": "liggghts", "dimension": 3, "kn": opt["kn"], "kn_unit": "<Fn>/R",
            "kn_abs": meta["kn_abs"], "kt_ratio": opt["kt_ratio"],
            "damping_ratio": opt["damping_ratio"], "dt": meta["dt"], "t_c": meta["t_c"],
            "force_scale": meta["force_scale"], "tolerance": opt["tolerance"],
            "tolerance_used": meta["tolerance_used"], "precision_floor": meta["precision_floor"],
            "tolerance_abs": meta["tolerance_abs"],
            "plate_tolerance_abs": meta["plate_tolerance_abs"], "steps": status["steps"],
            "converged": bool(status["converged"]), "wall_time_s": status["wall_time_s"],
            "max_residual_force": float(resid.max(initial=0.0)), "deck": d.name}
    soft.meta = dict(info)
    soft.seed = meta["packing"]["seed"]
    soft.scene_text = rigid.scene_text if rigid is not None else ""
    return soft, info
