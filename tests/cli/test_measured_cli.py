"""``forcespace convert`` and ``forcespace check`` through the command line: a CSV pair to
a packing file with provenance, the check's strict JSON and figure, one-line bad inputs."""
import json

import numpy as np
import pytest

import forcespace as fs
from forcespace import cli
from forcespace.io.readers import write_csv_pair, write_pegs2

from paths import DATA


@pytest.fixture(scope="module")
def frame(tmp_path_factory):
    d = tmp_path_factory.mktemp("frame")
    p = fs.read_packing(DATA / "paper_mu1_seed2.h5")
    write_csv_pair(p, d)
    return d, p


def test_convert_then_check(frame, capsys, tmp_path):
    d, p = frame
    out = tmp_path / "frame.h5"
    assert cli.main(["convert", "csv", str(d / "particles.csv"), str(d / "contacts.csv"),
                     "--mu", "1", "--width", repr(p.width), "--length-unit", "mm",
                     "--force-unit", "N", "-o", str(out)]) == 0
    capsys.readouterr()
    assert cli.main(["check", str(out), "--region", "slice=28", "--json", "--quiet",
                     "--figure", str(tmp_path / "check.png")]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["feasible"] and doc["dim"] == 1 and doc["distance"] < 1e-9
    assert doc["fraction_inside_ranges"] == 1.0 and doc["n_coulomb_violations"] == 0
    assert doc["measurement"]["format"] == "csv pair"
    assert doc["measurement"]["units"] == {"length": "mm", "force": "N"}
    row = doc["contacts"][0]
    assert row["fn_min"] <= row["fn"] <= row["fn_max"] and row["inside"]
    assert (tmp_path / "check.png").stat().st_size > 0 and (tmp_path / "check.pdf").exists()


def test_convert_pegs2_frame(frame, capsys, tmp_path):
    """PeGS2's own files (adjacency list, particle positions) through `convert pegs2`: the
    frame's contacts not across the periodic seam, the pixel scale in the provenance."""
    _, p = frame
    written = write_pegs2(p, tmp_path / "pegs2", pixel_scale=0.05, frame=3)
    files = written["paths"]
    out = tmp_path / "frame.h5"
    assert cli.main(["convert", "pegs2", str(files["adjacency"]), str(files["positions"]),
                     "--pixel-scale", "0.05", "--frame", "3", "--mu", "1", "-o",
                     str(out)]) == 0
    assert "from pegs2" in capsys.readouterr().out
    q = fs.read_packing(out)
    assert q.n_contacts == p.n_contacts - written["left_out"].size
    assert q.measurement.provenance["pixel_scale"] == 0.05


def test_check_an_engine_packing(capsys):
    assert cli.main(["check", str(DATA / "paper_mu1_seed2.h5"), "--region", "slice=28",
                     "--no-ranges", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "dim: 1" in out and "feasible: True" in out


@pytest.mark.parametrize("argv, fragment", [
    (["convert", "csv", "nope.csv", "nope2.csv", "--mu", "1", "-o", "x.h5"], "does not exist"),
    (["convert", "pegs2", "adj.txt", "pos.txt", "--mu", "1", "--pixel-scale", "0.1", "-o",
      "x.h5"], "does not exist"),
    (["check", "nope.h5"], "does not exist"),
    (["check", str(DATA / "paper_mu1_seed2.h5"), "--region", "ring=3"], "--region"),
    (["check", str(DATA / "paper_mu1_seed2.h5"), "--wall-mu", "0.3"], "needs --walls unknown"),
    (["check", str(DATA / "paper_mu1_seed2.h5"), "--weighted"], "uncertainty"),
])
def test_bad_input_exit_2_one_line(argv, fragment, capsys):
    assert cli.main(argv) == cli.EXIT_INPUT
    err = capsys.readouterr().err.strip()
    assert fragment in err and "\n" not in err and "Traceback" not in err


def test_noisy_frame_reports_empty_S(frame, capsys, tmp_path):
    d, p = frame
    rng = np.random.default_rng(2)
    s = p.mean_normal_force()
    q = p.with_forces(p.fn + (p.fn > 0) * 0.05 * s * rng.standard_normal(p.n_contacts), p.ft)
    write_csv_pair(q, tmp_path)
    out = tmp_path / "noisy.h5"
    assert cli.main(["convert", "csv", str(tmp_path / "particles.csv"),
                     str(tmp_path / "contacts.csv"), "--mu", "1", "--width", repr(p.width),
                     "-o", str(out)]) == 0
    capsys.readouterr()
    assert cli.main(["check", str(out), "--region", "slice=28", "--json", "--quiet"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["feasible"] is False and doc["relaxation_total"] > 0 and doc["relaxation"]
    assert doc["loads"] == "adjusted" and doc["distance"] > 0
