"""The scene schema as data, radius distributions, and scenes refused before any work."""
import json

import numpy as np
import pytest

from forcespace.cli import main
from forcespace.errors import InputError
from forcespace.io.packing_file import read_packing
from forcespace.model.radii import draw_radii, moments, radii
from forcespace.model.setup import Setup
from forcespace.model.scene import SCHEMA, Range, load_scene, schema_table, validate
from paths import PACKINGS, QUICK


def _outside(rng: Range):
    """A value just outside the range (below if bounded below, else above)."""
    if rng.lo is not None:
        return rng.lo if rng.lo_open else (rng.lo - 1 if rng.integer else rng.lo * (1 - 1e-9)
                                           - 1e-300)
    return rng.hi if rng.hi_open else (rng.hi + 1 if rng.integer else rng.hi * (1 + 1e-9))


@pytest.mark.parametrize("key", [k for k, s in SCHEMA.items() if isinstance(s.check, Range)])
def test_every_range_in_the_schema_is_the_one_validation_applies(key):
    spec = SCHEMA[key]
    row = next(r for r in schema_table() if r["key"] == key)
    assert row["range"]["min"] == spec.check.lo and row["range"]["max"] == spec.check.hi
    validate({key: spec.default, "disks.n": 10}, "s.toml")          # the default is allowed
    bad = _outside(spec.check)
    with pytest.raises(InputError, match=key.replace(".", r"\.")) as exc:
        validate({key: bad, "disks.n": 10} if key != "disks.n" else {key: bad}, "s.toml")
    assert spec.check.text in str(exc.value)          # the message quotes the schema's range


def test_schema_command_prints_every_key_from_the_schema(capsys):
    assert main(["scene", "--schema", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [r["key"] for r in out["keys"]] == list(SCHEMA)
    row = {r["key"]: r for r in out["keys"]}["box.initial_packing_fraction"]
    assert row["range"] == {"kind": "range", "min": 0.0, "max": 0.8, "min_open": True,
                            "max_open": True, "integer": False, "text": "in (0, 0.8)",
                            "why": "a loose random start"}
    assert {r["key"]: r for r in out["keys"]}["disks.distribution"]["range"]["choices"] == \
        ["uniform", "bidisperse", "lognormal"]
    assert main(["scene", "--schema"]) == 0
    text = capsys.readouterr().out
    assert "[disks]" in text and "radius_max = 2.0  [R]  allowed: in [disks.radius_min" in text


def test_scene_command_prints_a_bundled_scene_that_loads_back(capsys, tmp_path):
    assert main(["scene", "paper"]) == 0
    f = tmp_path / "mine.toml"
    f.write_text(capsys.readouterr().out)
    assert load_scene(f).values == load_scene("paper").values
    assert main(["scene", "nosuch"]) == 2
    assert "must be a bundled scene" in capsys.readouterr().err


def test_uniform_radii_are_the_same_draws_as_before_distributions():
    sc = load_scene("paper")
    r1, r2 = np.random.default_rng(7), np.random.default_rng(7)
    assert np.array_equal(draw_radii(Setup.from_scene(sc).grains, r1), r2.uniform(1.0, 2.0, 200))
    assert r1.bit_generator.state == r2.bit_generator.state     # the stream goes on alike
    # and the committed seed-1 paper packing has exactly these radii
    p = read_packing(PACKINGS / "paper_mu0.1.h5")
    mine = draw_radii(Setup.from_scene(sc).grains, np.random.default_rng(1))
    assert np.array_equal(np.sort(mine), np.sort(p.r))


def test_bidisperse_and_lognormal_radii():
    r = radii("bidisperse", 101, 1.0, 1.4, small_fraction=0.3)
    assert (r == 1.0).sum() == 30 and (r == 1.4).sum() == 71
    rng = np.random.default_rng(0)
    r = radii("lognormal", 20000, 1.0, 4.0, rng, lognormal_sigma=0.3)
    assert r.min() >= 1.0 and r.max() <= 4.0
    assert np.median(r) == pytest.approx(2.0, rel=0.02)         # sqrt(1 * 4)
    from scipy.stats import truncnorm          # ln r: a normal cut at +-ln(2)/0.3
    c = np.log(2.0) / 0.3
    assert np.log(r).std() == pytest.approx(0.3 * truncnorm(-c, c).std(), rel=0.02)
    assert moments(r)["size_ratio"] <= 4.0


def test_a_bidisperse_scene_jams(tmp_path):
    from forcespace.engine.protocol import build_packing
    sc = load_scene(QUICK).with_overrides(**{"disks.n": 20, "disks.distribution": "bidisperse",
                                             "disks.radius_max": 1.4})
    p = build_packing(sc, show_progress=False)
    assert sorted(set(p.r.tolist())) == [1.0, 1.4] and (p.r == 1.0).sum() == 10
    assert p.equilibrium_residual() < 1e-9


def test_empty_scene_is_refused(tmp_path, capsys):
    for text in ("", "# only a comment\n"):
        f = tmp_path / "empty.toml"
        f.write_text(text)
        assert main(["pack", str(f), "-o", str(tmp_path / "p.h5"), "--quiet"]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "is empty (no key set)" in err
        assert not (tmp_path / "p.h5").exists()


def test_a_nul_in_a_scene_string_is_refused_before_any_work(tmp_path, capsys):
    f = tmp_path / "nul.toml"
    f.write_text('[scene]\nname = "a\\u0000b"\n[disks]\nn = 20\n')
    assert main(["pack", str(f), "-o", str(tmp_path / "p.h5"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "scene.name" in err and "control characters" in err and "Traceback" not in err
    with pytest.raises(InputError, match="scene.description"):
        validate({"scene.description": "x\x00"}, "s")
    validate({"scene.description": "two\nlines\tand a tab"}, "s")   # allowed in free text


@pytest.mark.parametrize("n", ["0", "-5"])
def test_scale_box_with_a_bad_n_is_one_line(tmp_path, capsys, n):
    assert main(["pack", str(QUICK), "-o", str(tmp_path / "p.h5"), "--n", n,
                 "--scale-box"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "disks.n" in err and "must be an integer in [1, " \
        in err and "Traceback" not in err
