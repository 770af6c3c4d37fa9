"""Map a soft force network onto the contacts of a rigid packing.

Contacts are matched by their bodies (disk indices or wall codes, in either
order) and the periodic image; with a periodic width larger than two disk
diameters a pair of bodies has at most one contact, so the image is checked
through the separation direction (rigid and soft normals must agree).

The soft force vector of a matched contact is expressed on the rigid
contact's own normal and tangent (force on the rigid ``b``), which is what the
force ensemble S of the rigid packing is defined in; for spheres the tangential part
is the vector perpendicular to the rigid normal (ft (Nc, 3)). Rigid contacts the soft
run does not have get zero force ("lost"); soft contacts the rigid packing
does not have are reported with the force they carry ("unmatched"; their
force is absent from the mapped state).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from forcespace import Packing


@dataclass
class MatchResult:
    """fn, ft (Nc_rigid,) [F0]: soft forces on the rigid contacts, rigid frame (ft (Nc, 3)
    for spheres).

    ``soft_index`` (Nc_rigid,) int: matched soft contact or -1.
    ``unmatched``: soft contacts without rigid counterpart, each
    dict(a, b, image, fn, |F|); ``lost``: rigid contacts without soft
    counterpart, dict(k, a, b, image, rigid_fn, rigid_|F|).
    ``fixed``: rigid contacts whose soft force is imposed as a load (top plate),
    matched trivially.
    """

    fn: np.ndarray
    ft: np.ndarray
    soft_index: np.ndarray
    unmatched: list = field(default_factory=list)
    lost: list = field(default_factory=list)

    def summary(self, scale: float = 1.0) -> dict:
        """Counts and largest forces (absolute [F0] and relative to ``scale``)."""
        um = max((u["force"] for u in self.unmatched), default=0.0)
        lo = max((u["rigid_force"] for u in self.lost), default=0.0)
        return {"unmatched_contacts": len(self.unmatched), "lost_contacts": len(self.lost),
                "max_unmatched_force": um, "max_lost_rigid_force": lo,
                "max_unmatched_force_rel": um / scale, "max_lost_rigid_force_rel": lo / scale}


def _key(a, b):
    return (int(a), int(b)) if a <= b else (int(b), int(a))


def match_contacts(rigid: Packing, soft: Packing) -> MatchResult:
    """Match ``soft`` contacts onto ``rigid`` ones (same disk indices required; disks or
    spheres, both of the same kind)."""
    if soft.n_disks != rigid.n_disks:
        raise ValueError(f"soft network has {soft.n_disks} disks, rigid packing {rigid.n_disks}")
    index = {}
    for k in range(soft.n_contacts):
        index.setdefault(_key(soft.a[k], soft.b[k]), []).append(k)
    Fsoft = soft.contact_forces()
    nc = rigid.n_contacts
    spheres = getattr(rigid, "dim", 2) == 3
    fn = np.zeros(nc)
    ft = np.zeros((nc, 3)) if spheres else np.zeros(nc)
    soft_index = -np.ones(nc, dtype=np.int64)
    used = np.zeros(soft.n_contacts, dtype=bool)
    tr = None if spheres else rigid.tangent
    for k in range(nc):
        a, b = rigid.a[k], rigid.b[k]
        best = None
        for q in index.get(_key(a, b), []):
            if used[q]:
                continue
            same = soft.a[q] == a
            nq = soft.normal[q] if same else -soft.normal[q]
            if nq @ rigid.normal[k] > 0.5:          # same periodic image
                best = (q, same)
                break
        if best is None:
            continue
        q, same = best
        F = Fsoft[q] if same else -Fsoft[q]         # force on rigid b
        fn[k] = F @ rigid.normal[k]
        ft[k] = F - fn[k] * rigid.normal[k] if spheres else F @ tr[k]
        soft_index[k] = q
        used[q] = True
    Fr = np.linalg.norm(rigid.contact_forces(), axis=1)
    lost = [{"k": int(k), "a": int(rigid.a[k]), "b": int(rigid.b[k]),
             "image": np.asarray(rigid.image[k]).tolist(), "rigid_fn": float(rigid.fn[k]),
             "rigid_force": float(Fr[k])} for k in np.flatnonzero(soft_index < 0)]
    Fs = np.linalg.norm(Fsoft, axis=1)
    unmatched = [{"q": int(q), "a": int(soft.a[q]), "b": int(soft.b[q]),
                  "image": np.asarray(soft.image[q]).tolist(), "fn": float(soft.fn[q]),
                  "force": float(Fs[q]),
                  "overlap": float(max(0.0, -soft.gap[q]))}
                 for q in np.flatnonzero(~used)]
    return MatchResult(fn, ft, soft_index, unmatched, lost)
