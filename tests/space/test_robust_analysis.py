"""The exact analysis of S on packings off the seed-1 path: force scale, mu = 0, round-off."""
import dataclasses
import json

import numpy as np
import pytest

from ensemble_cases import lattice_rows, pyramid
from forcespace.space.structure import domains
from forcespace.cli import main
from forcespace.io.packing_file import read_packing
from forcespace.space.force_space import ForceSpace
from forcespace.space.questions import check_bounded, check_feasible
from forcespace.space.projection import distance_to_S
from forcespace.model.problem import build_problem, full_problem, slice_problem

from paths import DATA, PACKINGS  # noqa: E402


@pytest.mark.parametrize("scale", [1e-12, 1e-6, 1e6, 1e12])
def test_analysis_is_invariant_under_the_force_scale(scale):
    # lattice rows with friction: dim S = 21 at W = 1; HiGHS' absolute tolerances once
    # gave dim S = 0 at W = 1e-12 and an infeasible LP at W = 1e12
    p, ref_prob = lattice_rows(4, 3, 0.3, W=1.0)
    q = dataclasses.replace(p, gravity=p.gravity * scale, fn=p.fn * scale, ft=p.ft * scale)
    sup = np.zeros(p.n_disks, bool)
    sup[:5] = True                                # the fixed support row of lattice_rows(4, .)
    prob = build_problem(q, ~sup, (), "test", support_mask=sup,
                         rattlers=np.zeros(p.n_disks, bool))
    ref, an = ForceSpace(ranges=True).compute(ref_prob), ForceSpace(ranges=True).compute(prob)
    assert ref.dim == 21
    assert (an.feasible, an.bounded, an.dim) == (True, True, 21)
    assert np.array_equal(an.implicit_rows, ref.implicit_rows)
    assert np.array_equal(an.varying, ref.varying)
    assert an.fn_range == pytest.approx(ref.fn_range * scale, rel=1e-7, abs=1e-9 * scale)
    assert an.ft_range == pytest.approx(ref.ft_range * scale, rel=1e-7, abs=1e-9 * scale)
    assert an.radius == pytest.approx(ref.radius * scale, rel=1e-7)
    assert prob.force_scale == pytest.approx(ref_prob.force_scale * scale, rel=1e-12)
    assert an.max_sum_fn == pytest.approx(ref.max_sum_fn * scale, rel=1e-9)
    assert prob.violation(an.centre) <= 1e-9
    feas, x, _ = check_feasible(prob)
    assert feas and prob.violation(x) <= 1e-8
    bounded, msum, _ = check_bounded(prob)
    assert bounded and msum == pytest.approx(ref.max_sum_fn * scale, rel=1e-9)
    # the projection of a kicked network: distance scales, relative distance does not
    kick = np.random.default_rng(0).uniform(-1, 1, prob.n_columns)
    x_ref = ref.centre + 0.3 * ref_prob.force_scale * kick
    d_ref = distance_to_S(ref_prob, x_ref)
    d = distance_to_S(prob, x_ref * scale)
    assert d.absolute == pytest.approx(d_ref.absolute * scale, rel=1e-6)
    assert d.relative == pytest.approx(d_ref.relative, rel=1e-6)


def test_infeasible_diagnosis_reports_imbalances_in_the_callers_units():
    p, ref = lattice_rows(4, 3, 0.3, W=1e-9)
    prob = dataclasses.replace(ref, b=ref.b.copy())
    prob.b[0] += 10 * prob.force_scale          # an extra x load on disk 0 nothing can carry
    an = ForceSpace(ranges=True).compute(prob)
    assert not an.feasible
    diag = an.infeasibility
    assert diag["relative_to_mean_force"] > 1
    assert diag["min_total_imbalance"] == pytest.approx(
        diag["relative_to_mean_force"] * prob.force_scale, rel=1e-9)   # F0, not <Fn>


@pytest.mark.parametrize("path, kind", [
    (PACKINGS / "paper_mu0.h5", "full"),          # seed 1: was called infeasible
    (DATA / "paper_mu0_seed2.h5", "slice"),       # seed 2, 28R slice: was called infeasible
    (DATA / "paper_mu0_seed2.h5", "full"),
    (PACKINGS / "paper_mu0.h5", "slice"),
])
def test_frictionless_packing_in_equilibrium_has_a_nonempty_point_like_S(path, kind):
    p = read_packing(path)
    assert p.equilibrium_residual() < 1e-9
    prob = full_problem(p) if kind == "full" else slice_problem(p, 28.0)
    an = ForceSpace(ranges=True).compute(prob)
    assert an.feasible and an.bounded
    # isostatic: S is the jammed network itself
    assert an.dim == 0 and an.radius == 0.0
    assert np.abs(an.centre - prob.x_jammed).max() <= 1e-8 * prob.force_scale
    assert prob.meta["load_inconsistency"] < 1e-9


def test_loads_only_a_fixed_ft_column_could_carry_are_projected_out():
    # frictionless lattice rows; the top disk is left out, so its contacts are loads. One
    # of them carries ft != 0 (round-off of a frictionless solve, here exaggerated): its
    # torque on an interior disk could be balanced only by ft columns, which are fixed at
    # 0. The load projection must remove that part (and report it), not leave S empty.
    p, _ = lattice_rows(4, 3, 0.0)
    top = int(np.argmax(p.y))
    load = np.flatnonzero((p.a == top) | (p.b == top))
    ft = p.ft.copy()
    ft[load[0]] = 1e-3 * p.mean_normal_force()
    sup = np.zeros(p.n_disks, bool)
    sup[:5] = True
    interior = ~sup
    interior[top] = False
    prob = build_problem(p.with_forces(p.fn, ft), interior, (), "test", support_mask=sup,
                         rattlers=np.zeros(p.n_disks, bool))
    an = ForceSpace(ranges=True).compute(prob)
    assert an.feasible and an.bounded
    assert prob.meta["load_inconsistency"] == pytest.approx(1e-3, rel=0.5)
    assert np.abs(prob.x_jammed[1::2]).max() == 0.0


def test_round_off_couplings_do_not_enlarge_an_elementary_cluster():
    # mu = 1, seed 2, 28R slice: dim S = 1; its circuit is 5 contacts (the LP ranges of all
    # other contacts are below 2e-10 <Fn>); null-space entries of 1e-9 once made it 25-33
    p = read_packing(DATA / "paper_mu1_seed2.h5")
    prob = slice_problem(p, 28.0)
    an = ForceSpace(ranges=True).compute(prob)
    assert an.dim == 1
    width = np.maximum(np.ptp(an.fn_range, axis=1), np.ptp(an.ft_range, axis=1))
    by_lp = np.flatnonzero(width > 1e-6 * prob.force_scale)
    assert by_lp.size == 5
    assert np.array_equal(an.varying_contacts, by_lp)
    doms = domains(prob, an)
    assert len(doms) == 1 and doms[0].elementary and doms[0].dim == 1
    assert np.array_equal(doms[0].contacts, by_lp)


@pytest.mark.parametrize("path", [PACKINGS / "paper_mu0.5.h5", DATA / "paper_mu1_seed2.h5"])
def test_domains_agree_with_the_varying_contacts_and_dim_S(path):
    p = read_packing(path)
    prob = slice_problem(p, 28.0)
    an = ForceSpace(ranges=True).compute(prob)
    doms = domains(prob, an)
    union = np.unique(np.concatenate([d.contacts for d in doms])) if doms else np.zeros(0)
    assert np.array_equal(union, an.varying_contacts)
    assert sum(d.dim for d in doms) == an.dim
    # disjoint domains, and a contact varies iff its LP range exceeds VARY_TOL <Fn>
    assert sum(d.contacts.size for d in doms) == union.size
    width = np.maximum(np.ptp(an.fn_range, axis=1), np.ptp(an.ft_range, axis=1))
    assert np.array_equal(np.flatnonzero(width > 1e-6 * prob.force_scale), union)


def test_analyze_ranges_json_is_strict_json(tmp_path, capsys):
    p, _ = pyramid(3, 0.6)
    from forcespace.io.packing_file import write_packing
    write_packing(p, tmp_path / "p.h5")
    assert main(["analyze", str(tmp_path / "p.h5"), "--full", "--ranges", "--json"]) == 0
    text = capsys.readouterr().out
    out = json.loads(text)
    assert "NaN" not in text and "Infinity" not in text
    fn = np.array(out["fn_range"])
    assert fn.shape == (out["n_contacts"], 2) and (fn[:, 0] <= fn[:, 1] + 1e-12).all()
    assert out["n_thin_directions"] == 0


def test_interior_point_lp_prints_nothing_and_solves():
    # highspy >= 1.12 prints its banner when the first Highs is built, before any option;
    # a study's log and a user's pipe must not carry it. min x + y, x + y >= 1, x = y:
    # the optimum is x = y = 1/2, the only point of the optimal face.
    import subprocess
    import sys
    code = ("import numpy as np\n"
            "from forcespace.space.lp import solve_lp_interior\n"
            "st, x = solve_lp_interior(np.ones(2), np.array([[-1.0, -1.0]]), np.array([-1.0]),"
            " np.array([[1.0, -1.0]]), np.zeros(1), np.zeros(2), np.full(2, np.inf))\n"
            "import sys; sys.stderr.write(f'{st} {x[0]:.9f} {x[1]:.9f}')\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert run.stdout == ""
    st, x0, x1 = run.stderr.split()[-3:]
    assert st == "0" and abs(float(x0) - 0.5) < 1e-7 and abs(float(x1) - 0.5) < 1e-7
