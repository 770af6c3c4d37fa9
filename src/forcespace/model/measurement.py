"""What a measured network knows beyond a packing's arrays: which forces are data, how
uncertain they are, which particles sit at the frame's edge, and where it all came from.

A packing made by forcespace's engine has no :class:`Measurement` (``Packing.measurement
is None``): every force is the engine's. A packing read from another code or an
experiment (:mod:`forcespace.io.readers`) carries one:

* ``known`` (Nc,) bool: the contact's force was measured (False: the reader knows the
  contact from the geometry only, e.g. a CSV row with empty fn, ft);
* ``sigma`` (Nc, 2) [F0] or None: the measurement's standard uncertainty of fn and ft
  per contact (e.g. half the difference of PeGS' two estimates of one contact), used to
  weight the nearest admissible network;
* ``boundary`` (n,) bool or None: particles the data itself flags as lying at the edge
  of its frame (the CSV ``boundary`` column, PeGS2's edge flag); the first rim layer;
* ``frame`` (x0, y0, x1, y1) [R] or None: the field of view, when the data gives it
  (else the frame is the disks' bounding box);
* ``provenance``: a JSON-able dict: ``format``, ``files`` (name, sha256, bytes of every
  source file), ``units`` (what one length and one force unit of the packing are),
  ``pixel_scale`` (length units per pixel, for image data), ``conventions`` (the sign
  and frame conventions the reader applied), ``reader`` (forcespace's code version).
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError


@dataclass(frozen=True)
class Measurement:
    """The measured part of a packing's network (module docstring for the fields)."""

    known: np.ndarray
    sigma: np.ndarray | None = None
    boundary: np.ndarray | None = None
    frame: tuple | None = None
    provenance: dict = field(default_factory=dict)

    @property
    def n_unknown(self) -> int:
        """Contacts whose force the data does not give."""
        return int((~np.asarray(self.known, bool)).sum())

    def provenance_json(self) -> str:
        return json.dumps(self.provenance, sort_keys=True)

    def summary(self) -> dict:
        """What ``forcespace info`` and ``check`` print about the measurement."""
        prov = self.provenance
        return {"format": prov.get("format"), "files": [f.get("name") for f in
                                                        prov.get("files", [])],
                "units": prov.get("units"), "pixel_scale": prov.get("pixel_scale"),
                "n_contacts_force_unknown": self.n_unknown,
                "uncertainty_given": self.sigma is not None,
                "boundary_flags_given": self.boundary is not None}


def check_measurement(m: Measurement | None, n: int, nc: int, source="packing"):
    """InputError unless the measurement's arrays fit a packing of n disks and nc contacts
    (shapes, finite non-negative sigma, a finite frame with x0 < x1, y0 < y1)."""
    if m is None:
        return m
    if np.shape(m.known) != (nc,):
        raise InputError(source, "measured/known", f"must have shape ({nc},)",
                         got=np.shape(m.known))
    if m.sigma is not None:
        s = np.asarray(m.sigma, float)
        if s.shape != (nc, 2) or not np.all(np.isfinite(s)) or np.any(s < 0):
            raise InputError(source, "measured/sigma", f"must be finite, >= 0, shape ({nc}, 2) "
                             "[F0] (uncertainty of fn, ft)", got=s.shape)
    if m.boundary is not None and np.shape(m.boundary) != (n,):
        raise InputError(source, "measured/boundary", f"must have shape ({n},)",
                         got=np.shape(m.boundary))
    if m.frame is not None:
        f = np.asarray(m.frame, float)
        if f.shape != (4,) or not np.all(np.isfinite(f)) or f[2] <= f[0] or f[3] <= f[1]:
            raise InputError(source, "measured/frame", "must be finite (x0, y0, x1, y1) with "
                             "x0 < x1 and y0 < y1 [R]", got=tuple(np.ravel(f)))
    return m
