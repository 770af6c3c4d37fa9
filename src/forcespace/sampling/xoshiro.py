"""The random numbers of the samplers' kernels: xoshiro256** (Blackman & Vigna), one
state of 4 x uint64 per chain, advanced in place inside numba.

States come from :func:`forcespace.streams.chain_states`, one independent stream per
chain, so a checkpoint of the 4 words resumes a chain exactly. Hit-and-run and the
billiard walk share this generator.
"""
from __future__ import annotations

import numpy as np

from ..kernels import kernel


@kernel
def rotl(x, k):
    return (x << np.uint64(k)) | (x >> np.uint64(64 - k))


@kernel
def next_u64(s):
    """xoshiro256** step on state s (4,) uint64; returns a uint64."""
    result = rotl(s[1] * np.uint64(5), 7) * np.uint64(9)
    t = s[1] << np.uint64(17)
    s[2] ^= s[0]
    s[3] ^= s[1]
    s[1] ^= s[2]
    s[0] ^= s[3]
    s[2] ^= t
    s[3] = rotl(s[3], 45)
    return result


@kernel
def uniform(s):
    """Uniform double in [0, 1)."""
    return float(next_u64(s) >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@kernel
def normal(s):
    """Standard normal (Box-Muller, one of the pair)."""
    u1 = uniform(s)
    while u1 <= 0.0:
        u1 = uniform(s)
    u2 = uniform(s)
    return np.sqrt(-2.0 * np.log(u1)) * np.cos(2.0 * np.pi * u2)


@kernel
def unit_direction(s, u):
    """Fill ``u`` (d,) with a direction uniform on the unit sphere (d normals from state s,
    one at a time, normalised); returns the normals' length |g| (chi with d degrees)."""
    nrm = 0.0
    for i in range(u.shape[0]):
        u[i] = normal(s)
        nrm += u[i] * u[i]
    nrm = np.sqrt(nrm)
    for i in range(u.shape[0]):
        u[i] /= nrm
    return nrm


@kernel
def normals(s, out):
    """Fill ``out`` (n,) with independent standard normals (Box-Muller, both of each
    pair) from state s."""
    n = out.shape[0]
    i = 0
    while i < n:
        u1 = uniform(s)
        while u1 <= 0.0:
            u1 = uniform(s)
        u2 = uniform(s)
        r = np.sqrt(-2.0 * np.log(u1))
        out[i] = r * np.cos(2.0 * np.pi * u2)
        if i + 1 < n:
            out[i + 1] = r * np.sin(2.0 * np.pi * u2)
        i += 2
