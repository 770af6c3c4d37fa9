"""A measured network against S: hand-derived statics (imbalance, Coulomb, nearest network
Euclidean and weighted, ranges), empty S (the smallest relaxation, exact), projection
optimality on noisy jammed networks."""
from dataclasses import replace

import numpy as np
import pytest

import forcespace as fs
from forcespace.io.jsonfile import dumps
from forcespace.model.frame import frame_problem
from forcespace.model.measurement import Measurement
from forcespace.model.walls import WALL
from forcespace.space.measured import Measured

from paths import PACKINGS

SQRT3 = np.sqrt(3.0)


def corner(measured=(2.0, 0.7, 0.3), L=2.0):
    """A unit disk on a frictionless floor between two frictionless side walls pressing it
    (normals (0, 1), (1, 0), (-1, 0)), weight L: S = {floor = L, sides t = t >= 0}."""
    normals = np.array([[0.0, 1.0], [1.0, 0.0], [-1.0, 0.0]])
    p = fs.Packing.from_arrays([0.0], [0.0], [1.0], [WALL] * 3, [0, 0, 0], fn=list(measured),
                               ft=[0.0] * 3, wall_normal=normals, external=[[0.0, -L, 0.0]],
                               measurement=Measurement(known=np.ones(3, bool)))
    return p, frame_problem(p, "all", walls="unknown")


def test_corner_disk_imbalance_nearest_and_weighted():
    p, prob = corner()
    check = Measured().compute(prob)
    assert check.feasible and check.dim == 1 and check.force_scale == pytest.approx(1.0)
    # measured: floor 2 up, sides 0.7 - 0.3 = 0.4 along +x, weight 2 down: net (0.4, 0)
    assert np.allclose(check.imbalance[0], (0.4, 0.0, 0.0))
    fn = check.nearest[0::2]
    floor = int(np.argmax(p.normal[prob.contacts, 1]))
    sides = [j for j in range(3) if j != floor]
    assert fn[floor] == pytest.approx(2.0) and np.allclose(fn[sides], 0.5)
    assert np.allclose(check.contact_distance[sides], 0.2)
    assert check.distance == pytest.approx(np.sqrt(0.08 / 3))
    assert np.allclose(p.fn[prob.contacts][sides], (0.7, 0.3))
    sigma = np.full((3, 2), 1.0)
    sigma[sides, 0] = (0.1, 0.3)                           # the 0.7 side is the surer one
    w = Measured(weighted=True).compute(prob, sigma=sigma)
    t = (0.7 / 0.01 + 0.3 / 0.09) / (1 / 0.01 + 1 / 0.09)   # the inverse-variance mean
    assert np.allclose(w.nearest[0::2][sides], t, atol=1e-8)


def test_empty_S_smallest_relaxation_exact():
    """A disk on a frictionless floor, pushed sideways by 0.3 and down by 1: no network
    holds it; the smallest relaxation is 0.3 on its x row, the least-violating floor
    force 1. No loads to adjust (the floor is an unknown): no nearest network."""
    p = fs.Packing.from_arrays([0.0], [0.0], [1.0], [WALL], [0], fn=[1.0], ft=[0.0],
                               wall_normal=[[0.0, 1.0]], external=[[0.3, -1.0, 0.0]],
                               measurement=Measurement(known=np.ones(1, bool)))
    check = Measured().compute(frame_problem(p, "all", walls="unknown"))
    assert check.success and check.feasible is False and check.nearest is None
    assert check.relaxation_total == pytest.approx(0.3)
    assert [(r["disk"], r["row"]) for r in check.relaxation] == [(0, "fx")]
    assert np.allclose(check.least_violating, (1.0, 0.0))
    assert "no adjustment of the loads" in check.message
    dumps(check.summary(p))                                   # strict JSON


def test_disk_on_an_incline_rolls():
    """One frictional contact cannot hold a disk on a 30 degree incline (mu = 1 would hold
    the force, not the torque): the smallest relaxation is the torque W sin(alpha)."""
    a = np.radians(30.0)
    W = 1.0
    p = fs.Packing.from_arrays([0.0], [0.0], [1.0], [WALL], [0], fn=[W], ft=[0.0],
                               wall_normal=[[-np.sin(a), np.cos(a)]], mu=1.0, plate_mu=1.0,
                               external=[[0.0, -W, 0.0]],
                               measurement=Measurement(known=np.ones(1, bool)))
    check = Measured().compute(frame_problem(p, "all", walls="unknown"))
    assert check.feasible is False
    assert check.relaxation_total == pytest.approx(W * np.sin(a))
    assert [r["row"] for r in check.relaxation] == ["torque/r"]


@pytest.fixture(scope="module")
def packing():
    p = fs.read_packing(PACKINGS / "paper_mu0.5.h5")
    return replace(p, measurement=Measurement(known=np.ones(p.n_contacts, bool)))


def test_jammed_network_is_in_S(packing):
    check = Measured().compute(frame_problem(packing, "slice=28"))
    assert check.feasible and check.loads == "measured"
    assert check.distance < 1e-12 and np.abs(check.imbalance).max() < 1e-9
    assert check.inside.all() and not check.coulomb_violation.any()


def test_perturbed_contact_imbalance_and_coulomb(packing):
    """fn + delta at one region contact unbalances its two disks by delta n; ft pushed past
    the cone by delta is a Coulomb violation of delta."""
    prob = frame_problem(packing, "slice=28")
    s, delta = prob.force_scale, 0.01 * prob.force_scale
    x = prob.x_jammed.copy()
    j = int(np.argmax(x[0::2]))
    x[2 * j] += delta
    k = prob.contacts[j]
    check = Measured(ranges=False).compute(prob, x)
    rows = {int(d): v for d, v in zip(check.imbalance_disks, check.imbalance)}
    n = packing.normal[k]
    assert np.allclose(rows[int(packing.b[k])][:2], delta * n / s, atol=1e-10)
    assert np.allclose(rows[int(packing.a[k])][:2], -delta * n / s, atol=1e-10)
    x = prob.x_jammed.copy()
    x[2 * j + 1] = prob.mu[j] * x[2 * j] + delta
    viol = Measured(ranges=False).compute(prob, x).coulomb_violation
    assert viol[j] == pytest.approx(delta / s) and np.count_nonzero(viol) == 1


def test_nearest_is_no_farther_than_the_truth(packing):
    """Noise on the region's contacts only (the loads exact): the truth lies in S, so the
    projection is at most as far from the noisy input as the truth, the ranges hold the
    truth and the nearest network, and the nearest network is in S."""
    prob = frame_problem(packing, "slice=28")
    rng = np.random.default_rng(3)
    truth = prob.x_jammed
    noise = 0.05 * prob.force_scale * rng.standard_normal(truth.size)
    check = Measured().compute(prob, truth + noise)
    assert check.loads == "measured"
    assert check.distance_abs <= np.linalg.norm(noise) + 1e-12
    assert prob.violation(check.nearest) <= 1e-9
    tol = 1e-6 * prob.force_scale
    for x in (truth, check.nearest):
        assert np.all((x[0::2] >= check.fn_range[:, 0] - tol) & (x[0::2] <= check.fn_range[:, 1]
                                                                  + tol))
        assert np.all((x[1::2] >= check.ft_range[:, 0] - tol) & (x[1::2] <= check.ft_range[:, 1]
                                                                  + tol))


def test_noisy_loads_are_adjusted_least(packing):
    """Noise on every contact, the loads included: S at the measured loads is empty; the
    joint nearest network (region and boundary forces) is no farther from the measurement
    than the truth, and it lies in the S of its adjusted loads."""
    rng = np.random.default_rng(5)
    s = packing.mean_normal_force()
    live = packing.fn > 0
    q = replace(packing, fn=packing.fn + live * 0.05 * s * rng.standard_normal(packing.n_contacts),
                ft=packing.ft + live * 0.05 * s * rng.standard_normal(packing.n_contacts))
    prob = frame_problem(q, "slice=28")
    check = Measured().compute(prob)
    assert check.feasible is False and check.loads == "adjusted"
    truth = np.concatenate([prob.forces_from_packing(packing.fn, packing.ft),
                            np.column_stack([packing.fn[prob.load_contacts],
                                             packing.ft[prob.load_contacts]]).ravel()])
    measured = np.concatenate([prob.x_jammed, prob.meta["load_x"]])
    m = prob.n_contacts + prob.load_contacts.size
    assert check.distance_joint * prob.force_scale * np.sqrt(m) <= np.linalg.norm(
        truth - measured) + 1e-12
    assert check.analysed.violation(check.nearest) <= 1e-9
