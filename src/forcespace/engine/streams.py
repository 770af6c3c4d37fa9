"""Every random stream of the engine, derived from the scene seed in this one place.

Nothing else in :mod:`forcespace.engine` seeds a generator. The derivations are the
historical ones, kept bit for bit (every packing made so far is reproducible):

* **placement** -- :func:`placement_rng`: ``numpy.random.default_rng(seed)`` (PCG64)
  draws, in this order, the radii (uniform in [radius_min, radius_max], n values), the
  random sequential placement (x then y per attempt, largest disk first) and, for
  ``disks.density_ratio`` > 1, the log-uniform densities (n values).
* **window** -- :func:`window_seed`: the compression runs windows of
  ``jamming.window`` steps; the window that starts after ``steps`` steps has the
  seed ``seed + steps``.
* **step** -- :func:`step_seed` (numba): step s of a window (s = 0, 1, ...) sweeps
  with the seed ``(window_seed + 7919 s) mod (2^31 - 1)``.
* **relaxation chunk** -- :func:`chunk_seed`: a frozen-network relaxation (the static
  solve, the relax walk) runs chunks of sweeps; the chunk that starts after ``sweeps``
  sweeps has the seed ``(seed * 1000003 + sweeps) mod (2^31 - 1)``.
* **sweep order** -- :func:`order_state` (numba): a solve's seed becomes the state
  ``seed * 0x9E3779B97F4A7C15 + 0x632BE59BD9B4E019`` (mod 2^64) of a xorshift64*
  generator (:func:`next_state`) that shuffles the contact (or run) order before
  every sweep (Fisher-Yates).

The static solve and the push use the scene seed as their relaxation seed.
"""
from __future__ import annotations

import numpy as np

from ..kernels import kernel

SEED_MODULUS = 2**31 - 1       # step and chunk seeds are reduced modulo this prime
STEP_STRIDE = 7919             # seed distance of consecutive steps of a window
CHUNK_STRIDE = 1_000_003       # seed multiplier of a relaxation's chunks


def placement_rng(seed: int) -> np.random.Generator:
    """The generator of radii, start positions and densities (PCG64 seeded by ``seed``)."""
    return np.random.default_rng(seed)


def window_seed(seed: int, steps_done: int) -> int:
    """Seed of the compression window that starts after ``steps_done`` steps."""
    return seed + steps_done


@kernel(inline="always")
def step_seed(window: int, step: int) -> int:
    """Sweep-order seed of step ``step`` (0-based) of the window seeded ``window``."""
    return (window + STEP_STRIDE * step) % SEED_MODULUS


def chunk_seed(seed: int, sweeps_done: int) -> int:
    """Sweep-order seed of the relaxation chunk that starts after ``sweeps_done`` sweeps."""
    return (seed * CHUNK_STRIDE + sweeps_done) % SEED_MODULUS


@kernel(inline="always")
def order_state(seed):
    """Initial xorshift64* state (uint64) of a solve seeded ``seed`` (>= 0)."""
    return np.uint64(seed) * np.uint64(0x9E3779B97F4A7C15) + np.uint64(0x632BE59BD9B4E019)


@kernel(inline="always")
def next_state(state):
    """One xorshift64 step of the state (uint64)."""
    state ^= state >> np.uint64(12)
    state ^= state << np.uint64(25)
    state ^= state >> np.uint64(27)
    return state


@kernel(inline="always")
def draw_below(state, m):
    """A number in [0, m) from the (already advanced) state: the xorshift64* output's
    high bits modulo m."""
    x = (state * np.uint64(0x2545F4914F6CDD1D)) >> np.uint64(33)   # < 2^31
    if m <= 2147483647:      # the same remainder by a 32-bit division (several x faster)
        return np.int64(np.uint32(x) % np.uint32(m))
    return np.int64(x) % m


@kernel(inline="always")
def shuffle(order, m, state):
    """Fisher-Yates shuffle of order[:m] in place; returns the new state."""
    for s in range(m - 1, 0, -1):
        state = next_state(state)
        q = draw_below(state, s + 1)
        tmp = order[s]
        order[s] = order[q]
        order[q] = tmp
    return state
