"""The adapters' Python API: documented, options as keywords or a dict, and a distance
verdict at the soft code's own accuracy (what they import of forcespace: the house rules,
tests/test_house_rules.py)."""
import json
import pydoc

import numpy as np
import pytest

import forcespace_adapters as fa
from cases import two_row_packing
from forcespace.errors import InputError
from forcespace.io.packing_file import write_packing



def test_help_documents_the_round_trip_and_every_public_name():
    text = pydoc.render_doc(fa, renderer=pydoc.plaintext)
    for name in fa.__all__:
        assert name in text
    for phrase in ("<Fn>/R", "export(", "run(", "import_run(", "compare(", "verdict"):
        assert phrase in fa.__doc__
    assert "kn" in pydoc.render_doc(fa.LiggghtsOptions, renderer=pydoc.plaintext)


def test_options_as_keywords_or_a_dict(tmp_path):
    p = two_row_packing(3, mu=0.1)
    path = tmp_path / "p.h5"
    write_packing(p, path)
    d1 = fa.export("liggghts", path, tmp_path / "d1", options={"kn": 1e5, "tolerance": 1e-5})
    d2 = fa.export("liggghts", p, tmp_path / "d2", kn=1e5, tolerance=1e-5)
    d3 = fa.export("liggghts", path, tmp_path / "d3", fa.LiggghtsOptions(kn=1e3), kn=1e5,
                   tolerance=1e-5)
    decks = [json.loads((d / "deck.json").read_text()) for d in (d1, d2, d3)]
    for deck in decks:
        assert deck["kn"] == 1e5 and deck["options"]["tolerance"] == 1e-5
        # the unit convention: kn in <Fn>/R, the deck gets kn <Fn> in F0/R
        assert deck["kn_abs"] == pytest.approx(1e5 * p.mean_normal_force(), rel=1e-12)
    assert fa.make_options("pymunk", {"dt": 0.003}, iterations=50).iterations == 50
    with pytest.raises(InputError, match="unknown liggghts option; allowed:.*kn") as exc:
        fa.export("liggghts", path, tmp_path / "d4", options={"kN": 1e5})
    assert exc.value.field == "kN" and not (tmp_path / "d4").exists()
    with pytest.raises(InputError, match=r"must be a number in \[1, 1e12\]") as exc:
        fa.make_options("liggghts", kn=-1.0)
    assert exc.value.field == "kn"
    with pytest.raises(InputError, match="must be a PymunkOptions, a dict"):
        fa.make_options("pymunk", options=[("dt", 1)])


def test_verdict_tells_a_soft_network_inside_S_from_one_outside():
    import forcespace as fs
    from forcespace_adapters.pymunk_sim import simulate
    p = two_row_packing(4, mu=0.1)
    soft, info = simulate(fa.soft_problem(p, top="loads"), fa.PymunkOptions(max_steps=5000))
    c = fa.compare(p, soft, fa.make_problem(p, "loads"))
    v = c["verdict"]
    assert v["inside_S"] and c["relative_distance"] <= 10 * v["accuracy"]
    assert v["overlap_scale"] == pytest.approx(soft.max_overlap() / soft.r.min())
    assert "inside S at the soft code's accuracy" in v["text"]
    # the same network with one contact force doubled is far outside at that accuracy
    bad = soft.with_forces(np.where(np.arange(soft.n_contacts) == 5, 2 * soft.fn, soft.fn),
                           soft.ft)
    c2 = fa.compare(p, bad, fa.make_problem(p, "loads"))
    assert not c2["verdict"]["inside_S"]
    assert c2["relative_distance"] > 10 * c2["verdict"]["accuracy"]
    assert "outside S" in c2["verdict"]["text"]
    assert "stiffer soft run" in c2["verdict"]["text"] and "stiffer" not in v["text"]
    assert isinstance(fs.plate_problem(p), fs.StaticsProblem)
