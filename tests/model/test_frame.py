"""Frames of measured networks: regions (rim layers, distances, boxes), walls with any
normal, per-disk external forces, geometric rattlers, loads that must be measured."""
from dataclasses import replace

import numpy as np
import pytest

import forcespace as fs
from forcespace.errors import InputError
from forcespace.model.frame import Region, frame_problem, rim_layers
from forcespace.model.measurement import Measurement
from forcespace.model.walls import WALL


def grid(k=5):
    """k x k touching unit disks on a square lattice (spacing 2), every neighbour pair a
    contact, no forces."""
    ij = [(i, j) for j in range(k) for i in range(k)]
    x = np.array([2.0 * i for i, _ in ij])
    y = np.array([2.0 * j for _, j in ij])
    idx = {c: n for n, c in enumerate(ij)}
    a, b = [], []
    for (i, j), n in idx.items():
        for di, dj in ((1, 0), (0, 1)):
            if (i + di, j + dj) in idx:
                a.append(n)
                b.append(idx[(i + di, j + dj)])
    p = fs.Packing.from_arrays(x, y, np.ones(k * k), a, b, mu=0.5)
    return replace(p, measurement=Measurement(known=np.zeros(len(a), bool)))


def test_rim_layers_peel_the_grid():
    p = grid(5)
    for k, inner in ((0, 25), (1, 9), (2, 1), (3, 0)):
        assert int(Region("rim", k).mask(p).sum()) == inner
    layer1 = rim_layers(p, 1)
    border = (p.x == 0) | (p.x == 8) | (p.y == 0) | (p.y == 8)
    assert np.array_equal(layer1, border)


def test_distance_box_and_flags():
    p = grid(5)
    assert Region("distance", 3.0).mask(p).sum() == 9          # centres >= 3 from the edge
    assert Region("box", (1.0, 1.0, 5.0, 5.0)).mask(p).sum() == 4
    flagged = np.zeros(25, bool)
    flagged[0] = True                        # the data's own edge flags define layer 1
    q = replace(p, measurement=replace(p.measurement, boundary=flagged))
    assert Region("rim", 1).mask(q).sum() == 24
    assert Region.parse("rim=2") == Region("rim", 2)
    assert Region.parse("box=0,0,1,1").value == (0.0, 0.0, 1.0, 1.0)
    for bad in ("rim=-1", "box=1,2,3", "slice=0", "disk=3", "rim=x"):
        with pytest.raises(InputError, match="--region"):
            Region.parse(bad)


def corner_disk(L=2.0, known=True, fn=(2.0, 0.7, 0.3), mu=0.0):
    """A unit disk in the corner of a floor (normal (0, 1)) and two side walls (normals
    (1, 0) and (-1, 0), i.e. it is squeezed sideways), pressed down by an external force
    L: the floor carries L, the two side walls one free self-stress t >= 0."""
    normals = np.array([[0.0, 1.0], [1.0, 0.0], [-1.0, 0.0]])
    meas = Measurement(known=np.full(3, known))
    return fs.Packing.from_arrays([0.0], [0.0], [1.0], [WALL] * 3, [0, 0, 0],
                                  fn=list(fn), ft=[0.0] * 3, mu=mu, plate_mu=mu,
                                  wall_normal=normals, external=[[0.0, -L, 0.0]],
                                  measurement=meas)


def test_walls_with_any_normal_and_external_force():
    """Geometry and load as data: S = {floor L, sides t = t >= 0} (frictionless)."""
    p = corner_disk()
    prob = frame_problem(p, "all", walls="unknown")
    S = fs.ForceSpace(ranges=True).compute(prob)
    assert S.feasible and S.dim == 1 and not S.bounded
    floor = int(np.flatnonzero(np.isclose(p.normal[prob.contacts, 1], 1.0))[0])
    assert np.allclose(S.fn_range[floor], (2.0, 2.0))
    sides = [j for j in range(3) if j != floor]
    assert np.allclose(S.fn_range[sides, 0], 0.0) and np.all(np.isinf(S.fn_range[sides, 1]))


def test_geometry_only_frame_is_analysable():
    """No force measured: rattlers are decided by geometry, S is the same."""
    p = corner_disk(known=False, fn=(0.0, 0.0, 0.0))
    assert not p.rattlers().any()
    S = fs.ForceSpace().compute(frame_problem(p, "all", walls="unknown"))
    assert S.feasible and S.dim == 1


def test_geometric_rattlers_prune_dangling_disks():
    """A chain dangling off a grid: each end disk has one contact, so it carries nothing,
    and the pruning walks up the chain; the grid itself stays."""
    p = grid(3)
    x = np.concatenate([p.x, [6.0, 8.0]])
    y = np.concatenate([p.y, [0.0, 0.0]])
    a = np.concatenate([p.a, [2, 9]])
    b = np.concatenate([p.b, [9, 10]])
    q = fs.Packing.from_arrays(x, y, np.ones(11), a, b, mu=0.5)
    q = replace(q, measurement=Measurement(known=np.zeros(q.n_contacts, bool)))
    rat = q.rattlers()
    assert rat[9] and rat[10] and not rat[:9].any()


def test_unmeasured_load_is_refused():
    p = grid(3)
    with pytest.raises(InputError, match="crosses the region's boundary"):
        frame_problem(p, "rim=1")
