"""Hand-built systems with statics derived by hand (shared by the ensemble tests).

groove(theta, mu, W): disk 0 (radius 1) resting in a groove formed by two fixed
support disks at (-2 sin th, 0) and (2 sin th, 0); load W downward (gravity).
By hand (normals n1 = (sin th, cos th), n2 = (-sin th, cos th), torque balance
ft2 = -ft1 = -s): fn1 = fn2 = N = (W - 2 s sin th) / (2 cos th) and Coulomb gives
    -mu W / (2 (cos th - mu sin th)) <= s <= mu W / (2 (cos th + mu sin th)),
bounded iff mu < cot th (otherwise the disk wedges: s -> -inf, N -> inf).
"""
import numpy as np

from forcespace.packing import Packing
from forcespace.statics import build_problem


def groove_interval(theta, mu, W=1.0):
    lo = -mu * W / (2 * (np.cos(theta) - mu * np.sin(theta)))
    hi = mu * W / (2 * (np.cos(theta) + mu * np.sin(theta)))
    return lo, hi


def _packing(x, y, r, a, b, fn, ft, mu, gravity, plate_mu=0.0, y_bottom=np.nan):
    x, y, r = (np.asarray(v, float) for v in (x, y, r))
    a = np.asarray(a, np.int64)
    b = np.asarray(b, np.int64)
    nrm = []
    for i, j in zip(a, b):
        if i == -1:          # BOTTOM plate below disk j
            nrm.append((0.0, 1.0))
            continue
        d = np.array([x[j] - x[i], y[j] - y[i]])
        nrm.append(d / np.linalg.norm(d))
    nrm = np.array(nrm)
    pts = np.array([(x[j] - r[j] * n[0], y[j] - r[j] * n[1]) for j, n in zip(b, nrm)])
    return Packing(x=x, y=y, r=r, width=100.0, periodic_x=False, y_bottom=y_bottom,
                   y_top=np.nan, top_force=0.0, gravity=gravity, density=1.0, mu=mu,
                   plate_mu=plate_mu, a=a, b=b, normal=nrm, point=pts,
                   image=np.zeros(len(a), np.int64), gap=np.zeros(len(a)),
                   fn=np.asarray(fn, float), ft=np.asarray(ft, float))


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


def groove(theta, mu, W=1.0):
    return grooves([theta], mu, W)


def stack(mu, W=1.0, plate_mu=0.5):
    """Three unit disks on a floor (BOTTOM): 0 and 1 on the floor, touching each
    other; 2 on top of both. Weight W on each disk. 6 contacts, 9 equations.

    Jammed state: the frictionless-symmetric solution (ft = 0 everywhere,
    fn(2-0) = fn(2-1) = W / (2 cos 30deg) ... with a compressive 0-1 contact of
    W tan30 / 2 balancing the horizontal pushes). Returns (packing, problem).
    """
    c30, s30 = np.cos(np.pi / 6), np.sin(np.pi / 6)
    x = [-1.0, 1.0, 0.0]
    y = [1.0, 1.0, 1.0 + 2 * c30]
    f_top = W / (2 * c30)                    # contacts 0->2 and 1->2
    f_mid = f_top * s30                      # contact 0->1 pushes them apart? balance:
    # disk 0 gets -f_top*(s30, c30) from the top disk and -f_mid*(1,0) from disk 1:
    # x balance needs the contact 0-1 to pull, which is impossible -> use the floor:
    # with friction at the floor the horizontal push is taken by floor friction.
    a = [-1, -1, 0, 0, 1]
    b = [0, 1, 1, 2, 2]
    # floor normal forces: W + W/2 each; floor friction balances f_top*s30
    fn = [1.5 * W, 1.5 * W, 0.0, f_top, f_top]
    ft = [0.0, 0.0, 0.0, 0.0, 0.0]
    # disk 0: force from 2 on 0 is -f_top*(s30, c30); floor tangential t=(-1,0) on b=0
    ft[0] = f_top * s30 / -1.0 * -1.0        # ft*(-1) - f_top*s30 = 0 -> ft = -f_top*s30
    ft[0] = -f_top * s30
    ft[1] = f_top * s30
    # torque balance of 0: -r*ft0 (floor) -r*ft(0-2) ... needs ft(0-2) = -ft0: set it
    ft[3] = -ft[0]
    ft[4] = -ft[1]
    p = _packing(x, y, [1.0, 1.0, 1.0], a, b, fn, ft, mu, gravity=W / np.pi,
                 plate_mu=plate_mu, y_bottom=0.0)
    return p
