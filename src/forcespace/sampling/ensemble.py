"""Ensemble: samples of S of one statics problem, the one result type of every sampler.

Samples are in problem column order (:mod:`forcespace.model.problem`): ``samples[k, 2j]``
is fn and ``samples[k, 2j+1]`` ft of unknown contact j [F0]. An ensemble lives in
memory; :mod:`forcespace.io.ensemble_file` writes and reads it.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import config
from ..measures import distance_from_centre, eta


@dataclass
class Ensemble:
    """Samples of S and where they come from.

    samples (k, 2m) [F0]; chains (k,) the chain that produced each sample;
    violations (k,) the largest violation of S of each sample, / <Fn>; contacts (m,)
    packing contact index of each unknown contact; disks (n,) packing index of each
    interior disk; mu (m,) Coulomb coefficients; x_jammed (2m,) the jammed network
    [F0]; force_scale <Fn> [F0]; sampler ("hit-and-run", "billiard", "relax"); params (the
    sampler's parameters); attrs (provenance: packing_file, scene_name, scene_text,
    problem_kind, slice_height, mu_override, code_version, ...); diagnostics
    (convergence: split R-hat and ESS, per-chain eta, ...; see
    :func:`forcespace.sampling.diagnostics.diagnostics`); status 0 when all samples
    asked for were drawn, 1 when the run stopped at its time cap (``message`` says
    why); path: the file it was read from or written to, or None.
    """

    sampler: str
    samples: np.ndarray
    chains: np.ndarray
    violations: np.ndarray
    contacts: np.ndarray
    disks: np.ndarray
    mu: np.ndarray
    x_jammed: np.ndarray
    force_scale: float
    params: dict = field(default_factory=dict)
    attrs: dict = field(default_factory=dict)
    diagnostics: dict = field(default_factory=dict)
    status: int = 0
    message: str = ""
    path: str | None = None

    @property
    def n_samples(self) -> int:
        return int(self.samples.shape[0])

    @property
    def success(self) -> bool:
        """All the samples asked for were drawn."""
        return self.status == 0

    @property
    def forces(self) -> np.ndarray:
        """Sampled forces (k, m, 2): fn, ft of each unknown contact [F0]."""
        return self.samples.reshape(self.n_samples, -1, 2)

    @property
    def eta(self) -> float:
        """The paper's force ambiguity of the samples (:func:`forcespace.measures.eta`)."""
        return eta(self.samples)

    @property
    def rms_spread(self) -> float:
        """Root-mean-square spread of the samples per contact, / <Fn> (0: S is a point)."""
        _, _, lbar = distance_from_centre(self.samples, self.x_jammed)
        return lbar / (self.force_scale * np.sqrt(max(self.contacts.size, 1)))

    def distances_from_centre(self):
        """(l (k,), l0, lbar) [F0]: distances of the samples and of the jammed state
        from the samples' mean (the paper's Fig. 3)."""
        return distance_from_centre(self.samples, self.x_jammed)

    def plot(self, packing, sample: int = -1, ax=None, **kw):
        """Draw sample ``sample`` (default the last) as the force network of
        ``packing`` (fixed loads keep their values); returns the Axes."""
        from ..plot import plot_packing

        fn = np.array(packing.fn, float)
        ft = np.array(packing.ft, float)
        fn[self.contacts] = self.forces[sample, :, 0]
        ft[self.contacts] = self.forces[sample, :, 1]
        kw.setdefault("title", f"{self.sampler} sample {sample % self.n_samples} of "
                               f"{self.n_samples}")
        return plot_packing(packing, ax, values=fn, **kw)

    def summary(self) -> dict:
        """The numbers ``forcespace ensemble`` prints: provenance, eta, Fig. 3
        distances (no ratio when the samples differ only at the solver's
        accuracy) and the convergence diagnostics."""
        a = self.attrs
        out = {"ensemble": self.path, "sampler": self.sampler, "n_samples": self.n_samples,
               "packing_file": a.get("packing_file"), "scene_name": a.get("scene_name"),
               "problem_kind": a.get("problem_kind"), "mu_override": a.get("mu_override"),
               "slice_height": a.get("slice_height"),
               "n_contacts": int(self.contacts.size), "force_scale": self.force_scale,
               "max_violation": float(self.violations.max(initial=0.0)),
               "max_violation_convention": "max over samples of the largest equilibrium/"
                                           "Coulomb violation divided by <Fn> (jammed mean "
                                           "normal force)",
               "tolerance": a.get("tolerance_description"),
               "forcespace_version": a.get("forcespace_version"), "eta": None}
        if self.n_samples:
            out["eta"] = self.eta
            _, l0, lbar = self.distances_from_centre()
            out["jammed_distance_from_centre"] = l0
            out["mean_sample_distance_from_centre"] = lbar
            rms_spread = lbar / (self.force_scale * np.sqrt(max(self.contacts.size, 1)))
            if rms_spread > config.SPREAD_FLOOR:
                out["jammed_distance_over_mean"] = l0 / lbar
            else:   # a ratio of two round-off numbers means nothing
                out["jammed_distance_over_mean"] = None
                out["jammed_distance_over_mean_reason"] = (
                    f"samples differ only at the solver's accuracy (rms spread "
                    f"{rms_spread:.1e} <Fn> <= {config.SPREAD_FLOOR:g}): S is numerically "
                    "a point")
        out.update(self.diagnostics)
        return out

    def __repr__(self) -> str:
        where = f", path={self.path!r}" if self.path else ""
        return (f"Ensemble(sampler={self.sampler!r}, n_samples={self.n_samples}, "
                f"n_contacts={self.contacts.size}{where})")
