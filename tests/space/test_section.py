"""Cross-sections of S against a hand-derived polytope: two independent grooves."""
import json

import numpy as np
import pytest

import forcespace as fs
from ensemble_cases import groove_interval, grooves
from forcespace.cli import main
from paths import PACKINGS

THETAS, MU = [np.pi / 6, np.pi / 5], 0.3


def test_section_of_two_grooves_is_their_rectangle():
    # S is 2-dimensional, so any plane of its hull is S itself: a rectangle with sides
    # L_k |u_k|, u_k = (dN/ds, 1, dN/ds, -1) per groove, |u_k| = sqrt(2) / cos(theta_k)
    _, prob = grooves(THETAS, MU)
    sec = fs.Section(n=401, seed=3, margin=0.1).compute(prob)
    area = np.prod([np.subtract(*groove_interval(th, MU)[::-1]) * np.sqrt(2) / np.cos(th)
                    for th in THETAS])
    box = np.ptp(sec.s) * np.ptp(sec.t)
    cell = box / (sec.s.size - 1) / (sec.t.size - 1)
    assert sec.inside_fraction * box == pytest.approx(area, rel=0.02)
    assert cell < 1e-4 * area
    # inside means in S, outside means not (equilibrium holds on the whole plane)
    S_, T_ = np.meshgrid(sec.s, sec.t)
    rng = np.random.default_rng(0)
    for i, j in rng.integers(0, sec.s.size, size=(60, 2)):
        x = sec.x0 + S_[i, j] * sec.d1 + T_[i, j] * sec.d2
        assert (prob.violation(x) <= 1e-9) == (sec.violation[i, j] == 0.0)
    assert sec.violation.max() > 0 and sec.s_range[0] <= 0 <= sec.s_range[1]
    # the figure says that white is S (exactly the cells of zero violation: NaN, undrawn)
    ax = sec.plot()
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any(label.startswith("$S$ (white") for label in labels)
    mesh = ax.collections[0].get_array()
    assert np.ma.count_masked(mesh) == np.count_nonzero(sec.violation == 0.0) > 0


def test_section_cli_and_refusals(tmp_path, capsys):
    p = fs.read_packing(PACKINGS / "paper_mu0.1.h5")
    fs.write_packing(p, tmp_path / "p.h5")
    assert main(["section", str(tmp_path / "p.h5"), "-n", "41", "-o", str(tmp_path / "s.png"),
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    # the jammed network is in S, to its solver's accuracy
    assert 0 < out["inside_fraction"] < 1 and out["jammed_state_violation"] <= 1e-9
    assert (tmp_path / "s.png").is_file() and (tmp_path / "s.pdf").is_file()
    _, prob = grooves([THETAS[0]], MU)                  # dim S = 1: no plane
    with pytest.raises(fs.InputError, match="dim S"):
        fs.Section().compute(prob)


def test_where_x0_sits_in_the_section_of_two_grooves():
    # the rectangle's sides are L_k |u_k| (above): from its Chebyshev centre the nearest
    # edge is half the shorter side away (= the Chebyshev radius); from a point on the
    # edge, nothing; the ratio to the section's extent is at most 1/2
    _, prob = grooves(THETAS, MU)
    sides = [np.subtract(*groove_interval(th, MU)[::-1]) * np.sqrt(2) / np.cos(th)
             for th in THETAS]
    an = fs.ForceSpace().compute(prob)
    sec = fs.Section(n=3, seed=3).compute(prob, x0=an.centre, analysis=an)
    assert sec.x0_edge_distance == pytest.approx(min(sides) / 2, rel=1e-6)
    assert sec.x0_edge_distance == pytest.approx(an.radius, rel=1e-6)
    assert 0 < sec.x0_edge_ratio <= 0.5
    on_edge = sec.x0 + sec.s_range[1] * sec.d1              # the plane's extreme along d1
    edge = fs.Section(n=3, seed=3).compute(prob, x0=on_edge, analysis=an)
    assert edge.x0_edge_distance < 1e-9 * min(sides) and edge.x0_edge_ratio < 1e-9
