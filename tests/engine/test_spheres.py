"""Spheres in 3-D: the cell list, the free dynamics' conservation laws, the protocol."""
import numpy as np
import pytest

from forcespace.engine.bodies import SphereBodies
from forcespace.engine.contacts import detect_contacts3
from forcespace.engine.protocol import build_packing
from forcespace.engine.records import Box3, ContactForces, StepSettings, SweepSettings
from forcespace.engine.step import run_steps3
from forcespace.model.scene import load_scene
from forcespace.model.walls import N_WALL_SLOTS


def brute_force3(pos, r, size, margin, bottom, top):
    """All (a, b, image_x, image_y) with gap < margin, every periodic image tried."""
    n = len(r)
    out = {}
    for i in range(n):
        for j in range(i + 1, n):
            for ix in (-1, 0, 1):
                for iy in (-1, 0, 1):
                    d = pos[j] + (ix * size[0], iy * size[1], 0.0) - pos[i]
                    g = np.linalg.norm(d) - r[i] - r[j]
                    if g < margin:
                        out[(i, j, ix, iy)] = g
        if pos[i, 2] - r[i] - bottom < margin:
            out[(n, i, 0, 0)] = pos[i, 2] - r[i] - bottom
        if top - pos[i, 2] - r[i] < margin:
            out[(i, n + 1, 0, 0)] = top - pos[i, 2] - r[i]
    return out


@pytest.mark.parametrize("seed", range(8))
def test_the_3d_cell_list_finds_exactly_the_pairs_of_an_all_pairs_search(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 120))
    rmin = rng.uniform(0.05, 1.0)
    rmax = rmin * rng.uniform(1.0, 5.0)
    margin = float(rng.uniform(0.0, 0.5))
    size = rng.uniform(2.0, 5.0, 2) * (2 * rmax + margin)
    r = rng.uniform(rmin, rmax, n)
    pos = np.column_stack([rng.uniform(0, size[0], n), rng.uniform(0, size[1], n),
                           rng.uniform(0, 2 * size[0], n)])
    bottom, top = float(pos[:, 2].min() - rmin), float(pos[:, 2].max() + rmin)
    all_pos = np.zeros((n + N_WALL_SLOTS, 3))
    all_pos[:n] = pos
    all_pos[n, 2], all_pos[n + 1, 2] = bottom, top
    ints, floats = detect_contacts3(all_pos, r, Box3(*size, True, True), margin)
    want = brute_force3(pos, r, size, margin, bottom, top)
    got = {tuple(int(v) for v in row): g for row, g in zip(ints, floats[:, 3])}
    assert set(got) == set(want)
    for key, g in want.items():
        assert got[key] == pytest.approx(g, abs=1e-12)
    assert np.allclose(np.linalg.norm(floats[:, :3], axis=1), 1.0)
    keys = ints[:, 0] * (n + N_WALL_SLOTS) + ints[:, 1]
    assert (np.diff(keys) > 0).all()


def gas(n, seed, size=40.0, spread=6.0):
    """n spheres of radius 1 near the middle of a large periodic box without plates,
    random velocities and spins; mass 1 each (I = 2/5), rotation integrated."""
    rng = np.random.default_rng(seed)
    nb = n + N_WALL_SLOTS
    pos = np.zeros((nb, 3))
    placed = 0
    while placed < n:
        p = size / 2 + rng.uniform(-spread, spread, 3)
        if placed == 0 or np.linalg.norm(pos[:placed] - p, axis=1).min() > 2.05:
            pos[placed] = p
            placed += 1
    v = np.zeros((nb, 3))
    w = np.zeros((nb, 3))
    v[:n] = rng.normal(0, 0.5, (n, 3))
    w[:n] = rng.normal(0, 0.5, (n, 3))
    inv_m = np.zeros((nb, 3))
    inv_m[:n] = 1.0
    inv_i = np.zeros(nb)
    inv_i[:n] = 1.0 / 0.4
    bodies = SphereBodies(pos, np.zeros((nb, 3)), v, w, np.ones(n), inv_m, inv_i,
                          np.zeros((nb, 3)))
    return bodies, Box3(size, size, False, False)


def momenta(b, unwrapped):
    """Total momentum (3,) and angular momentum about the origin (3,): orbital + spin."""
    n = b.n
    p = b.v[:n].sum(0)
    L = np.cross(unwrapped, b.v[:n]).sum(0) + 0.4 * b.w[:n].sum(0)
    return p, L


def advance(b, box, mu, steps):
    """``steps`` steps one at a time, the centres followed without wrapping; returns the
    unwrapped positions and the solver's statistics."""
    step = StepSettings(margin=0.1, mu_disk=mu, mu_wall=0.0, rotation=True)
    sweep = SweepSettings(dt=0.01, tol=1e-12, max_sweeps=2000)
    n = b.n
    unwrapped = b.pos[:n].copy()
    contacts = ContactForces.empty()
    total = None
    for k in range(steps):
        contacts, st = run_steps3(b, box, step, sweep, contacts, 1, 3, k)
        unwrapped += 0.01 * b.v[:n]
        total = st if total is None else total.merged(st)
    return unwrapped, total


def test_free_spheres_keep_momentum_angular_momentum_and_move_in_straight_lines():
    b, _ = gas(20, seed=1)
    b.pos[:20] = 100.0 + 4.0 * np.arange(20)[:, None] * np.array([1.0, 0.5, 1.0])
    box = Box3(400.0, 400.0, False, False)      # far apart, far from the periodic edges
    start = b.pos[:20].copy()
    p0, L0 = momenta(b, start)
    w0 = b.w[:20].copy()
    unwrapped, stats = advance(b, box, mu=0.5, steps=50)
    p1, L1 = momenta(b, unwrapped)
    assert stats.normal_updates == 0                      # no contact at all
    np.testing.assert_allclose(unwrapped, start + 50 * 0.01 * b.v[:20], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(b.w[:20], w0)           # free spins never change
    np.testing.assert_allclose(p1, p0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(L1, L0, rtol=1e-12, atol=1e-10)


@pytest.mark.parametrize("mu", [0.0, 0.5])
def test_colliding_spheres_keep_their_momentum(mu):
    b, box = gas(30, seed=2)
    p0, _ = momenta(b, b.pos[:30])
    _, stats = advance(b, box, mu=mu, steps=300)
    p1, _ = momenta(b, b.pos[:30])
    assert stats.normal_updates > 0                       # they did collide
    assert (stats.tangential_updates > 0) == (mu > 0)     # friction only where asked
    np.testing.assert_allclose(p1, p0, rtol=0, atol=1e-12 * 30)


def test_frictionless_collisions_keep_the_angular_momentum():
    # impulses along the line of centres exert no torque about any point: L (orbital +
    # spin) is conserved to round-off while the spheres stay away from the periodic edges
    b, box = gas(30, seed=4)
    _, L0 = momenta(b, b.pos[:30])
    unwrapped, stats = advance(b, box, mu=0.0, steps=300)
    _, L1 = momenta(b, unwrapped)
    assert stats.normal_updates > 0
    np.testing.assert_allclose(L1, L0, rtol=0, atol=1e-10 * np.abs(L0).max())


@pytest.fixture(scope="module")
def quick3d():
    return build_packing(load_scene("quick3d"), show_progress=False)


def test_a_frictionless_sphere_packing_is_isostatic_at_rest_and_never_runs_friction(quick3d):
    s = quick3d.summary()
    assert s["equilibrium_residual"] <= 1e-10
    assert s["coulomb_violation"] == 0.0
    assert 5.6 <= s["z"] <= 6.2                 # isostatic: z = 6 up to boundary terms
    assert 0.5 < s["packing_fraction"] < 0.68
    assert quick3d.meta["tangential_updates"] == 0
    assert quick3d.meta["static_tangential_updates"] == 0
    assert quick3d.meta["rotation"] is False
    assert np.all(quick3d.ft == 0.0)


def test_a_frictional_sphere_packing_is_hypostatic_relative_to_six_and_admissible():
    p = build_packing(load_scene("quick3d").with_overrides(**{"physics.mu": 0.5,
                                                            "disks.n": 40}),
                      show_progress=False)
    s = p.summary()
    assert s["equilibrium_residual"] <= 1e-10
    assert s["coulomb_violation"] <= 1e-12
    assert 4.0 <= s["z"] < 5.6
    assert p.meta["tangential_updates"] > 0
    assert np.abs((p.ft * p.normal).sum(1)).max() <= 1e-12 * np.abs(p.ft).max()


def test_an_interrupted_sphere_jam_resumes_bit_identically(tmp_path):
    from forcespace.errors import NumericalError
    scene = load_scene("quick3d").with_overrides(**{"disks.n": 20, "physics.mu": 0.3})
    fresh = build_packing(scene, show_progress=False)
    ck = tmp_path / "p.h5.checkpoint.h5"
    with pytest.raises(NumericalError, match="resumes from"):
        build_packing(scene.with_overrides(**{"jamming.max_steps": 600}), show_progress=False,
                      checkpoint=ck)
    assert ck.exists()
    resumed = build_packing(scene, show_progress=False, checkpoint=ck)
    assert not ck.exists()
    np.testing.assert_array_equal(resumed.pos, fresh.pos)
    np.testing.assert_array_equal(resumed.fn, fresh.fn)
    np.testing.assert_array_equal(resumed.ft, fresh.ft)
    assert resumed.meta["steps"] == fresh.meta["steps"]
    np.testing.assert_array_equal(resumed.solver_log, fresh.solver_log)


def test_a_sphere_packing_file_round_trip_is_exact(quick3d, tmp_path):
    from forcespace.io.packing_file import read_packing, write_packing
    from forcespace.model.sphere_packing import SpherePacking
    path = tmp_path / "s.h5"
    write_packing(quick3d, path)
    back = read_packing(path)
    assert isinstance(back, SpherePacking)
    for name in ("pos", "r", "a", "b", "normal", "point", "image", "gap", "fn", "ft",
                 "solver_log"):
        np.testing.assert_array_equal(getattr(back, name), getattr(quick3d, name))
    assert back.lateral == quick3d.lateral and back.setup.dim == 3
    assert back.summary()["z"] == quick3d.summary()["z"]


def test_a_rotated_gas_moves_as_the_rotated_gas():
    # the dynamics has no preferred direction either: turn positions (about the box
    # centre, far from the periodic edges), velocities and spins by one rotation; after
    # 300 steps with collisions and friction the state is the turned state
    q, r = np.linalg.qr(np.random.default_rng(7).normal(size=(3, 3)))
    R = q * np.sign(np.diag(r))
    b1, box = gas(30, seed=2)
    b2, _ = gas(30, seed=2)
    c = np.full(3, 20.0)
    b2.pos[:30] = (b1.pos[:30] - c) @ R.T + c
    b2.v[:30] = b1.v[:30] @ R.T
    b2.w[:30] = b1.w[:30] @ R.T * np.linalg.det(R)    # an axial vector
    u1, s1 = advance(b1, box, mu=0.5, steps=300)
    u2, s2 = advance(b2, box, mu=0.5, steps=300)
    assert s1.tangential_updates > 0 and s1.normal_updates == s2.normal_updates
    np.testing.assert_allclose(u2, (u1 - c) @ R.T + c, rtol=0, atol=1e-9)
    np.testing.assert_allclose(b2.v[:30], b1.v[:30] @ R.T, rtol=0, atol=1e-9)
    np.testing.assert_allclose(b2.w[:30], b1.w[:30] @ R.T * np.linalg.det(R), rtol=0,
                               atol=1e-9)


@pytest.mark.parametrize("key, value, words", [
    ("box.periodic_x", False, "periodic in x and y"),
])
def test_a_sphere_scene_refuses_in_one_line_what_exists_for_disks_only(key, value, words):
    from forcespace.errors import InputError
    with pytest.raises(InputError, match=words):
        load_scene("quick3d").with_overrides(**{key: value})
    load_scene("quick").with_overrides(**{key: value})        # disks take both
