"""The Python API: the README example runs as written; compute objects and results."""
import dataclasses
import re
import subprocess
import sys

import numpy as np
import pytest

import forcespace as fs

from paths import ROOT  # noqa: E402


def test_readme_example_runs_as_written(tmp_path):
    text = (ROOT / "README.md").read_text()
    code = re.search(r"## Python API\s+```python\n(.*?)```", text, re.S).group(1)
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                       text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    dim, eta, rhat = re.search(r"dim S = (\d+), eta = (\S+), R-hat = (\S+)", r.stdout).groups()
    assert int(dim) > 0 and float(eta.rstrip(",")) > 1e-4   # an indeterminate slice, sampled
    assert 0.9 < float(rhat) < 1.2
    assert (tmp_path / "quick_ensemble.png").stat().st_size > 10_000


def test_help_lists_the_public_api():
    import pydoc
    text = pydoc.render_doc(fs, renderer=pydoc.plaintext)
    for name in ("jam", "Packing", "slice_problem", "ForceSpace", "HitAndRun", "RelaxWalk",
                 "Ensemble", "eta", "plot_difference"):
        assert name in text
    for name in fs.__all__:
        assert getattr(fs, name) is not None


def test_packing_from_arrays_matches_the_hand_built_geometry_and_round_trips(tmp_path):
    from ensemble_cases import pyramid
    p, _ = pyramid(3, 0.6)
    q = fs.Packing.from_arrays(p.x, p.y, p.r, p.a, p.b, p.fn, p.ft, y_bottom=0.0,
                               gravity=p.gravity, mu=p.mu, plate_mu=p.plate_mu)
    assert np.allclose(q.normal, p.normal, atol=1e-15) and np.allclose(q.point, p.point)
    assert np.abs(q.gap).max() < 1e-12 and q.equilibrium_residual() < 1e-12
    fs.write_packing(q, tmp_path / "q.h5")
    r = fs.read_packing(tmp_path / "q.h5")
    assert np.array_equal(r.fn, q.fn) and np.array_equal(r.normal, q.normal)
    assert len(repr(r)) < 200
    with pytest.raises(fs.InputError, match="TOP and RIGHT"):
        fs.Packing.from_arrays([0.0], [1.0], [1.0], [0], [-1])   # BOTTOM must be body a


def test_force_space_and_both_samplers_in_memory(tmp_path):
    from ensemble_cases import groove_interval, grooves
    thetas, mu = [np.pi / 6, np.pi / 5], 0.3
    p, prob = grooves(thetas, mu)
    S = fs.ForceSpace(ranges=True)
    assert repr(S) == "ForceSpace(ranges=True, centre=True)"
    with pytest.raises(AttributeError, match="compute"):
        S.dim
    assert S.compute(prob) is S and S.success
    assert S.dim == 2 and S.bounded and len(S.domains) == 2
    assert all(d.elementary for d in S.domains)
    for k, th in enumerate(thetas):       # ft range of each groove by hand
        lo, hi = groove_interval(th, mu)
        assert S.ft_range[2 * k] == pytest.approx([lo, hi], rel=1e-7)
    assert S.contains(S.centre) and S.distance(S.centre).absolute < 1e-12
    for sampler in (fs.HitAndRun(n=40, seed=2), fs.RelaxWalk(n=20, seed=2)):
        before = repr(sampler)
        ens = sampler.compute(prob).ensemble
        assert repr(sampler) == f"{before}: {sampler.n} samples, eta = {ens.eta:.4g}"
        assert isinstance(ens, fs.Ensemble) and ens.forces.shape == (sampler.n, 4, 2)
        assert max(prob.violation(x) for x in ens.samples) <= 1e-9
        assert ens.eta > 0 and "n_samples" in repr(ens)
        assert not list(tmp_path.iterdir())   # nothing written anywhere
    ens = fs.HitAndRun(n=10, seed=2).compute(prob, output=tmp_path / "h.h5").ensemble
    assert (tmp_path / "h.h5").is_file() and ens.n_samples == 10


def test_plots_draw_on_the_callers_axes():
    from matplotlib.figure import Figure
    from ensemble_cases import grooves
    p, prob = grooves([np.pi / 6, np.pi / 5], 0.3)
    S = fs.ForceSpace(ranges=True).compute(prob)
    ax = Figure().add_subplot()
    assert p.plot(ax) is ax and S.plot(p, ax=ax) is ax
    x1, x2 = S.fn_range[:, 0], S.fn_range[:, 1]
    a = np.zeros(prob.n_columns)
    b = np.zeros(prob.n_columns)
    a[0::2], b[0::2] = x1, x2
    assert fs.plot_difference(p, prob, a, b, domains=S.domains, ax=ax) is ax
    assert len(ax.collections) > 3


def test_scale_box_keeps_the_box_shape(tmp_path, capsys):
    from forcespace.cli import main
    sc = fs.load_scene(ROOT / "inputs" / "paper.toml")
    big, what = sc.scaled_to(800)
    assert big["disks.n"] == 800
    assert big["box.width"] == pytest.approx(2 * sc["box.width"])
    assert big["analysis.slice_height"] == pytest.approx(2 * sc["analysis.slice_height"])
    assert "box.width 42 -> 84" in what
    # the same pressure, plate mass per width, physical step and rest criterion
    assert big["plates.top_force"] / big["box.width"] == pytest.approx(
        sc["plates.top_force"] / sc["box.width"])
    assert big["plates.top_mass"] == pytest.approx(2 * sc["plates.top_mass"])
    # dt is in units of sqrt(rho R^3 / F): the physical step is dt / sqrt(F)
    assert big["solver.dt"] / big["plates.top_force"] ** 0.5 == pytest.approx(
        sc["solver.dt"] / sc["plates.top_force"] ** 0.5)
    assert big["jamming.velocity_tol"] == pytest.approx(sc["jamming.velocity_tol"] / 2 ** 0.5)
    assert main(["pack", str(ROOT / "inputs" / "quick.toml"), "--scale-box",
                 "-o", str(tmp_path / "p.h5")]) == 2
    assert "--scale-box" in capsys.readouterr().err


def test_bring_your_own_packing_example_runs_as_written(tmp_path):
    """The README's CSV-pair example, on a frame written from a jammed packing (a window:
    the contacts across its periodic seam left out)."""
    from forcespace.io.readers import write_csv_pair

    from paths import DATA
    text = (ROOT / "README.md").read_text()
    code = re.search(r"## Bring your own packing.*?```python\n(.*?)```", text, re.S).group(1)
    assert len(code.strip().splitlines()) <= 10
    p = fs.read_packing(DATA / "paper_mu1_seed2.h5")
    write_csv_pair(p, tmp_path)
    lines = (tmp_path / "contacts.csv").read_text().splitlines()
    (tmp_path / "contacts.csv").write_text("\n".join(
        [lines[0]] + [ln for ln in lines[1:] if ln.endswith(",0")]) + "\n")
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                       text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    out = r.stdout.splitlines()
    assert out[0].startswith("S empty:") and "dim S =" in out[0]
    assert len(out) > 50                        # one line per region contact


def test_the_api_checks_what_it_is_handed_at_its_door():
    """Misuses that drew or answered without a word (issue 47): another packing's ensemble
    drawn onto the wrong contacts, plot values of the wrong length, a "section" along
    identical or zero directions, a problem whose mu was set to NaN after building (dim S
    9 where it is 6, samples without Coulomb cones), wrong shapes that reached numpy deep
    inside. Each is one InputError naming the field."""
    from ensemble_cases import grooves, pyramid
    from forcespace import measures
    p, prob = pyramid(3, 0.6)
    g, gprob = grooves([np.pi / 6, np.pi / 5], 0.3)
    ens = fs.HitAndRun(n=8, seed=1).compute(gprob).ensemble
    S = fs.ForceSpace().compute(prob)
    m2, d = prob.n_columns, S.affine_basis[:, :1]
    misuses = {
        "packing": lambda: ens.plot(p),                       # the grooves' ensemble
        "sample": lambda: ens.plot(g, sample=8),
        "values": lambda: p.plot(values=np.ones(p.n_contacts - 1)),
        "directions": lambda: fs.Section(n=5).compute(prob, directions=np.hstack([d, d])),
        "x0": lambda: fs.Section(n=5).compute(prob, x0=np.zeros(m2 + 2)),
        "x": lambda: S.contains(np.zeros(3)),
        "x1": lambda: measures.difference_field(p, prob, np.ones(3), np.ones(m2)),
    }
    for field, call in misuses.items():
        with pytest.raises(fs.InputError, match=rf"\b{field}\b"):
            call()
    with pytest.raises(fs.InputError, match=r"\bdirections\b"):
        fs.Section(n=5).compute(prob, directions=np.zeros((m2, 2)))
    with pytest.raises(fs.InputError, match=r"\bx0\b"):
        measures.distance_from_centre(ens.samples, np.zeros(3))
    assert ens.plot(g) is not None and ens.plot(g, sample=-1) is not None   # its own: drawn
    dim = S.dim
    prob.mu[:] = np.nan                                       # set after building
    for compute in (fs.ForceSpace().compute, fs.HitAndRun(n=4).compute,
                    fs.BilliardWalk(n=4).compute, fs.RelaxWalk(n=4).compute):
        with pytest.raises(fs.InputError, match=r"\bmu\b.*NaN"):
            compute(prob)
    prob.mu[:] = 0.6                                          # restored in place: S again
    assert fs.ForceSpace().compute(prob).dim == dim
    prob.mu[:] = 0.0                               # changed in place: the S of that mu
    fresh = dataclasses.replace(prob, mu=np.zeros(prob.n_contacts))
    assert fs.ForceSpace().compute(prob).summary() == fs.ForceSpace().compute(fresh).summary()
    assert fs.ForceSpace().compute(prob).summary() != S.summary()
