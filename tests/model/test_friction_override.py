"""A frictionless packing analysed and sampled with friction switched on (the paper's squares)."""
import json
from paths import PACKINGS

import numpy as np

from forcespace.sampling.diagnostics import read_ensemble
from forcespace.cli import main
from forcespace.io.packing_file import read_packing
from forcespace.space.force_space import ForceSpace
from forcespace.model.problem import slice_problem

PACK0 = PACKINGS / "paper_mu0.h5"


def test_friction_switched_on_opens_S_around_the_frictionless_jammed_state(capsys):
    p = read_packing(PACK0)
    plain = ForceSpace(ranges=False).compute(slice_problem(p, 28.0))
    assert plain.dim == 0
    prob = slice_problem(p, 28.0, mu=0.1)
    assert np.all(prob.mu == 0.1) and prob.meta["mu_override"] == 0.1
    an = ForceSpace(ranges=False).compute(prob)
    assert an.feasible and an.bounded and an.dim > 0
    # the frictionless network (ft = 0) stays admissible with friction
    assert prob.violation(prob.x_jammed) <= 1e-9
    # every ft becomes an unknown; the frictionless state (fn > 0, ft = 0) is strictly
    # inside every Coulomb cone, so no inequality is tight on all of S: dim S = 2m - rank A
    assert an.degree_of_indeterminacy == 2 * prob.n_contacts - an.rank_A
    assert an.dim == an.degree_of_indeterminacy and an.n_sliding == 0
    assert main(["analyze", str(PACK0), "--mu", "0.1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["dim_S"] == an.dim and out["mu_override"] == 0.1 and out["packing_mu"] == 0.0
    assert main(["analyze", str(PACK0), "--mu", "-1"]) == 2


def test_sampling_with_friction_switched_on_is_recorded(tmp_path, capsys):
    ens = tmp_path / "e.h5"
    assert main(["sample", str(PACK0), "--mu", "0.05", "--sampler", "hit-and-run", "-n", "8",
                 "--thin", "5", "--burn-in", "20", "-o", str(ens), "--quiet"]) == 0
    e = read_ensemble(ens)
    assert e.attrs["mu_override"] == 0.05 and np.all(e.mu == 0.05)
    assert main(["ensemble", str(ens), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["mu_override"] == 0.05 and out["eta"] > 1e-6
    # the same file without the override is another run: refused, not mixed
    assert main(["sample", str(PACK0), "--sampler", "hit-and-run", "-n", "8", "--thin", "5",
                 "--burn-in", "20", "-o", str(ens), "--quiet"]) == 2
