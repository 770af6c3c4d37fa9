"""Options out of range are one line naming the option, before any work (issue 21)."""
import pytest

from forcespace.cli import main
from paths import DATA

PACK = DATA / "paper_mu1_seed2.h5"


@pytest.fixture
def no_work(monkeypatch):
    import forcespace
    import forcespace.io.packing_file as pf
    # forcespace.read_packing is resolved lazily and then kept in the package: resolve it
    # before the patch, or a first use during this test would keep the failing stand-in
    # for every later test of the same process (seen with pytest -n 2)
    forcespace.read_packing
    monkeypatch.setattr(pf, "read_packing", lambda *a, **k: pytest.fail("read before checks"))


@pytest.mark.parametrize("argv, option, words", [
    (["draw", "--difference", "--seed", "-1", "-o", "d.png"], "--seed", "integer in [0,"),
    (["section", "--seed", "-1", "-o", "s.png"], "--seed", "integer in [0,"),
    (["sample", "--sampler", "hit-and-run", "-n", "2", "--seed", "-1", "-o", "e.h5"],
     "--seed", "integer in [0,"),
    (["sample", "--sampler", "relax", "-n", "2", "--seed", "-1", "-o", "e.h5"],
     "--seed", "integer in [0,"),
    (["select", "--kn", "1e308", "-o", "s.h5"], "--kn", "[1e-12, 1e+12]"),
    (["select", "--kt-ratio", "1e-300", "-o", "s.h5"], "--kt-ratio", "[1e-06, 1e+06]"),
    (["analyze", "--mu", "1e300"], "--mu", "[0, 1e+06]"),
    (["analyze", "--gap-tol", "nan"], "--gap-tol", ">= 0"),
    (["analyze", "--gap-tol", "-1"], "--gap-tol", ">= 0"),
    (["sample", "--sampler", "relax", "-n", "2", "--gap-tol", "nan", "-o", "e.h5"],
     "--gap-tol", ">= 0"),
    (["select", "--mu", "1e300", "-o", "s.h5"], "--mu", "[0, 1e+06]"),
    (["draw", "--difference", "--mu", "-1", "-o", "d.png"], "--mu", "[0, 1e+06]"),
])
def test_bad_options_are_one_line_naming_the_option(tmp_path, capsys, no_work, argv, option,
                                                    words):
    assert main([argv[0], str(PACK), *argv[1:]]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0]
    assert f"command line: {option} = " in err[0] and words in err[0]
    assert list(tmp_path.iterdir()) == []


def test_the_library_refuses_them_too():
    from forcespace.errors import InputError
    from forcespace.io.packing_file import read_packing
    from forcespace.model.problem import slice_problem
    p = read_packing(PACK)
    for kw, field in (({"mu": 1e300}, "mu"), ({"gap_tol": float("nan")}, "gap_tol"),
                      ({"gap_tol": -1.0}, "gap_tol")):
        with pytest.raises(InputError, match=f"{PACK}: {field} = "):
            slice_problem(p, 28.0, **kw)


BIG = "99999999999999999999"        # beyond int64


@pytest.mark.parametrize("argv, option, words", [
    # issue 48: --kn 1e308 wrote inf into the deck (exit 0); integers beyond int64 ended
    # in a traceback
    (["export", "liggghts", "--kn", "1e308"], "kn", "[1, 1e12]"),
    (["export", "liggghts", "--tolerance", "1e300"], "tolerance", "(0, 1)"),
    (["export", "liggghts", "--max-steps", BIG], "max_steps", "<= 2147483647"),
    (["export", "liggghts", "--ramp-steps", BIG], "ramp_steps", "<= 2147483647"),
    (["export", "liggghts", "--check-every", BIG], "check_every", "<= 2147483647"),
    (["export", "pymunk", "--iterations", BIG], "iterations", "[1, 2**31 - 1]"),
    (["export", "pymunk", "--max-steps", BIG], "max_steps", "[1, 1e+12]"),
    (["export", "pymunk", "--dt", "1e308"], "dt", "(0, 1e3]"),
])
def test_export_options_out_of_range_are_one_line(tmp_path, capsys, no_work, argv, option,
                                                  words):
    pytest.importorskip("forcespace_adapters")
    assert main([*argv[:2], str(PACK), "-o", str(tmp_path / "d"), *argv[2:]]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0], err
    assert f"command line: {option} = " in err[0] and words in err[0]
    assert list(tmp_path.iterdir()) == []


def test_the_deck_never_holds_a_number_that_is_not_finite(tmp_path):
    pytest.importorskip("forcespace_adapters")
    from forcespace.errors import NumericalError
    from forcespace_adapters import liggghts
    with pytest.raises(NumericalError, match="came out inf"):
        liggghts.deck_number(float("inf"))
    assert liggghts.deck_number(0.1) == "0.1"


@pytest.mark.parametrize("sampler, option, value, field", [
    ("billiard", "-n", "99999999999999999999", "n"),
    ("hit-and-run", "-n", "99999999999999999999", "n"),
    ("relax", "-n", "100000001", "n"),
    ("hit-and-run", "--thin", "1000000000000", "thin"),
    ("hit-and-run", "--burn-in", "1000000000000", "burn_in"),
    ("billiard", "--thin", "1000000000000", "thin"),
    ("billiard", "--burn-in", "1000000000000", "burn_in"),
    ("billiard", "--chains", "1000000000000", "chains"),
    ("relax", "--chains", "1000000000000", "chains"),
])
def test_sampling_budgets_that_would_run_until_killed_are_refused_at_once(
        tmp_path, capsys, no_work, sampler, option, value, field):
    """-n 1e20 or --thin 1e12 ran until killed (issue 47): refused before the packing is
    read, in one line naming the option and its range."""
    argv = ["sample", str(PACK), "--sampler", sampler, "-n", "10", "-o",
            str(tmp_path / "e.h5"), option, value]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"sample: {field} = {value}: must be an integer in [" in err[0]
    assert list(tmp_path.iterdir()) == []
