"""Hand-built systems with statics derived by hand (shared by the ensemble tests).

groove(theta, mu, W): disk 0 (radius 1) resting in a groove formed by two fixed
support disks at (-2 sin th, 0) and (2 sin th, 0); load W downward (gravity).
By hand (normals n1 = (sin th, cos th), n2 = (-sin th, cos th), torque balance
ft2 = -ft1 = -s): fn1 = fn2 = N = (W - 2 s sin th) / (2 cos th) and Coulomb gives
    -mu W / (2 (cos th - mu sin th)) <= s <= mu W / (2 (cos th + mu sin th)),
bounded iff mu < cot th (otherwise the disk wedges: s -> -inf, N -> inf).
"""
import numpy as np

from forcespace.model.packing import Packing
from forcespace.model.problem import build_problem


def groove_interval(theta, mu, W=1.0):
    lo = -mu * W / (2 * (np.cos(theta) - mu * np.sin(theta)))
    hi = mu * W / (2 * (np.cos(theta) + mu * np.sin(theta)))
    return lo, hi


def _packing(x, y, r, a, b, fn, ft, mu, gravity, plate_mu=0.0, y_bottom=np.nan):
    return Packing.from_arrays(x, y, r, a, b, fn, ft, width=100.0, y_bottom=y_bottom,
                               gravity=gravity, mu=mu, plate_mu=plate_mu)


def grooves(thetas, mu, W=1.0):
    """Independent grooves side by side: S is the product of their intervals.

    Returns (packing, problem). Disk 3k is loaded, 3k+1 and 3k+2 are its supports.
    """
    xs, ys, a, b, fn = [], [], [], [], []
    for k, th in enumerate(thetas):
        x0 = 10.0 * k
        base = 3 * k
        xs += [x0, x0 - 2 * np.sin(th), x0 + 2 * np.sin(th)]
        ys += [2 * np.cos(th), 0.0, 0.0]
        a += [base + 1, base + 2]
        b += [base, base]
        fn += [W / (2 * np.cos(th))] * 2
    n = len(xs)
    p = _packing(xs, ys, np.ones(n), a, b, fn, np.zeros(len(a)), mu, gravity=W / np.pi)
    interior = np.zeros(n, bool)
    interior[0::3] = True
    prob = build_problem(p, interior, (), "test", support_mask=~interior,
                         rattlers=np.zeros(n, bool))
    return p, prob


def shared_support_grooves(theta_a, theta_b, mu, W=1.0):
    """Two loaded disks, each in its own groove, the middle support disk shared:
    one connected contact network with two independent elementary clusters.

    Supports S1 (0), S2 (1), S3 (2) at y = 0; disk A (3) on S1, S2 at angle
    theta_a, disk B (4) on S2, S3 at theta_b (A and B do not touch for
    theta_a, theta_b >= 30 deg). Contacts: 0 = S1-A, 1 = S2-A, 2 = S2-B, 3 = S3-B.
    Returns (packing, problem).
    """
    sa, sb = np.sin(theta_a), np.sin(theta_b)
    xs = [-4 * sa, 0.0, 4 * sb, -2 * sa, 2 * sb]
    ys = [0.0, 0.0, 0.0, 2 * np.cos(theta_a), 2 * np.cos(theta_b)]
    a, b = [0, 1, 1, 2], [3, 3, 4, 4]
    fn = [W / (2 * np.cos(theta_a))] * 2 + [W / (2 * np.cos(theta_b))] * 2
    p = _packing(np.array(xs) + 20.0, ys, np.ones(5), a, b, fn, np.zeros(4), mu,
                 gravity=W / np.pi)
    interior = np.array([False, False, False, True, True])
    prob = build_problem(p, interior, (), "test", support_mask=~interior,
                         rattlers=np.zeros(5, bool))
    return p, prob


def groove(theta, mu, W=1.0):
    return grooves([theta], mu, W)


def pyramid(rows, mu, plate_mu=0.5, W=1.0):
    """A pyramid of unit disks on a floor (BOTTOM plate, a support): row k
    (k = 0 at the floor) holds rows-k disks, neighbours touching. Weight W per
    disk. Returns (packing, problem) with the packing's forces set to the
    Chebyshev centre of S (an admissible 'jammed' state)."""
    from forcespace.space.force_space import ForceSpace

    xs, ys = [], []
    for k in range(rows):
        for i in range(rows - k):
            xs.append(2.0 * i + k)
            ys.append(1.0 + k * np.sqrt(3.0))
    n = len(xs)
    a, b = [], []
    for i in range(n):
        if abs(ys[i] - 1.0) < 1e-12:
            a.append(-1)
            b.append(i)
        for j in range(i + 1, n):
            if abs(np.hypot(xs[j] - xs[i], ys[j] - ys[i]) - 2.0) < 1e-9:
                a.append(i)
                b.append(j)
    m = len(a)
    p = _packing(xs, ys, np.ones(n), a, b, np.ones(m), np.zeros(m), mu, gravity=W / np.pi,
                 plate_mu=plate_mu, y_bottom=0.0)
    prob = build_problem(p, np.ones(n, bool), (-1,), "test", rattlers=np.zeros(n, bool))
    an = ForceSpace(ranges=False).compute(prob)
    fn, ft = prob.to_packing_forces(an.centre)
    p = p.with_forces(fn, ft)
    prob = build_problem(p, np.ones(n, bool), (-1,), "test", rattlers=np.zeros(n, bool))
    return p, prob


def lattice_in_box(mu):
    """A hexagon of 7 unit disks whose outer 6 are fixed supports, no load:
    any isotropic compression is admissible, so S is unbounded."""
    xs = [0.0] + [2 * np.cos(k * np.pi / 3) for k in range(6)]
    ys = [0.0] + [2 * np.sin(k * np.pi / 3) for k in range(6)]
    a = [1, 2, 3, 4, 5, 6]
    b = [0] * 6
    p = _packing(xs, ys, np.ones(7), a, b, np.ones(6), np.zeros(6), mu, gravity=0.0)
    interior = np.zeros(7, bool)
    interior[0] = True
    prob = build_problem(p, interior, (), "test", support_mask=~interior,
                         rattlers=np.zeros(7, bool))
    return p, prob


def lattice_rows(k, rows, mu, W=1.0):
    """Rows of unit disks in the grooves of a fixed support row (triangular
    lattice): supports at (2i, 0), i = 0..k; row q (1-based) holds k+1-q disks
    at y = q sqrt(3). Weight W per disk. Kinematically rigid (unlike a pyramid
    on a floor, which can roll apart), bounded for mu < cot 30 deg.
    Returns (packing, problem) with the Chebyshev centre as the jammed state."""
    from forcespace.space.force_space import ForceSpace

    xs = [2.0 * i for i in range(k + 1)]
    ys = [0.0] * (k + 1)
    for q in range(1, rows + 1):
        for i in range(k + 1 - q):
            xs.append(2.0 * i + q)
            ys.append(q * np.sqrt(3.0))
    n = len(xs)
    sup = np.zeros(n, bool)
    sup[:k + 1] = True
    a, b = [], []
    for i in range(n):
        for j in range(i + 1, n):
            if sup[i] and sup[j]:
                continue
            if abs(np.hypot(xs[j] - xs[i], ys[j] - ys[i]) - 2.0) < 1e-9:
                a.append(i)
                b.append(j)
    m = len(a)
    p = _packing(xs, ys, np.ones(n), a, b, np.ones(m), np.zeros(m), mu, gravity=W / np.pi)
    kw = dict(support_mask=sup, rattlers=np.zeros(n, bool))
    prob = build_problem(p, ~sup, (), "test", **kw)
    an = ForceSpace(ranges=False).compute(prob)
    fn, ft = prob.to_packing_forces(an.centre)
    p = p.with_forces(fn, ft)
    return p, build_problem(p, ~sup, (), "test", **kw)
