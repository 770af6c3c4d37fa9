"""The cell list against an all-pairs search over random systems."""
import numpy as np
import pytest

from forcespace.model.walls import N_WALL_SLOTS
from forcespace.engine.contacts import detect_contacts
from forcespace.engine.records import Box


def brute_force(x, y, r, width, periodic, margin, bottom=None, top=None, sides=False):
    """All (a, b, image, gap) with gap < margin, every periodic image tried (O(n^2))."""
    n = len(r)
    out = {}
    for i in range(n):
        for j in range(i + 1, n):
            for image in ((-1, 0, 1) if periodic else (0,)):
                dx = x[j] + image * width - x[i]
                g = np.hypot(dx, y[j] - y[i]) - r[i] - r[j]
                if g < margin:
                    out[(i, j, image)] = g
        if bottom is not None and y[i] - r[i] - bottom < margin:
            out[(n, i, 0)] = y[i] - r[i] - bottom
        if top is not None and top - y[i] - r[i] < margin:
            out[(i, n + 1, 0)] = top - y[i] - r[i]
        if sides:
            if x[i] - r[i] < margin:
                out[(n + 2, i, 0)] = x[i] - r[i]
            if width - x[i] - r[i] < margin:
                out[(i, n + 3, 0)] = width - x[i] - r[i]
    return out


def random_system(rng, n, width, rmin, rmax, periodic):
    r = rng.uniform(rmin, rmax, n)
    x = rng.uniform(0, width, n) if periodic else rng.uniform(r, width - r)
    y = rng.uniform(0, 3 * width, n)
    return x, y, r


@pytest.mark.parametrize("seed", range(12))
def test_cell_list_finds_exactly_the_pairs_of_an_all_pairs_search(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 80))
    rmin = rng.uniform(0.05, 1.0)
    rmax = rmin * rng.uniform(1.0, 20.0)
    periodic = bool(seed % 2)
    margin = float(rng.uniform(0.0, 0.5))
    # wide enough that one periodic image of a pair can be within reach at most
    width = float(rng.uniform(2.0, 6.0) * (2 * rmax + margin))
    x, y, r = random_system(rng, n, width, rmin, rmax, periodic)
    bottom, top = float(y.min() - rmin), float(y.max() + rmin)
    X = np.concatenate([x, np.zeros(N_WALL_SLOTS)])
    Y = np.concatenate([y, [bottom, top, 0.0, 0.0]])
    ints, floats = detect_contacts(X, Y, r, Box(width, periodic, True, True, not periodic),
                                   margin)
    want = brute_force(x, y, r, width, periodic, margin, bottom, top, sides=not periodic)
    got = {tuple(int(v) for v in row): g for row, g in zip(ints, floats[:, 2])}
    assert set(got) == set(want)
    for key, g in want.items():
        assert got[key] == pytest.approx(g, abs=1e-12)
    # unit normals pointing from a to b
    assert np.allclose(np.hypot(floats[:, 0], floats[:, 1]), 1.0)
    disk_pairs = (ints[:, 0] < n) & (ints[:, 1] < n)
    a, b, im = ints[disk_pairs].T
    d = np.column_stack([x[b] + im * width - x[a], y[b] - y[a]])
    assert np.allclose((d * floats[disk_pairs, :2]).sum(1), np.linalg.norm(d, axis=1))
    keys = ints[:, 0] * (n + N_WALL_SLOTS) + ints[:, 1]
    assert (np.diff(keys) > 0).all()  # sorted and unique


def test_one_mapping_between_packing_wall_codes_and_kernel_slots():
    from forcespace.model.walls import (SLOT_BOTTOM, SLOT_LEFT, SLOT_RIGHT, SLOT_TOP, kernel_body_index, packing_body_code)
    from forcespace.model.walls import BOTTOM, LEFT, RIGHT, TOP
    n = 7
    codes = np.array([0, 6, BOTTOM, TOP, LEFT, RIGHT])
    idx = kernel_body_index(codes, n)
    assert idx.tolist() == [0, 6, n + SLOT_BOTTOM, n + SLOT_TOP, n + SLOT_LEFT, n + SLOT_RIGHT]
    assert packing_body_code(idx, n).tolist() == codes.tolist()
