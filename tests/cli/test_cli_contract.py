"""The command line's contract: exit codes and strict JSON."""
import json

import numpy as np

from forcespace import cli
from forcespace.errors import InputError, NumericalError


def _run_with(exc, capsys):
    def boom(args):
        raise exc
    parser = cli.build_parser
    try:
        cli.build_parser = lambda: _FakeParser(boom)
        return cli.main([])
    finally:
        cli.build_parser = parser


class _FakeParser:
    def __init__(self, func):
        self.func = func

    def parse_args(self, argv):
        import argparse
        return argparse.Namespace(func=self.func, command="fake")


def test_exit_codes_distinguish_bad_input_from_non_convergence(capsys):
    assert _run_with(InputError("a.toml", "disks.n", "must be >= 1", got=0), capsys) \
        == cli.EXIT_INPUT == 2
    err = capsys.readouterr().err
    assert "a.toml: disks.n = 0: must be >= 1" in err and "Traceback" not in err
    assert _run_with(NumericalError("relaxation stalled"), capsys) \
        == cli.EXIT_NOT_CONVERGED == 3
    assert "not converged: relaxation stalled" in capsys.readouterr().err


def test_json_is_strict_nan_and_inf_become_null(capsys):
    cli.print_json({"a": float("nan"), "b": np.array([1.0, np.inf]), "c": np.float64(2.5),
                    "d": np.int64(3), "e": [np.nan, {"f": -np.inf}], "g": None})
    out = capsys.readouterr().out
    assert "NaN" not in out and "Infinity" not in out
    assert json.loads(out) == {"a": None, "b": [1.0, None], "c": 2.5, "d": 3,
                               "e": [None, {"f": None}], "g": None}


def test_commands_run_with_one_blas_thread_unless_the_environment_sets_a_count(monkeypatch):
    """The same command gives the same numbers whatever the machine's core count (the MVE
    rounding's branch once followed the sign of a 1e-19 slack that flipped with it), and
    an explicit OMP_NUM_THREADS is honoured."""
    from threadpoolctl import threadpool_info, threadpool_limits

    def blas_threads_in_command():
        seen = []
        parser = cli.build_parser
        try:
            cli.build_parser = lambda: _FakeParser(lambda args: seen.append(
                {i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}))
            assert cli.main([]) == 0
        finally:
            cli.build_parser = parser
        return seen[0]
    for v in cli.BLAS_THREAD_VARIABLES:
        monkeypatch.delenv(v, raising=False)
    with threadpool_limits(limits=2, user_api="blas"):
        assert blas_threads_in_command() == {1}
        monkeypatch.setenv("OMP_NUM_THREADS", "2")
        assert blas_threads_in_command() == {2}


def test_dimensioned_numbers_carry_their_units(tmp_path, capsys):
    """issue 47: info/analyze --json gave centre_radius, max_sum_fn, force_scale, ... with
    no unit. A "units" entry names each; the plain output shows it beside the number."""
    from ensemble_cases import pyramid
    from forcespace.io.packing_file import write_packing

    p, _ = pyramid(3, 0.6)
    write_packing(p, tmp_path / "p.h5")
    assert cli.main(["info", str(tmp_path / "p.h5"), "--json"]) == 0
    units = json.loads(capsys.readouterr().out)["units"]
    assert {units[k] for k in ("width", "max_overlap")} == {"R"}
    assert units["mean_normal_force"] == "F0"
    assert cli.main(["analyze", str(tmp_path / "p.h5"), "--full", "--json", "--quiet"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["units"]["max_sum_fn"] == "F0" and out["units"]["centre_radius"].startswith("F0")
    assert out["units"]["force_scale"].startswith("F0") and out["units"]["slice_height"] == "R"
    assert all(k in out or "." in k or k.endswith("_range") for k in out["units"])
    assert cli.main(["analyze", str(tmp_path / "p.h5"), "--full", "--quiet"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert any(line.strip().startswith("max_sum_fn:") and line.endswith("[F0]")
               for line in lines)
    assert not any(line.strip().startswith("units:") for line in lines)


def test_a_target_ess_run_says_it_converged_and_its_bar_ends_full(tmp_path, capsys):
    """issue 47: `sample --target-ess` never said whether it converged, and its bar stopped
    at 400/100000 (<33:10) after convergence."""
    from ensemble_cases import pyramid
    from forcespace.io.packing_file import write_packing

    p, _ = pyramid(3, 0.6)
    write_packing(p, tmp_path / "p.h5")
    assert cli.main(["sample", str(tmp_path / "p.h5"), "--full", "--sampler", "billiard",
                     "-n", "20000", "--target-ess", "50", "-o", str(tmp_path / "e.h5")]) == 0
    err = capsys.readouterr().err
    last = err.replace("\r", "\n").strip().splitlines()
    assert "converged: ESS >= " in last[-1] and "(target 50)" in last[-1]
    n = int(last[-1].split()[0])
    assert n < 20000 and "100%" in last[-2] and f"{n}/{n}" in last[-2]
