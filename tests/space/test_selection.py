"""forcespace.select: the compatible (minimum complementary energy) network in S.

The reference solutions are derived independently of the statics matrix A:
the direct stiffness method on the hand-built geometry. Each contact k
between bodies a and b (normal n from a to b, t = (-n_y, n_x); a fixed
support has no degrees of freedom) has

    overlap  dn = n.(u_a - u_b),   slip  s = t.(u_b - u_a) - r_b th_b - r_a th_a,
    fn = kn dn,   ft = -kt s,

so the spring energy is U = 1/2 sum (kn dn^2 + kt s^2) = 1/2 q^T K q with
K = sum kn c_n c_n^T + kt c_t c_t^T (c_n, c_t the gradients of dn, s in the
dofs q = (u_x, u_y, th) per disk), and equilibrium is K q = F (loads: forces
and torques on the disks). Linear springs loaded from a stress-free state.
"""
import json
import subprocess
import sys

import numpy as np
import pytest

import forcespace as fs
from forcespace.model.packing import Packing
from forcespace.model.problem import build_problem

from paths import PACKINGS


# ---------------------------------------------------------------------------
# hand-built systems
# ---------------------------------------------------------------------------
def tripod(alpha, mu, W=1.0, load=None):
    """Disk 0 (r = 1) at the origin resting on three fixed support disks (r = 1)
    below it at angles -alpha, 0, +alpha from the vertical; weight W.
    ``load`` = (angle, fn, ft): an extra fixed load contact from a disk touching
    disk 0 at that polar angle (gives a horizontal force and a torque)."""
    xs = [0.0, -2 * np.sin(alpha), 0.0, 2 * np.sin(alpha)]
    ys = [0.0, -2 * np.cos(alpha), -2.0, -2 * np.cos(alpha)]
    a, b, fn, ft = [1, 2, 3], [0, 0, 0], [0.3, 0.3, 0.3], [0.0, 0.0, 0.0]
    if load is not None:
        ang, lfn, lft = load
        xs.append(2 * np.cos(ang))
        ys.append(2 * np.sin(ang))
        a.append(4)
        b.append(0)
        fn.append(lfn)
        ft.append(lft)
    n = len(xs)
    p = Packing.from_arrays(xs, ys, np.ones(n), a, b, fn, ft, width=100.0,
                            gravity=W / np.pi, mu=mu)
    interior = np.zeros(n, bool)
    interior[0] = True
    support = np.zeros(n, bool)
    support[1:4] = True
    prob = build_problem(p, interior, (), "test", support_mask=support,
                         rattlers=np.zeros(n, bool))
    return p, prob


def stack(mu, W=1.0, P=1.0):
    """Two rows in the grooves of three fixed supports at (0,0), (2,0), (4,0):
    disks 3, 4 at (1, sqrt3), (3, sqrt3) and disk 5 at (2, 2 sqrt3) on top;
    weight W each; radius 1; disks 6, 7 at (-1, sqrt3), (5, sqrt3) push 3 and 4
    together with fixed loads P (so the 3-4 spring stays compressed).
    7 unknown contacts (3 interior disks, 9 rows)."""
    s3 = np.sqrt(3.0)
    xs = [0.0, 2.0, 4.0, 1.0, 3.0, 2.0, -1.0, 5.0]
    ys = [0.0, 0.0, 0.0, s3, s3, 2 * s3, s3, s3]
    a = [0, 1, 1, 2, 3, 3, 4, 6, 4]
    b = [3, 3, 4, 4, 4, 5, 5, 3, 7]
    m = len(a)
    fn = np.ones(m)
    fn[-2:] = P
    p = Packing.from_arrays(xs, ys, np.ones(8), a, b, fn, np.zeros(m), width=100.0,
                            gravity=W / np.pi, mu=mu)
    sup = np.zeros(8, bool)
    sup[:3] = True
    interior = np.zeros(8, bool)
    interior[3:6] = True
    prob = build_problem(p, interior, (), "test", support_mask=sup, rattlers=np.zeros(8, bool))
    return p, prob


def stiffness_solution(p, prob, kn, kt, overlap=None):
    """Direct stiffness method (module docstring): (x (2m,) in problem order, u (n, 2), th (n,)).

    kn, kt: numbers or (m,) per unknown contact; a frictionless contact has no
    tangential spring. Load contacts and gravity are loads. Without tangential
    springs a disk's rotation is free (K singular there): least squares, the
    forces are unique.
    """
    disks = list(prob.disks)
    n = len(disks)
    dof = {d: 3 * i for i, d in enumerate(disks)}
    kn = np.broadcast_to(np.asarray(kn, float), (prob.n_contacts,))
    kt = np.where(prob.mu > 0, np.broadcast_to(np.asarray(kt, float), (prob.n_contacts,)), 0.0)
    K = np.zeros((3 * n, 3 * n))
    F = np.zeros(3 * n)
    grads = []
    for j, k in enumerate(prob.contacts):
        nrm = p.normal[k]
        t = np.array([-nrm[1], nrm[0]])
        cn, ct = np.zeros(3 * n), np.zeros(3 * n)
        for body, sgn in ((p.a[k], 1.0), (p.b[k], -1.0)):
            if body in dof:
                i = dof[body]
                cn[i:i + 2] += sgn * nrm
                ct[i:i + 2] += -sgn * t
                ct[i + 2] += -p.r[body]
        grads.append((cn, ct))
        K += kn[j] * np.outer(cn, cn) + kt[j] * np.outer(ct, ct)
    # loads: gravity and the fixed load contacts (force on b, torque -r ft on both)
    g = p.external_forces()
    for d in disks:
        F[dof[d]:dof[d] + 2] += g[d]
    for k in prob.load_contacts:
        nrm = p.normal[k]
        t = np.array([-nrm[1], nrm[0]])
        force = p.fn[k] * nrm + p.ft[k] * t
        for body, sgn in ((p.b[k], 1.0), (p.a[k], -1.0)):
            if body in dof:
                i = dof[body]
                F[i:i + 2] += sgn * force
                F[i + 2] += -p.r[body] * p.ft[k]
    # U = 1/2 sum kn (dn + d0)^2 + kt s^2; equilibrium dU/dq = F (generalised loads)
    d0 = np.zeros(prob.n_contacts) if overlap is None else np.asarray(overlap, float)
    for j, (cn, _) in enumerate(grads):
        F -= kn[j] * d0[j] * cn
    q = np.linalg.lstsq(K, F, rcond=1e-12)[0]
    x = np.empty(prob.n_columns)
    for j, (cn, ct) in enumerate(grads):
        x[2 * j] = kn[j] * (d0[j] + cn @ q)
        x[2 * j + 1] = -kt[j] * ct @ q
    return x, q.reshape(n, 3)[:, :2], q.reshape(n, 3)[:, 2]


def rel(a, b):
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / np.abs(b).max())


# ---------------------------------------------------------------------------
# must-show: the selected network is the analytic elastic solution
# ---------------------------------------------------------------------------
def test_frictionless_tripod_closed_form():
    """Frictionless disk on three supports (degree of indeterminacy 1): by hand,
    u_y = -W / (kn (1 + 2 cos^2 a)), so fn_middle = W / (1 + 2 cos^2 a) and
    fn_side = W cos a / (1 + 2 cos^2 a) -- not the Chebyshev centre of S."""
    alpha, W = 0.5, 1.7
    p, prob = tripod(alpha, mu=0.0, W=W)
    assert fs.ForceSpace(ranges=False).compute(prob).dim == 1
    sel = fs.Selection(kt_ratio=2 / 7, kn=100.0).compute(prob)
    c2 = 1 + 2 * np.cos(alpha) ** 2
    expect = np.zeros(6)
    expect[0::2] = [W * np.cos(alpha) / c2, W / c2, W * np.cos(alpha) / c2]
    assert rel(sel.x, expect) < 1e-9
    assert sel.violation < 1e-12 and sel.sliding_contacts.size == 0
    assert sel.displacement[0] == pytest.approx([0.0, -W / (100.0 * c2)], abs=1e-12)
    assert sel.energy == pytest.approx(0.5 * W ** 2 / (100.0 * c2), rel=1e-9)
    centre = fs.ForceSpace(ranges=False).compute(prob).centre
    assert rel(centre, expect) > 1e-2          # elasticity picks its own point of S


def test_frictionless_tripod_per_contact_kn():
    """Unequal springs move the answer as the stiffness method says."""
    p, prob = tripod(0.6, mu=0.0, W=1.0)
    kn = np.array([1.0, 5.0, 2.0])
    x_ref, _, _ = stiffness_solution(p, prob, kn, kn)
    sel = fs.Selection(kn=kn).compute(prob)
    assert rel(sel.x, x_ref) < 1e-9


@pytest.mark.parametrize("ratio", [2 / 7, 1.0, 3.0])
def test_frictional_tripod_with_torque_load(ratio):
    """Tangential springs, rotation and a load with a torque: 6 unknowns,
    3 equations; the stiffness method's solution, no contact sliding (mu = 20;
    at kt/kn = 3 the springs need |ft|/fn up to 7)."""
    p, prob = tripod(0.5, mu=20.0, W=1.0, load=(np.deg2rad(100.0), 1.0, 0.1))
    x_ref, u_ref, th_ref = stiffness_solution(p, prob, 1.0, ratio)
    assert x_ref[0::2].min() > 0.1 * x_ref[0::2].max()      # no spring in tension
    sel = fs.Selection(kt_ratio=ratio).compute(prob)
    assert sel.sliding_contacts.size == 0
    assert rel(sel.x, x_ref) < 1e-9
    assert np.abs(x_ref[1::2]).max() > 0.05 * np.abs(x_ref).max()   # friction really carries
    assert sel.displacement == pytest.approx(u_ref, rel=1e-8, abs=1e-12)
    assert sel.rotation == pytest.approx(th_ref, rel=1e-8, abs=1e-12)
    assert sel.compatibility_residual < 1e-9


@pytest.mark.parametrize("ratio", [2 / 7, 1.0])
def test_frictional_stack_disk_disk_contacts(ratio):
    """Three interior disks with disk-disk contacts (7 contacts, 14 unknowns, 9 rows)."""
    p, prob = stack(mu=10.0)
    x_ref, u_ref, th_ref = stiffness_solution(p, prob, 1.0, ratio)
    sel = fs.Selection(kt_ratio=ratio, kn=1.0).compute(prob)
    assert sel.sliding_contacts.size == 0 and sel.open_contacts.size == 0
    assert rel(sel.x, x_ref) < 1e-9
    assert sel.displacement == pytest.approx(u_ref, rel=1e-8, abs=1e-12)
    assert sel.rotation == pytest.approx(th_ref, rel=1e-8, abs=1e-12)


# ---------------------------------------------------------------------------
# kt/kn, scale, sliding
# ---------------------------------------------------------------------------
def test_kt_ratio_changes_answer_as_predicted():
    p, prob = stack(mu=100.0)          # at kt/kn = 10 the springs need |ft|/fn ~ 12
    sels = {r: fs.Selection(kt_ratio=r).compute(prob) for r in (0.1, 2 / 7, 1.0, 10.0)}
    for r, s in sels.items():
        assert rel(s.x, stiffness_solution(p, prob, 1.0, r)[0]) < 1e-9
    assert rel(sels[2 / 7].x, sels[1.0].x) > 1e-3
    # softer tangential springs carry less tangential force
    ft = [np.abs(sels[r].ft).sum() for r in (0.1, 2 / 7, 1.0, 10.0)]
    assert ft == sorted(ft)
    # only the ratio matters: kn x 1000 gives the same network, energy / 1000
    s2 = fs.Selection(kt_ratio=1.0, kn=1000.0).compute(prob)
    assert rel(s2.x, sels[1.0].x) < 1e-12
    assert s2.energy == pytest.approx(sels[1.0].energy / 1000.0, rel=1e-12)
    # frictionless: kt does not enter
    p0, prob0 = stack(mu=0.0)
    assert rel(fs.Selection(kt_ratio=0.1).compute(prob0).x, fs.Selection(kt_ratio=10.0).compute(prob0).x) < 1e-12


def test_initial_overlaps():
    """Springs that start overlapping (a soft code started from a rigid packing):
    the stiffness method with the misfit as eigenstrain; kn now matters."""
    p, prob = stack(mu=100.0)
    rng = np.random.default_rng(3)
    d0 = rng.uniform(-0.05, 0.1, prob.n_contacts)
    for kn in (1.0, 10.0):
        x_ref, u_ref, th_ref = stiffness_solution(p, prob, kn, 0.5 * kn, d0)
        assert x_ref[0::2].min() > 0
        sel = fs.Selection(kt_ratio=0.5, kn=kn, overlap=d0).compute(prob)
        assert rel(sel.x, x_ref) < 1e-9
        assert sel.displacement == pytest.approx(u_ref, rel=1e-8, abs=1e-12)
        assert sel.compatibility_residual < 1e-9
    assert rel(fs.Selection(0.5, 1.0, d0).compute(prob).x, fs.Selection(0.5, 10.0, d0).compute(prob).x) > 1e-2
    # a gap wider than the spring's approach: that contact carries nothing (Signorini)
    p, prob = tripod(0.5, mu=0.0)
    gap = np.array([0.0, 0.0, -10.0])
    sel = fs.Selection(kn=1.0, overlap=gap).compute(prob)
    assert abs(sel.fn[2]) < 1e-12 and 2 in sel.open_contacts
    with pytest.raises(fs.InputError, match="overlap"):
        fs.Selection(overlap=np.ones(2)).compute(prob)


def test_force_scale_invariance():
    p, prob = tripod(0.5, mu=20.0, load=(np.deg2rad(100.0), 1.0, 0.1))
    for f in (1e-9, 1e9):
        s = fs.Selection(kt_ratio=1.0).compute(prob.scaled(f))
        assert rel(s.x / f, fs.Selection(kt_ratio=1.0).compute(prob).x) < 1e-9


def test_tight_mu_slides_and_stays_in_S():
    """mu below what the elastic solution needs: Coulomb becomes active, the result
    is in S, at the limit on the sliding contacts, and is the minimum over S
    (checked against scipy's SLSQP and against points of S)."""
    from scipy.optimize import minimize

    p, prob = stack(mu=10.0)
    x_el, _, _ = stiffness_solution(p, prob, 1.0, 1.0)
    need = np.abs(x_el[1::2]) / x_el[0::2]
    mu = 0.5 * need.max()
    p, prob = stack(mu=mu)
    sel = fs.Selection(kt_ratio=1.0).compute(prob)
    assert prob.violation(sel.x) < 1e-12
    assert sel.sliding_contacts.size >= 1
    j = sel.sliding_contacts
    assert np.abs(sel.ft[j]) == pytest.approx(mu * sel.fn[j], rel=1e-9)
    assert rel(sel.x, x_el) > 1e-3                 # it is not the elastic solution any more
    # an independent solver
    G, _, _ = prob.inequalities()
    A, b, Gd = prob.A.toarray(), prob.b, G.toarray()
    res = minimize(lambda x: 0.5 * x @ x, x_el, jac=lambda x: x, method="SLSQP",
                   constraints=[{"type": "eq", "fun": lambda x: A @ x - b, "jac": lambda x: A},
                                {"type": "ineq", "fun": lambda x: -Gd @ x, "jac": lambda x: -Gd}],
                   options={"ftol": 1e-15, "maxiter": 500})
    assert res.success
    assert rel(sel.x, res.x) < 1e-6
    # no point of S has lower energy: segments towards the centre and the ranges' corners
    S = fs.ForceSpace(ranges=False).compute(prob)
    e = lambda x: 0.5 * x @ x  # noqa: E731
    for y in [S.centre, S.affine_point]:
        for t in (1e-3, 0.1, 0.5, 1.0):
            assert e((1 - t) * sel.x + t * y) >= sel.energy - 1e-12


def test_frictionless_tension_opens():
    """A support whose spring would pull (tension) opens: fn = 0, listed as open."""
    # tripod with a sideways push: the support on the pushed side would pull
    p, prob = tripod(1.0, mu=0.0, W=1.0, load=(np.deg2rad(180.0), 0.8, 0.0))
    x_lin, _, _ = stiffness_solution(p, prob, 1.0, 1.0)
    assert x_lin[0::2].min() < 0            # the linear (bilateral) solution pulls
    sel = fs.Selection().compute(prob)
    assert sel.open_contacts.size >= 1 and sel.fn.min() >= 0
    assert prob.violation(sel.x) < 1e-12


def test_bad_input():
    p, prob = tripod(0.5, mu=0.0)
    for bad in (0.0, -1.0, float("nan"), float("inf"), "x"):
        with pytest.raises(fs.InputError, match="kt_ratio"):
            fs.Selection(kt_ratio=bad).compute(prob)
    with pytest.raises(fs.InputError, match="kn"):
        fs.Selection(kn=np.ones(2)).compute(prob)
    with pytest.raises(fs.InputError, match="kn"):
        fs.Selection(kn=-1.0).compute(prob)
    with pytest.raises(AttributeError, match="compute"):
        fs.Selection().x


def test_paper_slice_in_S():
    """The 200-disk paper packing at mu = 0.1: verified minimum, in S, some sliding."""
    prob = fs.slice_problem(fs.read_packing(PACKINGS / "paper_mu0.1.h5"), 28.0)
    sel = fs.Selection(kt_ratio=2 / 7).compute(prob)
    assert sel.violation < 1e-12 and sel.kkt_residual < 1e-9
    assert sel.compatibility_residual < 1e-9
    assert sel.sliding_contacts.size > 0


# ---------------------------------------------------------------------------
# CLI
# ---------------------------------------------------------------------------
def _cli(*args):
    return subprocess.run([sys.executable, "-m", "forcespace.cli", *args],
                          capture_output=True, text=True)


def test_cli_bad_kt_ratio():
    pack = str(PACKINGS / "paper_mu0.1.h5")
    for bad in ("0", "-0.5", "nan"):
        r = _cli("select", pack, "--kt-ratio", bad, "-o", "sel.h5")
        assert r.returncode == 2, r.stderr
        assert "--kt-ratio" in r.stderr and "> 0" in r.stderr and "Traceback" not in r.stderr
    r = _cli("select", pack, "--kt-ratio", "1", "--slice", "28", "--plate", "-o", "sel.h5")
    assert r.returncode == 2                      # argparse: not both
    r = _cli("select", pack, "-o", pack)          # refuses to overwrite its input
    assert r.returncode == 2 and "-o" in r.stderr


@pytest.mark.slow
def test_cli_select_then_distance():
    """The selected network (plate S, and a slice's) is a soft-network file that
    `forcespace distance` accepts, and it lies in the plate S of the packing."""
    pack = str(PACKINGS / "paper_mu0.1.h5")
    r = _cli("select", pack, "--kt-ratio", "0.2857142857", "--plate", "-o", "sel.h5", "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["violation"] < 1e-12 and out["kind"] == "full_plate"
    from forcespace.io.packing_file import read_packing
    sel = read_packing("sel.h5", kind="soft_network")
    assert sel.meta["code"] == "forcespace select" and sel.meta["converged"]
    r = _cli("distance", "sel.h5", pack, "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["relative_distance"] < 1e-9 and d["unmatched_contacts"] == 0
    # the slice selection is admissible for the whole packing too
    r = _cli("select", pack, "--kt-ratio", "1", "--slice", "28", "-o", "sel2.h5",
             "--initial-overlaps", "--kn", "1e5")
    assert r.returncode == 0, r.stderr
    r = _cli("distance", "sel2.h5", pack, "--json")
    assert r.returncode == 0 and json.loads(r.stdout)["relative_distance"] < 1e-9


# ---------------------------------------------------------------------------
# the study (quick variant: 30 disks, LIGGGHTS + pymunk)
# ---------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.external
def test_selection_study_quick(tmp_path, capsys):
    import shutil

    if shutil.which("liggghts") is None:
        pytest.skip("LIGGGHTS binary missing (apt-get install liggghts)")
    from forcespace.cli import main

    out = tmp_path / "sel"
    assert main(["study", "selection", "--quick", "--workers", "1", "-o", str(out),
                 "--quiet"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["failed"] == 0 and summary["rows"] == 4
    assert (out / "selection.csv").is_file() and (out / "selection.png").is_file()
    table = (out / "selection_table.md").read_text()
    assert "lig–sel" in table
    for f in (out / "tasks").glob("*.json"):
        for row in json.loads(f.read_text())["rows"]:
            # every network compared is admissible: soft ones land within 1e-2 <Fn> of S
            assert row["lig_distance_to_S"] < 1e-2 and row["pym_distance_to_S"] < 1e-2
            assert row["d_lig_sel"] >= 0 and row["d_sel_centre"] > 0
            assert row["na_lig_residual"] < 1e-9
