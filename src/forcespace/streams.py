"""Every random stream of forcespace, derived from a seed in this one place.

Nothing else in :mod:`forcespace` seeds a generator (a test walks the sources). The
derivations are the historical ones, kept bit for bit: every packing, sample stream and
section made so far is reproducible from its seed.

The engine (the scene seed):

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

Sampling and the analysis of S (the run's ``seed``):

* **hit-and-run and billiard chains** -- :func:`chain_states`: chain c walks with the
  xoshiro256** state ``SeedSequence(seed).spawn(chains)[c].generate_state(4, uint64)``
  (the generator itself: :mod:`forcespace.sampling.xoshiro`).
* **billiard starts** -- :func:`start_generator`: the chains' dispersed starting
  directions, ``default_rng(SeedSequence([seed, 0x57A7]))``.
* **relax-walk kicks** -- :func:`chain_generators`: one chain: ``default_rng(seed)``;
  more: ``default_rng`` of each of ``SeedSequence(seed).spawn(chains)``.
* **tracked projections** -- :func:`projection_generator`: the random directions the
  convergence diagnostics project samples on, ``default_rng(SeedSequence([seed,
  0x5EED]))`` (the same for every run and sampler at seed 0).
* **random directions of S** -- :func:`direction_generator`: ``default_rng(seed)``, the
  Fig. 3 section's plane and the generic combination of null vectors that finds the
  contacts varying in S.
"""
from __future__ import annotations

import numpy as np

from .kernels import kernel

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


# ---- sampling and the analysis of S ------------------------------------------------------

def chain_states(seed: int, n_chains: int) -> np.ndarray:
    """Independent xoshiro256 states (n_chains, 4) uint64 of hit-and-run's chains."""
    ss = np.random.SeedSequence(seed)
    return np.array([c.generate_state(4, dtype=np.uint64) for c in ss.spawn(n_chains)],
                    dtype=np.uint64)


def chain_generators(seed: int, n_chains: int) -> list:
    """The relax walk's kick generators, one per chain (one chain: ``default_rng(seed)``,
    the stream of every single-chain walk made so far)."""
    if n_chains == 1:
        return [np.random.default_rng(seed)]
    return [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(n_chains)]


def restored_generator(state: dict) -> np.random.Generator:
    """A PCG64 generator continuing from a saved ``bit_generator.state``."""
    g = np.random.default_rng()
    g.bit_generator.state = state
    return g


def start_generator(seed: int) -> np.random.Generator:
    """The generator of the billiard chains' dispersed starting directions."""
    return np.random.default_rng(np.random.SeedSequence([seed, 0x57A7]))


def projection_generator(seed: int) -> np.random.Generator:
    """The generator of the diagnostics' tracked random projections."""
    return np.random.default_rng(np.random.SeedSequence([seed, 0x5EED]))


def direction_generator(seed: int) -> np.random.Generator:
    """The generator of random directions in S (sections, generic null combinations)."""
    return np.random.default_rng(seed)
