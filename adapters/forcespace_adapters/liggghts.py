"""LIGGGHTS 3.8 adapter: write a deck for a packing, run the binary, read the forces back.

Deck directory layout (written atomically: a temporary folder renamed into place)::

    in.liggghts     input script; its header comment maps every quantity
    data.lmp        atoms: id type diameter density x y z (id = disk index + 1)
    load_fx.txt     per-atom fixed loads (atomfile format) [F0]
    load_fy.txt
    deck.json       options, derived quantities (dt, gamma, tolerances), id map
    -- after `run` --
    screen.txt      unbuffered screen output (-echo screen), log.liggghts
    atoms.dump      final per-atom state (id x y radius fx fy tqz, wall force)
    contacts.dump   final per-contact forces from compute pair/gran/local
    snap_atoms.dump, snap_contacts.dump
                    with ``snapshot_every`` > 0: the same every N steps after the
                    ramp (read with :func:`read_snapshots`)
    status.json     converged flag, steps, wall time, return code

Mapping (units identical to forcespace: lengths R, forces F0, density rho):
2-D (``dimension 2``, periodic z slab 10 R thick, ``fix enforce2d`` last),
periodic x over [0, width), bottom plate = primitive ``yplane`` granular wall
(material type 2) with friction ``plate_mu``; gravity as fixed per-disk loads
(``fix addforce`` with atomfile variables, ramped in linearly).
Top plate (default, ``top="plate"`` problems): a load-controlled plane made of
narrow STL strips (``top.stl``; a two-triangle plane with periodic x trips an
assertion) driven by the servo mesh module ``mesh/surface/stress/servo``
(moves along y only; v = mobility*(target - force on it), target = top_force
raised in 20 steps; frictionless when plate_mu = 0). With a 1 R thick slab
any mesh wall aborts in region_neighbor_list_I.h:165; 10 R works. The plate's
final y is printed as ``FORCESPACE_PLATE_Y`` and gives the top overlaps.
Dead-load mode (``top="loads"``): the top plate's rigid contact forces become
fixed loads through the centres (unstable for real packings: columns buckle). Hookean contacts ``hooke/stiffness`` with kn = K <Fn>/R
(``LiggghtsOptions.kn`` is K, the stiffness in units of the rigid packing's mean normal
force per R, so that a mean contact overlaps by R/K whatever the load; the deck gets
kn_abs = K <Fn> in F0/R), kt = kt_ratio*kn, gamma_n = gamma_t = 2*zeta*sqrt(kn/m_ref) (LIGGGHTS
multiplies by the pair's effective mass, so the damping ratio is zeta for
pairs of effective mass m_ref = m_min/2 and larger for heavier pairs).
dt = t_c * dt_fraction with t_c = pi*sqrt(m_ref/kn).

Convergence test (every ``check_every`` steps): the velocities and spins are zeroed and
one step is run, so the residual sqrt(F^2 + (T/r)^2) of every disk is the *static*
imbalance (contact springs and loads only). Measured with live velocities it would
include the damping forces, which at soft stiffness balance the springs of a slowly
creeping packing: such a run passed a live test with a static residual 17x its
tolerance, or (the plate) never passed. The plate passes when its force is within
tolerance * sqrt(N_top) of its target (N_top rigid plate contacts: the error of a sum of
N_top contact forces each known to the tolerance). Once the plate force is within 100x
that, the servo gains an integral term (time constant ``plate_integral_time`` t_c): a
proportional servo lags a creeping packing by (creep speed)/(mobility), which left the
plate force 1.2e-7 F0 short of its target for 2e6 steps on the mu = 0.1, seed-2 paper
packing (LIGGGHTS 3.8 resets the integral when the gains are set).
LIGGGHTS has no per-atom torque in this build, so boundary loads with a torque
(frictional slice loads, frictional top plate) are refused.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from forcespace.extend import (check_output_dir, mark_run_dir, recording_new_entries,
                               writing_run_dir)

from forcespace.errors import ForcespaceError, InputError, NumericalError
from forcespace.extend import BOTTOM, TOP
from forcespace import Packing

from .problem import SoftProblem, check_options

DECK_VERSION = 2      # 2: kn in <Fn>/R (was F0/R), static convergence test, PI plate
UNITS = ("lengths R, forces F0 in the deck; options: stiffness kn in <Fn>/R, tolerance in "
         "<Fn>, <Fn> = mean normal force of the rigid packing (force-bearing contacts)")
PRECISION_FACTOR = 200.0


def precision_floor(K: float, extent: float) -> float:
    """The smallest static residual per disk [<Fn>] a LIGGGHTS run at stiffness K
    [<Fn>/R] reaches in a box whose coordinates reach ``extent`` [R]:
    ``PRECISION_FACTOR * K * ulp(extent)``.

    Why: positions are doubles, so a disk moves only if v*dt exceeds half an ulp of its
    coordinate; a damped disk whose remaining force imbalance F drives it slower than
    that stays where it is. With gamma = 2 zeta sqrt(kn/m) and dt = t_c/50 this happens
    below F ~ 11 kn ulp(x) per disk, i.e. ~11 K ulp(x) <Fn>; a few contacts per disk and
    the plate add to it. Measured here with the static test (velocities zeroed) on the
    mu = 0.1 seed-2 paper packing: the static residual stalls at 8.2e-7 <Fn> at
    K = 1.27e6 and 7.4e-6 <Fn> at K = 1e7, i.e. 91 and 104 K ulp(44 R) -- while the
    residual with live velocities reads 1e-8..1e-7 <Fn>, because the damping forces of
    the disks' sub-ulp jitter balance the springs. PRECISION_FACTOR = 200 leaves a factor
    of 2 over that."""
    return PRECISION_FACTOR * float(K) * float(np.spacing(float(extent)))


class LiggghtsError(ForcespaceError):
    """LIGGGHTS is missing, failed, or its output cannot be read."""


MAX_STEPS = 2 ** 31 - 1     # LIGGGHTS' run N and loop counts are 32-bit integers


@dataclass
class LiggghtsOptions:
    """Parameters of a LIGGGHTS run.

    Units (one convention for every adapter): stiffness in <Fn>/R and forces in
    <Fn>, <Fn> the mean normal force of the rigid packing (force-bearing contacts).

    kn [<Fn>/R] normal stiffness K (a mean contact overlaps by R/K); kt_ratio = kt/kn;
    damping_ratio zeta (0.5-1 settles fastest); dt_fraction: dt = t_c*dt_fraction (t_c/50
    is safe); tolerance [<Fn>]: stop when the largest per-disk static residual
    sqrt(F^2 + (T/r)^2) is below tolerance (the plate: tolerance*sqrt(N_top)); the
    tolerance actually used is raised to the run's own accuracy floor,
    :func:`precision_floor` (K, L) = 200 K ulp(L) (L the largest deck coordinate; 2e-5
    <Fn> at K = 1e7 in the 42 R paper box), below which a double-precision LIGGGHTS run
    cannot settle (recorded in deck.json and the soft network's meta); ramp_steps: steps over which the
    loads rise linearly from 0; check_every: steps between convergence checks;
    max_steps: give up after this many steps (status converged = False);
    plate_time: relaxation time of the load-controlled top plate in t_c (the
    plate is overdamped: velocity = (force on it - target) / (N_top kn plate_time t_c));
    plate_integral_time: time constant of the servo's integral term in t_c (switched on
    near convergence; see the module docstring);
    snapshot_every: if > 0, after the ramp dump atoms and contacts every this many
    steps (snap_*.dump, see :func:`read_snapshots`); 0 = final state only.
    """

    kn: float = 1e5
    kt_ratio: float = 2.0 / 7.0
    damping_ratio: float = 0.7
    dt_fraction: float = 1.0 / 50.0
    tolerance: float = 1e-6
    plate_time: float = 5.0
    plate_integral_time: float = 1000.0
    ramp_steps: int = 5000
    check_every: int = 1000
    max_steps: int = 2_000_000
    snapshot_every: int = 0

    def validate(self, source="options"):
        steps = f"<= {MAX_STEPS} (LIGGGHTS counts a run's steps and loops in 32 bits)"
        checks = [("kn", 1 <= self.kn <= 1e12, "in [1, 1e12] <Fn>/R (a mean contact "
                   "overlaps by R/K: below 1 by more than a radius; above 1e12 the run's "
                   "precision floor 200 K ulp(L) reaches <Fn> in a box of tens of R)"),
                  ("kt_ratio", 0 <= self.kt_ratio <= 1e6, "in [0, 1e6] (kt/kn)"),
                  ("damping_ratio", 0 <= self.damping_ratio <= 1e3, "in [0, 1e3]"),
                  ("dt_fraction", 0 < self.dt_fraction <= 0.1, "in (0, 0.1] (t_c/10 fails)"),
                  ("tolerance", 0 < self.tolerance < 1, "in (0, 1) <Fn> (a residual of "
                   "<Fn> or more is no static state)"),
                  ("plate_time", 0 < self.plate_time <= 1e6, "in (0, 1e6] t_c"),
                  ("plate_integral_time", 0 < self.plate_integral_time <= 1e9,
                   "in (0, 1e9] t_c"),
                  ("ramp_steps", 1 <= self.ramp_steps <= MAX_STEPS, f">= 1 and {steps}"),
                  ("check_every", 1 <= self.check_every <= MAX_STEPS, f">= 1 and {steps}"),
                  ("max_steps", self.ramp_steps <= self.max_steps <= MAX_STEPS,
                   f">= ramp_steps and {steps}"),
                  ("snapshot_every", 0 <= self.snapshot_every <= MAX_STEPS,
                   f">= 0 and {steps}")]
        check_options(self, checks, source)


def deck_number(v: float) -> str:
    """A deck number, exactly (repr); NumericalError if it is not finite (LIGGGHTS would
    read inf or nan as a number and run with it)."""
    v = float(v)
    if not np.isfinite(v):
        raise NumericalError(f"a LIGGGHTS deck number came out {v} (from the options and "
                             "the packing's scale); nothing was written")
    return repr(v)


def material_fixes(kn: float, kt: float, gamma: float, mu: float, wmu: float) -> str:
    """The deck's material block (2-D and 3-D decks): normal and tangential stiffness and
    damping for every pair of atom types (1 grains, 2 walls), friction mu between grains
    and wmu where a wall takes part."""
    def pairs(name, grains, wall=None):
        wall = grains if wall is None else wall
        return (f"fix m{name[0]} all property/global {name[1]} peratomtypepair 2 "
                f"{deck_number(grains)} {deck_number(wall)} {deck_number(wall)} "
                f"{deck_number(wall)}")
    return "\n".join(pairs(k, *v) for k, v in (
        ((1, "kn"), (kn,)), ((2, "kt"), (kt,)), ((3, "gamman"), (gamma,)),
        ((4, "gammat"), (gamma,)), ((5, "coefficientFriction"), (mu, wmu))))


def write_deck(problem: SoftProblem, directory, options: LiggghtsOptions | None = None,
               source="packing", also=None) -> Path:
    """Write the LIGGGHTS deck for ``problem`` into ``directory`` (replaced atomically,
    :func:`forcespace.io.outputs.writing_run_dir`); ``also(folder)`` writes further files
    into the folder before it takes the directory's place.

    Refuses (InputError) what LIGGGHTS cannot represent exactly: loads with a
    torque, slices (no walls), packings not periodic in x.
    """
    opt = options or LiggghtsOptions()
    opt.validate()
    p = problem.packing
    if not p.periodic_x:
        raise InputError(source, "box.periodic_x", "LIGGGHTS export needs a packing periodic in x")
    if problem.bottom_wall is None:
        raise InputError(source, "slice", "LIGGGHTS export supports the full packing only "
                         "(slice loads are frictional and need per-atom torques, which "
                         "LIGGGHTS 3.8 lacks); use the pymunk adapter for slices")
    if problem.frictional_loads:
        raise InputError(source, "plate_mu / top-plate ft",
                         "the top-plate forces have tangential parts; applying them needs a "
                         "per-atom torque that LIGGGHTS 3.8 lacks (no fix addtorque) — only "
                         "frictionless top-plate loads can be exported exactly; use pymunk")
    n = p.n_disks
    ids = np.flatnonzero(problem.active)       # rattlers are not exported
    m = p.mass[ids]
    m_ref = 0.5 * float(m.min())
    scale = problem.force_scale
    kn = opt.kn * scale                       # [F0/R]
    t_c = np.pi * np.sqrt(m_ref / kn)
    dt = t_c * opt.dt_fraction
    gamma = 2.0 * opt.damping_ratio * np.sqrt(kn / m_ref)
    kt = opt.kt_ratio * kn
    W = float(p.width)
    extent = max(W, float(np.abs(p.y - p.y.max()).max() + 2 * p.r.max()))
    floor = precision_floor(opt.kn, extent)
    tol_used = max(opt.tolerance, floor)
    tol_abs = tol_used * scale
    x = np.mod(p.x, W)
    ybot = float(problem.bottom_wall)
    # deck y = packing y - ys: with a plate, ys = y_top puts the plate near y = 0 so its
    # per-step servo motion (~1e-15 R near convergence at large kn) is not lost to the
    # rounding of y ~ 10 (that floor left the plate force error at ~1e-6 <Fn> at K = 1e7)
    ys = float(problem.top_plate[0]) if problem.top_plate is not None else 0.0
    rmax = float(p.r.max())
    ylo = ybot - 2.0 * rmax
    yhi = float(np.max(p.y + p.r)) + 4.0 * rmax
    skin = 0.25 * float(p.r.min())
    # z slab: with a mesh wall a slab of thickness ~1 R trips LIGGGHTS' mesh neighbour
    # list ("assertion failed (./src/region_neighbor_list_I.h:165)"); 10 R is fine
    zhalf = max(5.0, 4.0 * rmax)
    mu, wmu = float(problem.mu), float(problem.wall_mu)
    # after the ramp: one chunk of check_every steps, then chunks of check_every + 1
    n_chunks = max(1, (opt.max_steps - opt.ramp_steps - opt.check_every)
                   // (opt.check_every + 1))
    n_ramp = 20 if problem.top_plate is not None else 1
    ramp_len = max(1, opt.ramp_steps // n_ramp)
    if n_ramp == 1:
        ramp_cmds = f"run {opt.ramp_steps}"
    else:   # servo target raised in n_ramp steps while the body loads ramp continuously
        ramp_cmds = "\n".join(
            (f"fix_modify top servo/target_val {deck_number(problem.top_plate[1] * (k + 1) / n_ramp)}\n"
             if k else "") + f"run {ramp_len} start 0 stop {ramp_len * n_ramp}"
            for k in range(n_ramp))
    plate = problem.top_plate
    if plate is not None:
        y_top, T, pmu = plate
        if pmu != wmu:
            raise InputError(source, "plate_mu", "bottom and top plate friction must agree")
        n_top = max(1, int(((p.b == TOP) & problem.internal).sum()))
        mobility = 1.0 / (n_top * kn * opt.plate_time * t_c)
        tol_plate = tol_abs * np.sqrt(n_top)
        vmax = 0.2 * skin / dt
        # the servo sets v = vel_max*kp*(target - F)/target along its axis (P control,
        # LIGGGHTS 3.8 fix_mesh_surface_stress_servo.cpp): kp so that v = mobility*(target - F)
        kp = mobility * T / vmax
        ki = kp / (opt.plate_integral_time * t_c)
        yhi = max(yhi, y_top + 4.0 * rmax)
        nstrip = int(np.ceil(W / float(p.r.min())))
        xs = np.linspace(0.0, W, nstrip + 1)
        top_lines = ["solid top"]
        for k in range(nstrip):
            x0_, x1_ = xs[k], xs[k + 1]
            for tri in (((x0_, -0.4), (x1_, -0.4), (x1_, 0.4)), ((x0_, -0.4), (x1_, 0.4), (x0_, 0.4))):
                top_lines += ["facet normal 0 -1 0", "outer loop"]
                top_lines += [f"vertex {deck_number(xx)} {deck_number(y_top - ys)} {deck_number(zz)}" for xx, zz in tri]
                top_lines += ["endloop", "endfacet"]
        top_lines.append("endsolid top")
        plate_cmds = f"""
# top plate: frictionless STL plane y = {y_top:g} in {nstrip} strips (top.stl), load-controlled
#   by the servo mesh module (mesh/surface/stress/servo): it moves along y only, with velocity
#   v = mobility*(target - force on it) along -y (P controller, mobility = {mobility:g}, kp = {kp:g}), capped at vel_max;
#   the target ramps with the loads: fix_modify servo/target_val between ramp chunks
fix top all mesh/surface/stress/servo file top.stl type 2 com {deck_number(0.5 * W)} {deck_number(y_top - ys)} 0.0 ctrlPV force axis 0.0 -1.0 0.0 target_val {deck_number(T / n_ramp)} vel_max {deck_number(vmax)} kp {deck_number(kp)}
fix wallt all wall/gran model hooke/stiffness tangential history mesh n_meshes 1 meshes top store_force yes limitForce on
compute ftop all reduce sum f_force_wallt[2]
variable ptop equal -c_ftop
variable perr equal abs(c_ftop+{deck_number(T)})
"""
        cond = f'"${{rmax}} < {deck_number(tol_abs)} && ${{perr}} < {deck_number(tol_plate)}"'
        integral_on = (f'if "${{pion}} == 0 && ${{perr}} < {deck_number(100 * tol_plate)}" then '
                       f'"fix_modify top ctrlParam {deck_number(kp)} {deck_number(ki)} 0.0" '
                       '"variable pion delete" "variable pion equal 1" '
                       '"print \'FORCESPACE_PLATE_INTEGRAL on\'"\n')
        thermo_extra = " v_ptop"
        wall_cols = " f_force_wallt[1] f_force_wallt[2]"
        stop_plate = "fix_modify top servo/integrate stop\n"
        plate_print = 'variable yplate equal f_top[8]\nprint "FORCESPACE_PLATE_Y ${yplate}"\n'
    else:
        plate_cmds, thermo_extra, wall_cols, stop_plate, plate_print = "", "", "", "", ""
        integral_on, tol_plate, n_top, ki = "", None, 0, None
        cond = f'"${{rmax}} < {deck_number(tol_abs)}"'

    def dumps(tag, every, prefix):
        """Dump commands: contacts (local) and atoms (custom) every ``every`` steps."""
        return (f"dump {tag}c all local {every} {prefix}contacts.dump "
                + " ".join(f"c_cpg[{k}]" for k in range(1, 14)) + "\n"
                f"dump_modify {tag}c format \"%.0f %.0f %.0f{' %.17g' * 10}\"\n"
                f"dump {tag}a all custom {every} {prefix}atoms.dump id x y radius fx fy tqz "
                f"f_force_wall[1] f_force_wall[2]{wall_cols}\n"
                f"dump_modify {tag}a format \"%d{' %.17g' * (8 + (2 if plate else 0))}\"")

    snap_on = snap_off = ""
    if opt.snapshot_every:     # after the ramp, inside the check loop's runs
        snap_on = dumps("s", opt.snapshot_every, "snap_") + "\n"
        snap_off = "undump sc\nundump sa\n"

    directory = check_output_dir(directory)
    with writing_run_dir(directory) as tmp:    # replaces it only if all in it is ours
        with open(tmp / "data.lmp", "w") as f:
            f.write("LAMMPS data file written by forcespace_adapters.liggghts\n\n")
            f.write(f"{ids.size} atoms\n2 atom types\n\n")
            f.write(f"0.0 {deck_number(W)} xlo xhi\n{deck_number(ylo - ys)} {deck_number(yhi - ys)} ylo yhi\n"
                    f"{deck_number(-zhalf)} {deck_number(zhalf)} zlo zhi\n\nAtoms\n\n")
            for i in ids:
                f.write(f"{i + 1} 1 {deck_number(2 * p.r[i])} {deck_number(np.broadcast_to(p.density, p.r.shape)[i])} "
                        f"{deck_number(x[i])} {deck_number(p.y[i] - ys)} 0.0\n")
        for comp, name in ((0, "load_fx.txt"), (1, "load_fy.txt")):
            with open(tmp / name, "w") as f:
                f.write(f"# fixed load component {'xy'[comp]} on each disk [F0]\n{ids.size}\n")
                for i in ids:
                    f.write(f"{i + 1} {deck_number(problem.load[i, comp])}\n")
        if plate is not None:
            top_doc = (f"# top plate: load-controlled frictionless servo mesh (see below), target force "
                       f"{plate[1]:g} F0 ramped in 20 steps;\n#   gravity = fixed per-disk loads in "
                       f"load_fx.txt / load_fy.txt (fix addforce), ramped over {opt.ramp_steps} steps\n")
        else:
            top_doc = ("# top plate: removed; its rigid contact forces (frictionless, through the centres) "
                       "and gravity\n#   are fixed per-disk loads in load_fx.txt / load_fy.txt, applied "
                       f"by fix addforce, ramped\n#   linearly from 0 over {opt.ramp_steps} steps\n")
        header = f"""# forcespace -> LIGGGHTS 3.8 deck (generated; do not edit by hand)
# packing: {p.scene_name or '?'} seed {p.seed}, {n} disks, {p.n_contacts} rigid contacts;
#   {ids.size} exported ({n - ids.size} rattlers left out: they carry no force in S)
# units: lj numbers = forcespace units: lengths R, forces F0, density rho (mass = rho*pi*r^2 in 2-D)
# atoms: id = forcespace disk index + 1, type 1; the bottom plate is material type 2
# box: x periodic [0, {W:g}) (= packing width), y fixed [{ylo - ys:g}, {yhi - ys:g}], z slab +-{zhalf:g}
# y shift: deck y = packing y - {ys!r} (plate near y = 0, see liggghts.py)
# bottom plate: fix wall/gran primitive yplane {ybot:g} (packing y_bottom), friction {wmu:g} (plate_mu)
{top_doc}# contacts: hooke/stiffness, kn = K <Fn>/R = {opt.kn:g} x {scale:g} = {kn:g} F0/R,
#   kt = {opt.kt_ratio:g}*kn = {kt:g},
#   friction mu = {mu:g} (disk-disk), tangential history (Coulomb-capped spring)
# damping: gamma_n = gamma_t = {gamma:g} (times the pair's effective mass, damping ratio
#   {opt.damping_ratio:g} for effective mass m_ref = m_min/2 = {m_ref:g})
# time step: dt = t_c*{opt.dt_fraction:g} = {dt:g}, t_c = pi*sqrt(m_ref/kn) = {t_c:g}
# stop: every {opt.check_every} steps the velocities and spins are zeroed and one step is run;
#   converged when max over disks of that static sqrt(fx^2+fy^2+(tqz/r)^2)
#   < {tol_abs:g} F0 (= {tol_used:g} <Fn>, <Fn> = {scale:g} F0: the tolerance {opt.tolerance:g},
#   raised to the precision floor {floor:.2g} of K = {opt.kn:g} if larger) and the plate force is
#   within {tol_plate if tol_plate is not None else 0:g} F0 of its target; at most {opt.max_steps} steps
# output: velocities and spins zeroed, run 0, then atoms.dump (id x y radius fx fy tqz wall fx fy)
#   and contacts.dump (compute pair/gran/local: id1 id2 periodic-flag, force on atom id1 (3),
#   normal part (3), tangential part (3), overlap delta)
"""
        script = header + f"""
atom_style granular
atom_modify map array
boundary p f p
newton off
communicate single vel yes
units lj
dimension 2
read_data data.lmp
neighbor {deck_number(skin)} bin
neigh_modify delay 0

{material_fixes(kn, kt, gamma, mu, wmu)}

pair_style gran model hooke/stiffness tangential history limitForce on
pair_coeff * *
timestep {deck_number(dt)}

fix wall all wall/gran model hooke/stiffness tangential history primitive type 2 yplane {deck_number(ybot - ys)} store_force yes limitForce on
fix integr all nve/sphere

variable s equal ramp(0.0,1.0){plate_cmds}
variable lfx atomfile load_fx.txt
variable lfy atomfile load_fy.txt
variable ax atom v_s*v_lfx
variable ay atom v_s*v_lfy
fix load all addforce v_ax v_ay 0.0

compute rad all property/atom radius tqz
variable res atom sqrt(fx*fx+fy*fy+(c_rad[2]/c_rad[1])^2)
compute rmax all reduce max v_res
variable rmax equal c_rmax
compute cpg all pair/gran/local id force force_normal force_tangential delta
fix twod all enforce2d

thermo_style custom step atoms ke c_rmax{thermo_extra}
thermo_modify norm no lost error
thermo {opt.check_every}

{ramp_cmds}
variable s delete
variable s equal 1.0
{snap_on}run {opt.check_every}
# later chunks without re-setup ("pre no"): a full setup resets the servo's reference
# position; the free drift along x (frictionless plates, periodic x) is removed before each
# chunk. The check: velocities and spins zeroed, one step, so the residual is static (no
# damping force in it); near convergence the servo gets its integral term (once).
variable pion equal 0
variable it loop {n_chunks}
label loop
velocity all zero linear
run {opt.check_every} pre no post no
velocity all set 0.0 0.0 0.0
set group all omegaz 0.0
run 1 pre no post no
if {cond} then "jump SELF converged"
{integral_on}next it
jump SELF loop
print "FORCESPACE_STATUS not_converged"
jump SELF final
label converged
print "FORCESPACE_STATUS converged"
label final
{snap_off}
{stop_plate}velocity all set 0.0 0.0 0.0
set group all omegaz 0.0
{dumps("d", 1, "")}
run 0
{plate_print}print "FORCESPACE_DONE"
"""
        (tmp / "in.liggghts").write_text(script)
        if plate is not None:
            (tmp / "top.stl").write_text("\n".join(top_lines) + "\n")
        meta = {"deck_version": DECK_VERSION, "code": "liggghts", "options": asdict(opt),
                "n_disks": n, "exported": ids.tolist(), "width": W,
                "rigid_xyr": np.column_stack([p.x, p.y, p.r]).tolist(), "y_bottom": ybot, "y_shift": ys, "m_ref": m_ref, "t_c": t_c,
                "dt": dt, "gamma": gamma, "kt": kt, "force_scale": scale,
                "units": UNITS, "kn": opt.kn, "kn_abs": kn,
                "tolerance_used": tol_used, "precision_floor": floor, "extent": extent,
                "tolerance_abs": tol_abs, "plate_tolerance_abs": tol_plate, "n_top": n_top,
                "servo_ki": ki, "mu": mu, "wall_mu": wmu,
                "load": problem.load.tolist(),
                "top_load": None if problem.top_load is None else problem.top_load.tolist(),
                "top_plate": plate,
                "packing": {"scene_name": p.scene_name, "seed": p.seed,
                            "fingerprint": p.fingerprint}}
        (tmp / "deck.json").write_text(json.dumps(meta, indent=1))
        if also is not None:
            also(tmp)
    return directory


def find_binary(binary: str | None = None) -> str:
    """Path of the LIGGGHTS executable (``$FORCESPACE_LIGGGHTS`` or ``liggghts`` on PATH)."""
    name = binary or os.environ.get("FORCESPACE_LIGGGHTS", "liggghts")
    path = shutil.which(name)
    if path is None:
        raise LiggghtsError(f"LIGGGHTS binary '{name}' not found; install it with "
                            f"`sudo apt-get install liggghts` or pass its path (--binary)")
    return path


RUN_FILES = ("screen.txt", "log.liggghts", "atoms.dump", "contacts.dump", "status.json",
             "snap_atoms.dump", "snap_contacts.dump")    # what a run writes into its deck


def run_deck(directory, binary: str | None = None, timeout: float | None = None,
             show_progress: bool = False) -> dict:
    """Run LIGGGHTS on a deck directory; write and return ``status.json``.

    Output is unbuffered (``stdbuf -o0``) with ``-echo screen`` into ``screen.txt``; on
    failure the ERROR lines are raised as LiggghtsError. ``show_progress``: a bar of
    LIGGGHTS' steps against the deck's step cap, read from its thermo output, with the
    residual beside its tolerance (the run usually stops at convergence long before the
    cap, so the bar's ETA is an upper bound).
    """
    d = Path(directory)
    if not (d / "in.liggghts").is_file():
        raise InputError(d, "in.liggghts", "missing; write the deck first (forcespace export liggghts)")
    exe = find_binary(binary)
    for name in ("atoms.dump", "contacts.dump", "status.json"):
        (d / name).unlink(missing_ok=True)
    cmd = [exe, "-in", "in.liggghts", "-echo", "screen", "-log", "log.liggghts"]
    if shutil.which("stdbuf"):
        cmd = ["stdbuf", "-o0", "-e0"] + cmd
    t0 = time.perf_counter()
    mark_run_dir(d, RUN_FILES)            # the run's files are forcespace's own, also
    with recording_new_entries(d):        # after a kill; and whatever else it writes
        rc = _run_streaming(cmd, d, timeout, _deck_progress(d, show_progress))
    wall = time.perf_counter() - t0
    text = (d / "screen.txt").read_text(errors="replace")
    errors = [ln.strip() for ln in text.splitlines() if "ERROR" in ln]
    if rc != 0 or errors or "FORCESPACE_DONE" not in text:
        msg = "; ".join(errors[:3]) or (text.strip().splitlines() or ["(no output)"])[-1]
        raise LiggghtsError(f"{d}: LIGGGHTS failed (exit code {rc}): {msg} "
                            f"(full log: {d / 'screen.txt'})")
    loops = _loop_seconds(text.splitlines())
    steps = int(loops[-1, 0]) if loops.size else 0
    status = {"converged": "FORCESPACE_STATUS converged" in text, "steps": steps,
              "wall_time_s": wall, "return_code": rc, "binary": exe}
    tmp = d / ".status.json.tmp"
    tmp.write_text(json.dumps(status, indent=1))
    os.replace(tmp, d / "status.json")
    return status


def _run_streaming(cmd, d: Path, timeout, on_line) -> int:
    """Run ``cmd`` in ``d``, its output into ``d/screen.txt`` line by line, each line also
    to ``on_line``; LiggghtsError after ``timeout`` seconds (its process group killed).

    The run is its own session, and output is read with a deadline: a killed
    LIGGGHTS can leave OpenMPI's singleton daemon (orted) holding the pipe open, and
    a plain read then never ends (seen under load with a 0.2 s limit)."""
    deadline = None if timeout is None else time.monotonic() + timeout
    killed = False
    with open(d / "screen.txt", "w") as out, subprocess.Popen(
            cmd, cwd=d, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL, start_new_session=True) as proc:
        try:
            for line in _lines_until(proc, deadline):
                out.write(line)
                on_line(line)
        except TimeoutError:
            killed = True
            _kill_session(proc)
        finally:
            on_line(None)
        rc = proc.wait()
    if killed:
        raise LiggghtsError(f"{d}: LIGGGHTS exceeded the time limit of {timeout} s "
                            f"(see {d / 'screen.txt'})")
    return rc


def _lines_until(proc, deadline):
    """The text lines of ``proc``'s stdout until end of file (TimeoutError once
    ``deadline``, a time.monotonic() value or None, passes first)."""
    import select

    fd, pending = proc.stdout.fileno(), b""
    while True:
        wait = None if deadline is None else deadline - time.monotonic()
        if wait is not None and wait <= 0:
            raise TimeoutError
        if not select.select([fd], [], [], wait)[0]:
            continue
        chunk = os.read(fd, 1 << 16)
        if not chunk:
            break
        *lines, pending = (pending + chunk).split(b"\n")
        for raw in lines:
            yield raw.decode(errors="replace") + "\n"
    if pending:
        yield pending.decode(errors="replace")


def _kill_session(proc) -> None:
    """SIGKILL every process of ``proc``'s session (LIGGGHTS and what MPI started)."""
    import signal

    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        proc.kill()


def _deck_progress(d: Path, show: bool):
    """A line handler that moves a progress bar along the thermo lines (step, atoms, ke,
    max residual, ...) of a deck's run; ``None`` closes the bar."""
    from forcespace.extend import progress

    try:
        meta = json.loads((d / "deck.json").read_text())
    except (OSError, ValueError):
        meta = {}
    cap = meta.get("options", {}).get("max_steps")
    tol, scale = meta.get("tolerance_abs"), meta.get("force_scale") or 1.0
    bar = progress(total=cap, desc="LIGGGHTS steps (ETA: to the step cap)", unit="step",
                   disable=not show)

    def on_line(line):
        if line is None:
            bar.close()
            return
        parts = line.split()
        if len(parts) >= 4 and parts[0].isdigit():
            try:
                step, res = int(parts[0]), float(parts[3])
            except ValueError:
                return
            bar.update(max(step - bar.n, 0))
            if tol:
                # the live residual of the disks (damping in it); convergence is
                # decided on the quenched one and the plate's load as well
                bar.set_postfix_str(f"live disk residual {res / scale:.1e} / tolerance "
                                    f"{tol / scale:.1e} <Fn>", refresh=False)
    return on_line


def _read_dump_blocks(path, section: str) -> dict:
    """{timestep: table} of every block of a dump file (a later block of the same step wins)."""
    lines = Path(path).read_text().splitlines()
    out = {}
    for i, ln in enumerate(lines):
        if ln.startswith(f"ITEM: {section}"):
            t = next(j for j in range(i - 1, -1, -1) if lines[j].startswith("ITEM: TIMESTEP"))
            end = next((j for j in range(i + 1, len(lines)) if lines[j].startswith("ITEM")),
                       len(lines))
            rows = [r.split() for r in lines[i + 1:end] if r.strip()]
            out[int(lines[t + 1])] = (np.array(rows, dtype=float).reshape(len(rows), -1)
                                      if rows else np.zeros((0, 1)))
    return out


def read_dump_table(path, section: str) -> np.ndarray:
    blocks = _read_dump_blocks(path, section)
    if not blocks:
        raise LiggghtsError(f"{path}: no 'ITEM: {section}' block; the run did not finish")
    return blocks[max(blocks)]


def _loop_seconds(screen_lines) -> np.ndarray:
    """(k, 2) cumulative (steps, loop seconds) after each ``run`` of a LIGGGHTS log."""
    rows, steps, secs = [], 0, 0.0
    for ln in screen_lines:
        if ln.startswith("Loop time of"):
            parts = ln.split()
            steps += int(parts[parts.index("for") + 1])
            secs += float(parts[3])
            rows.append((steps, secs))
    return np.array(rows, dtype=float).reshape(-1, 2)


def read_snapshots(directory, rigid: Packing | None = None):
    """The intermediate states of a run with ``snapshot_every`` > 0.

    Returns a list of (step, seconds, soft Packing, info), one per dump step.
    ``seconds`` [s] is the wall time the LIGGGHTS process needed to get there:
    its start-up, set-up and final output (process wall time minus the summed
    ``Loop time`` of its runs, all counted before the first step) plus the loop
    time of every run up to the end of the one containing the step. The TOP contacts' gaps assume the plate touches the disk (its
    position is only printed at the end); the forces are those of the dump step
    (damping terms included, velocities are not zeroed in between; with mu = 0 the
    disk-disk tangential forces are 0, see :func:`_soft_network`).
    """
    d = Path(directory)
    meta, status, screen = run_files(d)
    atoms = _read_dump_blocks(d / "snap_atoms.dump", "ATOMS")
    cont = _read_dump_blocks(d / "snap_contacts.dump", "ENTRIES")
    loops = _loop_seconds(screen)
    start = status["wall_time_s"] - (loops[-1, 1] if loops.size else 0.0)
    out = []
    for step in sorted(set(atoms) & set(cont)):
        k = min(int(np.searchsorted(loops[:, 0], step)), loops.shape[0] - 1)
        last = status["converged"] and step == status["steps"]
        soft, info = _soft_network(d, meta, dict(status, steps=step, converged=last),
                                   atoms[step], cont[step], float("nan"), rigid)
        out.append((step, start + float(loops[k, 1]), soft, info))
    return out


def run_files(d: Path):
    """(deck.json, status.json, screen lines) of a finished run directory."""
    try:
        meta = json.loads((d / "deck.json").read_text())
        status = json.loads((d / "status.json").read_text())
    except FileNotFoundError as exc:
        raise InputError(d, Path(exc.filename).name, "missing; run the deck first "
                         "(forcespace run liggghts DIR)") from None
    return meta, status, (d / "screen.txt").read_text(errors="replace").splitlines()


def read_result(directory, rigid: Packing | None = None):
    """Read a finished run back as a soft-network :class:`Packing` (same schema).

    Contacts: disk pairs from ``contacts.dump`` (a = first atom, b = second,
    image from the minimal-image separation), bottom-wall contacts from the
    per-atom wall force (a = BOTTOM), and TOP contacts (b = TOP): with a servo
    plate the per-atom plate forces (gap from the plate's final y, printed as
    FORCESPACE_PLATE_Y and shifted back by deck.json ``y_shift``); in dead-load
    mode the fixed top loads (fn = applied load, so the plate balance holds). fn, ft are the
    soft force on b in the soft geometry (normal from the final centres).
    ``rigid`` supplies box, friction and scene fields; without it they come
    from deck.json. Returns (soft_packing, run_info dict).
    """
    d = Path(directory)
    meta, status, screen = run_files(d)
    y_plate = float("nan")
    if meta.get("top_plate") is not None:
        vals = [ln.split()[1] for ln in screen if ln.startswith("FORCESPACE_PLATE_Y ")]
        if vals:        # decks older than this line: plate position unknown, gap 0
            y_plate = float(vals[-1]) + float(meta.get("y_shift", 0.0))
    return _soft_network(d, meta, status, read_dump_table(d / "atoms.dump", "ATOMS"),
                         read_dump_table(d / "contacts.dump", "ENTRIES"), y_plate, rigid)


def _soft_network(d: Path, meta, status, atoms, cont, y_plate, rigid):
    """(soft Packing, run info) of one dumped state; see :func:`read_result`."""
    n = meta["n_disks"]
    ids = np.asarray(meta["exported"], dtype=np.int64)
    if atoms.shape[0] != ids.size:
        raise LiggghtsError(f"{d / 'atoms.dump'}: {atoms.shape[0]} atoms, expected {ids.size} "
                            f"(atoms lost?)")
    xyr = np.asarray(meta["rigid_xyr"], float).reshape(n, 3)
    x, y, r = xyr[:, 0].copy(), xyr[:, 1].copy(), xyr[:, 2].copy()
    resid = np.zeros((n, 2))
    wall = np.zeros((n, 2))
    k = atoms[:, 0].astype(np.int64) - 1
    ys = float(meta.get("y_shift", 0.0))
    x[k], y[k], r[k] = atoms[:, 1], atoms[:, 2] + ys, atoms[:, 3]
    resid[k] = atoms[:, 4:6]
    wall[k] = atoms[:, 7:9]
    walltop = np.zeros((n, 2))
    if meta.get("top_plate") is not None:
        walltop[k] = atoms[:, 9:11]
    W = float(meta["width"])
    A, B, IMG, FN, FT = [], [], [], [], []
    mu_pair = float(meta["mu"]) > 0.0
    for row in cont.reshape(-1, 13) if cont.size else []:
        i, j = int(round(row[0])) - 1, int(round(row[1])) - 1
        f_on_i = row[3:5]
        dx = x[j] - x[i]
        image = -int(np.round(dx / W))
        dvec = np.array([dx + image * W, y[j] - y[i]])
        nv = dvec / np.linalg.norm(dvec)
        F = -f_on_i                      # force on b = j
        A.append(i); B.append(j); IMG.append(image)
        # mu = 0: the dynamics caps the tangential force at 0 (atoms' tqz stays exactly 0),
        # but compute pair/gran/local re-evaluates it with the free spins of the disks and
        # reports their tangential damping (~1e-2 <Fn> in snapshots of a 200-disk run)
        FN.append(F @ nv); FT.append(F @ np.array([-nv[1], nv[0]]) if mu_pair else 0.0)
    ybot = float(meta["y_bottom"])
    for i in np.flatnonzero(wall[:, 1] != 0.0):
        A.append(BOTTOM); B.append(int(i)); IMG.append(0)
        FN.append(wall[i, 1]); FT.append(-wall[i, 0])   # t = (-1, 0) for n = (0, 1)
    top_force = 0.0
    for i in np.flatnonzero(walltop[:, 1] != 0.0):        # plate pushes disk i down
        A.append(int(i)); B.append(TOP); IMG.append(0)
        FN.append(-walltop[i, 1]); FT.append(walltop[i, 0])   # force on TOP = -wall force
        top_force += -walltop[i, 1]
    top_load = np.asarray(meta["top_load"] or np.zeros(n))
    for i in np.flatnonzero(top_load != 0.0):
        A.append(int(i)); B.append(TOP); IMG.append(0)
        FN.append(top_load[i]); FT.append(0.0)
        top_force += top_load[i]
    opt = meta["options"]
    v1 = meta.get("deck_version", 1) < 2          # version 1 decks: kn in F0/R
    K = opt["kn"] / meta["force_scale"] if v1 else opt["kn"]
    info = {"code": "liggghts", "kn": K, "kn_unit": "<Fn>/R",
            "kn_abs": opt["kn"] if v1 else meta["kn_abs"], "kt_ratio": opt["kt_ratio"],
            "damping_ratio": opt["damping_ratio"], "dt": meta["dt"], "t_c": meta["t_c"],
            "force_scale": meta["force_scale"], "tolerance": opt["tolerance"],
            "tolerance_used": meta.get("tolerance_used", opt["tolerance"]),
            "precision_floor": meta.get("precision_floor", 0.0),
            "tolerance_abs": meta["tolerance_abs"],
            "plate_tolerance_abs": meta.get("plate_tolerance_abs") or meta["tolerance_abs"],
            "steps": status["steps"], "converged": bool(status["converged"]),
            "wall_time_s": status["wall_time_s"],
            "max_residual_force": float(np.linalg.norm(resid, axis=1).max(initial=0.0)),
            "deck": d.name}
    made_from = meta["packing"].get("fingerprint") or (rigid.fingerprint if rigid is not None
                                                       else None)
    if made_from:
        info["packing_fingerprint"] = made_from
    kw = dict(width=W, periodic_x=True, y_bottom=ybot, y_top=float("nan"),
              top_force=top_force, gravity=0.0, density=1.0, mu=meta["mu"],
              plate_mu=meta["wall_mu"], scene_name=meta["packing"]["scene_name"])
    scene_text = ""
    if rigid is not None:
        kw.update(gravity=rigid.gravity, density=rigid.density,
                  y_top=y_plate if np.isfinite(y_plate) else rigid.y_top,
                  top_force=rigid.top_force)
        scene_text = rigid.scene_text
    # geometry (normals, contact points, gaps) from the soft centres and plate positions
    soft = Packing.from_arrays(x, y, r, np.array(A, np.int64), np.array(B, np.int64),
                               np.array(FN, float), np.array(FT, float),
                               image=np.array(IMG, np.int64), **kw)
    soft = replace(soft, seed=meta["packing"]["seed"], scene_text=scene_text, meta=dict(info))
    return soft, info
