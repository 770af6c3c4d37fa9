"""Ensemble: samples of S of one statics problem, the one result type of every sampler.

Samples are in problem column order (:mod:`forcespace.model.problem`): ``samples[k, 2j]``
is fn and ``samples[k, 2j+1]`` ft of unknown contact j [F0] (disks); for spheres
(``per_contact`` = 3, :mod:`forcespace.model.sphere_problem`) ``samples[k, 3j:3j+3]`` are
fn, f1, f2 in the contact's frame. The samplers
(:mod:`forcespace.sampling`) make it and compute its convergence diagnostics (in memory,
and for one read back: :func:`forcespace.sampling.diagnostics.read_ensemble`);
:mod:`forcespace.io.ensemble_file` writes and reads its arrays.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import config
from ..errors import InputError
from ..measures import contact_fluctuations, distance_from_centre, eta


@dataclass
class Ensemble:
    """Samples of S and where they come from.

    samples (k, c m) [F0] (c = ``per_contact``: 2 disks, fn ft; 3 spheres, fn f1 f2); chains (k,) the chain that produced each sample;
    violations (k,) the largest violation of S of each sample, / <Fn>; contacts (m,)
    packing contact index of each unknown contact; disks (n,) packing index of each
    interior disk; mu (m,) Coulomb coefficients; x_jammed (c m,) the jammed network
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
    per_contact: int = 2

    @property
    def n_samples(self) -> int:
        return int(self.samples.shape[0])

    @property
    def success(self) -> bool:
        """All the samples asked for were drawn."""
        return self.status == 0

    @property
    def forces(self) -> np.ndarray:
        """Sampled forces (k, m, c): fn, ft (spheres fn, f1, f2) of each unknown contact
        [F0]."""
        return self.samples.reshape(self.n_samples, -1, self.per_contact)

    @property
    def eta(self) -> float:
        """The paper's force ambiguity of the samples (:func:`forcespace.measures.eta`)."""
        return eta(self.samples, self.per_contact)

    @property
    def rms_spread(self) -> float:
        """Root-mean-square spread of the samples per contact, / <Fn> (0: S is a point)."""
        _, _, lbar = distance_from_centre(self.samples, self.x_jammed)
        return lbar / (self.force_scale * np.sqrt(max(self.contacts.size, 1)))

    def distances_from_centre(self):
        """(l (k,), l0, lbar) [F0]: distances of the samples and of the jammed state
        from the samples' mean (the paper's Fig. 3)."""
        return distance_from_centre(self.samples, self.x_jammed)

    def contact_columns(self, packing) -> dict:
        """fn_mean, ft_mean, fn_std, ft_std, spread [F0] and sampled (0/1), each (Nc,) over
        ``packing``'s contacts: spread is the contact's dF of the paper's eta (sqrt of the
        mean of |F - <F>|^2 over the samples); contacts that are not unknowns of the
        ensemble keep the packing's forces and spread 0. InputError if the ensemble was
        not sampled on this packing (its contacts or jammed forces differ)."""
        p = packing
        k = np.asarray(self.contacts, np.int64)
        src = self.path or "ensemble"
        if k.size and (k.min() < 0 or k.max() >= p.n_contacts):
            raise InputError(src, "problem/contacts", f"refers to contacts outside this "
                             f"packing (0..{p.n_contacts - 1}); the ensemble belongs to "
                             "another packing")
        xj = np.asarray(self.x_jammed, float).reshape(-1, 2)
        scale = max(abs(self.force_scale), 1e-300)
        if k.size and np.abs(xj[:, 0] - p.fn[k]).max() > config.FORCE_MATCH_TOL * scale:
            raise InputError(src, "problem/x_jammed", "does not match this packing's normal "
                             "forces; the ensemble belongs to another packing")
        if self.n_samples == 0:
            raise InputError(src, "samples", "the ensemble has no samples")
        F = self.forces
        fn_mean, ft_mean = p.fn.copy(), p.ft.copy()
        zeros = np.zeros(p.n_contacts)
        fn_std, ft_std, spread = zeros.copy(), zeros.copy(), zeros.copy()
        sampled = np.zeros(p.n_contacts, np.int64)
        fn_mean[k], ft_mean[k] = F[:, :, 0].mean(0), F[:, :, 1].mean(0)
        fn_std[k], ft_std[k] = F[:, :, 0].std(0), F[:, :, 1].std(0)
        spread[k] = contact_fluctuations(self.samples)[0]
        sampled[k] = 1
        return {"fn_mean": fn_mean, "ft_mean": ft_mean, "fn_std": fn_std, "ft_std": ft_std,
                "spread": spread, "sampled": sampled}

    def force_distribution(self, edges=None) -> dict:
        """P(f), f = fn / <Fn> (``force_scale``), of every sampled contact over all the
        samples, beside the jammed network's: {"edges" (b + 1,), "ensemble" (b,),
        "jammed" (b,), "unit", "mean_f_ensemble", "mean_f_jammed"}; default bins 0.1 wide
        from 0 to past the largest force."""
        from ..measures import force_pdf
        fn, fj = self.forces[:, :, 0], self.x_jammed[0::self.per_contact]
        if edges is None:
            top = max(float(fn.max(initial=0.0)), float(fj.max(initial=0.0))) / self.force_scale
            edges = np.arange(0.0, np.floor(top / 0.1) * 0.1 + 0.2, 0.1)
        return {"edges": np.asarray(edges, float), "unit": "f = fn / <Fn> (the jammed mean "
                "normal force of the problem's contacts); density per unit f",
                "ensemble": force_pdf(fn, self.force_scale, edges),
                "jammed": force_pdf(fj, self.force_scale, edges),
                "mean_f_ensemble": float(fn.mean() / self.force_scale),
                "mean_f_jammed": float(fj.mean() / self.force_scale)}

    def eta_interval(self, batches: int = 5, level: float = 0.95) -> dict:
        """eta with its standard error and ``level`` interval from the chains
        (:func:`forcespace.measures.eta_interval`: batch jackknife)."""
        from ..measures import eta_interval
        return eta_interval(self.samples, self.chains, batches, level, self.per_contact)

    def network_measures(self, packing, problem) -> dict:
        """Stress and fabric tensors of the jammed network and over the samples, on the
        interior disks of ``problem`` (the ensemble's own, checked): "stress" [F0/R]
        (:func:`forcespace.measures.stress_tensor`; jammed, mean over the samples, and
        each component's min and max over them) and "fabric" [1] (geometric, of the
        force-bearing contacts, fn > ``config.FORCE_BEARING`` <Fn>; jammed and mean)."""
        from ..measures import fabric_tensor, network_arms_and_forces, region_area, \
            stress_tensor
        self.check_packing(packing, "Ensemble.network_measures")
        if not np.array_equal(problem.contacts, self.contacts):
            raise InputError("Ensemble.network_measures", "problem", "must be the problem "
                             "the ensemble was sampled in (its contacts differ)")
        area = region_area(packing, problem)

        def one(x):
            arms, F, n, fn = network_arms_and_forces(packing, problem, x)
            bearing = fn > config.FORCE_BEARING * self.force_scale
            return stress_tensor(arms, F, area), fabric_tensor(n[bearing])
        jam = one(self.x_jammed)
        each = [one(x) for x in self.samples]
        st = np.array([e[0] for e in each])
        return {"area_R2": area, "stress": {
                    "unit": "F0/R (2-D: force per length; compression < 0)",
                    "jammed": jam[0].tolist(), "mean": st.mean(0).tolist(),
                    "min": st.min(0).tolist(), "max": st.max(0).tolist()},
                "fabric": {"unit": "1 (sum n n / N_c over force-bearing contacts; trace 1)",
                           "jammed": jam[1].tolist(),
                           "mean": np.mean([e[1] for e in each], 0).tolist()}}

    def check_packing(self, packing, who: str = "Ensemble") -> None:
        """InputError unless ``packing`` is the one these samples are of: its contacts
        ``contacts`` exist and carry the jammed forces ``x_jammed`` (another packing's
        ensemble drew its samples onto the wrong contacts)."""
        k = self.contacts
        # spheres: fn (packing ft is a 3-vector, the samples' f1, f2 are in each frame)
        forces = (packing.fn,) if self.per_contact == 3 else (packing.fn, packing.ft)
        same = packing.n_contacts > int(k.max(initial=-1)) and packing.n_disks > \
            int(self.disks.max(initial=-1)) and all(
                np.allclose(np.asarray(f, float)[k], self.x_jammed[c::self.per_contact],
                            rtol=1e-9, atol=1e-12 * self.force_scale)
                for c, f in enumerate(forces))
        if not same:
            raise InputError(who, "packing", "must be the packing the ensemble was sampled "
                             f"from ({self.attrs.get('packing_file') or 'see its attrs'}): "
                             "its contacts' jammed forces differ")

    def plot(self, packing, sample: int | None = None, ax=None, **kw):
        """Draw the ensemble on ``packing`` (its own packing, checked): line width the
        mean normal force of every sampled contact over the samples, colour its standard
        deviation (grey: not sampled, e.g. outside the slice); ``sample=k``: sample k
        alone. Fixed loads keep their values. Returns the Axes."""
        import numbers

        from ..plot import plot_packing

        self.check_packing(packing, "Ensemble.plot")
        fn = np.array(packing.fn, float)
        if sample is None:
            fn[self.contacts] = self.forces[:, :, 0].mean(0)
            spread = np.full_like(fn, np.nan)
            spread[self.contacts] = self.forces[:, :, 0].std(0)
            kw.setdefault("title", f"{self.sampler} ensemble of {self.n_samples} samples: "
                                   r"mean $f_n$ per contact")
            return plot_packing(packing, ax, values=fn, spread=spread, **kw)
        k = self.n_samples
        if isinstance(sample, bool) or not isinstance(sample, numbers.Integral) \
                or not -k <= sample < k:
            raise InputError("Ensemble.plot", "sample", f"must be None (the ensemble) or a "
                             f"sample index in [-{k}, {k - 1}]", got=sample)
        fn[self.contacts] = self.forces[sample, :, 0]
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
        if self.n_samples:
            out["eta_interval"] = self.eta_interval()
            out["force_distribution"] = self.force_distribution()
        out.update(self.diagnostics)
        return out

    def __repr__(self) -> str:
        where = f", path={self.path!r}" if self.path else ""
        return (f"Ensemble(sampler={self.sampler!r}, n_samples={self.n_samples}, "
                f"n_contacts={self.contacts.size}{where})")
