"""The static certificate (forcespace.engine.certificate): hand-derived statics, Farkas
infeasibility, agreement with the independent StaticsProblem, and the protocol's use."""
import numpy as np
import pytest

from engine_cases import free_bodies
from forcespace.engine.certificate import certify, frozen_system, in_cones
from forcespace.engine.protocol import build_packing
from forcespace.engine.records import Box
from forcespace.model.scene import load_scene
from forcespace.model.walls import N_WALL_SLOTS

QUICK = "quick"
SIDES = Box(2.0, False, has_bottom=True, has_top=False, has_sides=True)


def test_a_disk_on_the_floor_carries_its_weight():
    b = free_bodies([5.0], [1.0], [1.0], gravity=2.0)
    c, _img, system, rn0, rt0 = frozen_system(b, Box(10.0, False, True, False, True), 0.0,
                                              0.0, 1e-6, None)
    cert = certify(system, rn0, rt0)
    weight = 2.0 * np.pi
    assert cert.status == "static"
    assert c.a.size == 1 and cert.rn[0] == pytest.approx(weight, rel=1e-9)
    assert cert.residual <= 1e-10


def test_a_disk_between_two_walls_hangs_on_friction_only():
    # a disk of radius 1 wedged between side walls 2 apart, no floor under it: its
    # weight W can only be carried by the tangential forces, W/2 each, and the nearest
    # network to zero forces has the smallest normal force Coulomb allows, W / (2 mu)
    b = free_bodies([1.0], [5.0], [1.0], gravity=1.0)
    weight = np.pi
    for mu, want in ((0.0, "not static"), (0.5, "static")):
        c, _img, system, rn0, rt0 = frozen_system(b, SIDES, mu, mu, 1e-6, None)
        cert = certify(system, rn0, rt0)
        assert c.a.size == 2 and cert.status == want
    assert np.allclose(cert.rn, weight / (2 * 0.5), rtol=1e-7)
    assert np.allclose(np.abs(cert.rt), weight / 2, rtol=1e-7)
    least = certify(system, rn0, rt0, norm="l1")      # the same unique least change
    assert np.allclose(least.rn, cert.rn, rtol=1e-7) and np.allclose(least.rt, cert.rt, rtol=1e-7)
    rn, rt = in_cones(cert.rn, cert.rt, c.mu)
    assert (np.abs(rt) <= c.mu * rn).all()


def test_a_disk_resting_off_centre_on_another_without_friction_is_not_static():
    # the only contact force is along the normal, which is not vertical: the weight's
    # component along the tangent is unbalanced (Farkas: the solver proves infeasibility)
    b = free_bodies([5.0, 5.5], [1.0, 3.0], [1.0, 1.0], gravity=1.0, fixed=(0,))
    b.x[1] = 5.0 + np.sqrt(4.0 - 2.0 ** 2 * 0.99)     # the upper disk touches off centre
    b.y[1] = 1.0 + np.sqrt(4.0 - (b.x[1] - 5.0) ** 2)
    _c, _img, system, rn0, rt0 = frozen_system(b, Box(10.0, False, False, False, False),
                                               0.0, 0.0, 1e-6, None)
    assert certify(system, rn0, rt0).status == "not static"


def test_the_equations_agree_with_the_statics_problem_of_a_jammed_packing():
    # an independent assembly (model.problem, through the packing's own residual):
    # the certificate's network of a jammed packing balances every disk and the plate
    scene = load_scene(QUICK).with_overrides(**{"physics.mu": 0.3, "disks.n": 30})
    p = build_packing(scene, show_progress=False)
    from forcespace.engine.protocol import start_bodies
    from forcespace.model.setup import Setup
    setup = Setup.from_scene(scene)
    b = start_bodies(setup)
    n = p.n_disks
    b.x[:n], b.y[:n] = p.x, p.y
    b.y[n + 1] = p.y_top
    from forcespace.engine.bodies import kernel_box
    c, _img, system, rn0, rt0 = frozen_system(b, kernel_box(setup.boundary), 0.3, 0.0, 1e-6,
                                              None)
    assert c.a.size == p.n_contacts
    f = np.empty(2 * c.a.size)
    order = np.argsort(c.keys)            # the packing lists contacts in key order too
    f[0::2], f[1::2] = p.fn[order], p.ft[order]
    assert np.abs(system.A @ f - system.b).max() <= 1e-9 * np.abs(p.fn).mean()
    cert = certify(system, rn0, rt0)
    assert cert.status == "static"
    from dataclasses import replace
    q = replace(p, fn=cert.rn[order], ft=cert.rt[order])
    assert q.equilibrium_residual() <= 1e-9


def test_a_certified_jam_says_how_it_ended_and_is_static():
    scene = load_scene(QUICK).with_overrides(**{"physics.mu": 0.3,
                                                "jamming.certificate_speed": 1e-2})
    p = build_packing(scene, show_progress=False)
    ref = build_packing(load_scene(QUICK).with_overrides(**{"physics.mu": 0.3}),
                        show_progress=False)
    assert p.meta["jam_end"] == "certificate" and ref.meta["jam_end"] == "rest"
    assert p.meta["static_network"] == "certificate" and ref.meta["static_network"] == "sweeps"
    # the quick scene comes to rest abruptly: 2e-3 v0 one window, 5e-9 the next
    assert p.meta["steps"] < ref.meta["steps"] and p.meta["certificates_tried"] >= 1
    assert p.equilibrium_residual() <= scene["jamming.static_tolerance"]
    assert (np.abs(p.ft) <= 0.3 * p.fn + 1e-15).all()
    assert p.max_overlap() <= scene["jamming.max_overlap"]


def test_a_certified_checkpoint_resumes_at_the_static_network_and_keeps_its_end(tmp_path):
    from forcespace.engine import compress as compress_module
    from forcespace.engine.protocol import start_bodies
    from forcespace.io.checkpoint import read_checkpoint
    scene = load_scene(QUICK).with_overrides(**{"physics.mu": 0.3, "disks.n": 20,
                                                "jamming.certificate_speed": 1e-2})
    fresh = build_packing(scene, show_progress=False)
    ck = tmp_path / "c.h5"
    from forcespace.model.setup import Setup
    setup = Setup.from_scene(scene)
    compress_module.compress(setup, start_bodies(setup), setup.seed, show_progress=False,
                             checkpoint=ck)
    state = read_checkpoint(ck, setup.identity)
    assert state["phase"] == "jammed" and state["ended"] == fresh.meta["jam_end"]
    resumed = build_packing(scene, show_progress=False, checkpoint=ck)
    assert resumed.meta["jam_end"] == fresh.meta["jam_end"] == "certificate"
    np.testing.assert_array_equal(resumed.fn, fresh.fn)
    np.testing.assert_array_equal(resumed.ft, fresh.ft)


def test_the_least_total_change_keeps_more_of_the_dynamics_forces_unchanged():
    # from the dynamics' last forces of a certified jam, the L1-nearest static network
    # changes the forces least in total (its defining property) and leaves many more
    # contacts exactly as the dynamics had them than the Euclidean projection, which
    # spreads its change over nearly all of them
    from forcespace.engine.bodies import kernel_box
    from forcespace.engine.compress import compress
    from forcespace.engine.protocol import start_bodies
    from forcespace.model.setup import Setup
    setup = Setup.from_scene(load_scene(QUICK).with_overrides(
        **{"physics.mu": 0.3, "jamming.certificate_speed": 1e-2}))
    b = start_bodies(setup)
    assert compress(setup, b, setup.seed, show_progress=False)["jam_end"] == "certificate"
    c, _img, system, rn0, rt0 = frozen_system(b, kernel_box(setup.boundary), 0.3, 0.0, 1e-6,
                                              b.contacts)
    scale = np.abs(rn0).mean()
    kept, total = {}, {}
    for norm in ("l1", "l2"):
        cert = certify(system, rn0, rt0, norm=norm)
        assert cert.status == "static" and cert.residual <= 1e-9
        change = np.abs(cert.rn - rn0) + np.abs(cert.rt - rt0)
        kept[norm], total[norm] = (change <= 1e-6 * scale).mean(), change.sum()
    assert total["l1"] <= total["l2"] * (1 + 1e-6)
    assert kept["l1"] > 0.2 > 0.1 > kept["l2"]


# ---- spheres: Coulomb as second-order cones (issue 43) ------------------------------------

def sphere_on_three(mu, push):
    """A sphere resting on three fixed ones (normals at sin(theta) = sqrt(2/3) to the
    horizontal) under a load (push, 0, -P): its SphereStaticsProblem and the contact
    normals (3, 3) (from the supports to the top sphere)."""
    from forcespace.model.sphere_packing import SpherePacking
    from forcespace.model.sphere_problem import build_sphere_problem
    d = 2 / np.sqrt(3)
    base = [(d * np.cos(a), d * np.sin(a), 1.0) for a in np.deg2rad([90, 210, 330])]
    pos = np.array(base + [(0.0, 0.0, 1.0 + np.sqrt(4 - d * d))]) + (25.0, 25.0, 0.0)
    p = SpherePacking.from_arrays(pos, np.ones(4), [0, 1, 2], [3, 3, 3], lateral=(50, 50),
                                  mu=mu, fn=np.ones(3))
    top = np.arange(4) == 3
    prob = build_sphere_problem(p, top, (), "hand", support_mask=~top,
                                rattlers=np.zeros(4, bool))
    prob.b[0] -= push                      # b = -(loads): load +push along x, -P along z
    prob.b[2] += 3.0
    normals = (pos[3] - pos[:3]) / 2.0
    return prob, normals


@pytest.mark.parametrize("push, want", [(0.2, "static"), (2.0, "not static")])
def test_a_frictionless_sphere_on_three_is_static_exactly_when_its_forces_push(push, want):
    # mu = 0: three normal forces balance the load alone, fn = N^-1 (-load); a sideways
    # push beyond the cone of the normals would need a pulling contact: no network
    from forcespace.engine.certificate import certify_spheres, least_change_spheres
    prob, normals = sphere_on_three(0.0, push)
    fn = np.linalg.solve(normals.T, [-push, 0.0, 3.0])
    assert (fn.min() > 0) == (want == "static")
    for cert, x in (certify_spheres(prob), least_change_spheres(prob)):
        assert cert.status == want
        if want == "static":
            np.testing.assert_allclose(x[0::3], fn, rtol=1e-8)
            assert x[1::3].max() == x[2::3].max() == 0.0 and cert.residual <= 1e-10


@pytest.mark.parametrize("push, want", [(1.0, "static"), (1.5, "not static")])
def test_friction_does_not_hold_a_sphere_on_three_past_its_tipping_push(push, want):
    # the frictionless limit (fn of one support reaching 0 at push = 1.225 P / 3 ...) holds
    # with mu = 1 too: past it the sphere rolls about the axis through the two other
    # contacts, which do not slide, so no Coulomb cone resists (a kinematic mechanism)
    from forcespace.engine.certificate import certify_spheres
    prob, normals = sphere_on_three(1.0, push)
    fn = np.linalg.solve(normals.T, [-push, 0.0, 3.0])
    assert (fn.min() > 0) == (want == "static")
    cert, x = certify_spheres(prob)
    assert cert.status == want
    if x is not None:
        assert np.abs(prob.A @ x - prob.b).max() <= 1e-9
        assert prob.cone_excess(x).max() <= 1e-9


@pytest.mark.parametrize("mu", [0.0, 0.5])
def test_a_sphere_wedged_between_two_hangs_on_its_cones(mu):
    # a sphere between two fixed ones on a horizontal line, load P down: only friction
    # carries it, P/2 along z at each contact, and the network nearest the start (fn = 1)
    # presses with the least fn the cones allow, P / (2 mu) (> 1 here)
    from forcespace.engine.certificate import certify_spheres, least_change_spheres
    from forcespace.model.sphere_packing import SpherePacking
    from forcespace.model.sphere_problem import build_sphere_problem
    pos = np.array([(23.0, 25.0, 5.0), (27.0, 25.0, 5.0), (25.0, 25.0, 5.0)])
    p = SpherePacking.from_arrays(pos, np.ones(3), [0, 2], [2, 1], lateral=(50, 50), mu=mu,
                                  fn=np.ones(2))
    mid = np.arange(3) == 2
    prob = build_sphere_problem(p, mid, (), "hand", support_mask=~mid,
                                rattlers=np.zeros(3, bool))
    prob.b[2] += 3.0
    for cert, x in (certify_spheres(prob), least_change_spheres(prob)):
        assert cert.status == ("static" if mu else "not static")
        if mu:
            # (an interior point meets a cone's boundary to ~sqrt of its tolerance)
            np.testing.assert_allclose(x[0::3], 3.0 / (2 * mu), rtol=1e-4)
            _, ft = prob.to_packing_forces(x)                     # by balance
            np.testing.assert_allclose(np.abs(ft[:, 2]), 1.5, rtol=1e-9)
            np.testing.assert_allclose(ft[:, :2], 0.0, atol=1e-9)
            assert prob.cone_excess(x).max() <= 1e-9


def test_a_certified_sphere_jam_ends_by_its_certificate_and_is_static():
    scene = load_scene("quick3d").with_overrides(**{"physics.mu": 0.3, "disks.n": 30,
                                                  "jamming.certificate_speed": 1e-3})
    p = build_packing(scene, show_progress=False)
    assert p.meta["jam_end"] == "certificate" and p.meta["certificates_tried"] >= 1
    # the network as the uncertified scene finds it: sweeps from the dynamics' forces
    assert p.meta["static_network"] == "sweeps"
    assert p.equilibrium_residual() <= scene["jamming.static_tolerance"]
    assert p.coulomb_violation() <= 1e-12
