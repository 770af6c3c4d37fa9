"""Walls: their codes in a packing, their slots in the engine's body arrays, their friction.

A packing names bodies by index: disks 0..n-1, walls by negative codes
``BOTTOM`` (-1, fixed lower plate), ``TOP`` (-2, load-controlled upper plate),
``LEFT`` (-3) and ``RIGHT`` (-4) (side walls, only without periodic x), and
``WALL`` (-5): a wall of a measured frame (an experiment's boundary: an annulus, a
tilted wall, a biaxial cell), with any normal, stored per contact. The engine never
makes ``WALL`` contacts; its kernels know the first four only.
The engine's kernels keep walls after the disks in the same body arrays:
wall code c sits at kernel index ``n - c - 1``, i.e. slot ``n + SLOT_*``.

Wall contacts have a fixed orientation: BOTTOM and LEFT are body ``a``,
TOP and RIGHT body ``b``; normals (0, 1) for the plates, (1, 0) for the
side walls. ``WALL`` is body ``a`` and its contact's normal (any unit vector) points
from the wall into the disk.

Friction rule (the only place it is written): a contact with a wall has
the disk-wall coefficient ``plate_mu``, every other contact the disk-disk
coefficient ``mu``.
"""
from __future__ import annotations

import numpy as np
from ..kernels import kernel

BOTTOM, TOP, LEFT, RIGHT, WALL = -1, -2, -3, -4, -5
WALL_NAMES = {BOTTOM: "bottom", TOP: "top", LEFT: "left", RIGHT: "right", WALL: "wall"}
WALL_CODES = (BOTTOM, TOP, LEFT, RIGHT, WALL)

N_WALL_SLOTS = 4
SLOT_BOTTOM, SLOT_TOP, SLOT_LEFT, SLOT_RIGHT = 0, 1, 2, 3


def kernel_body_index(body, n):
    """Packing body indices (disks >= 0, wall codes -1..-4) -> kernel body indices
    (disks, then wall slot n + SLOT_*): wall code c sits at n - c - 1."""
    body = np.asarray(body, np.int64)
    return np.where(body >= 0, body, n - body - 1)


def packing_body_code(index, n):
    """Kernel body indices -> packing body indices (the inverse of kernel_body_index)."""
    index = np.asarray(index, np.int64)
    return np.where(index < n, index, n - index - 1)


@kernel
def contact_mu(touches_wall, mu_disk, mu_wall):
    """Coulomb coefficient of a contact: ``mu_wall`` if it touches a wall, else
    ``mu_disk`` (numba- and numpy-callable on scalars)."""
    return mu_wall if touches_wall else mu_disk


def contact_mu_array(a, b, mu_disk, mu_wall, is_wall=None):
    """Per-contact Coulomb coefficients (Nc,) for packing body indices a, b (Nc,)
    (walls negative), by the rule of :func:`contact_mu`. ``is_wall`` (Nc,) bool
    overrides which contacts count as wall contacts."""
    a = np.asarray(a)
    b = np.asarray(b)
    wall = (a < 0) | (b < 0) if is_wall is None else np.asarray(is_wall, bool)
    return np.where(wall, float(mu_wall), float(mu_disk))
