"""Soft runs that stop early say so, and the distance to S is flagged, never silently used."""
import shutil
import subprocess
import sys

import pytest

from forcespace.cli import EXIT_NOT_CONVERGED, main

from paths import ROOT  # noqa: E402
PACK = ROOT / "studies" / "packings" / "paper_mu0.1.h5"


@pytest.mark.external
def test_a_liggghts_run_stopped_at_max_steps_is_flagged_by_run_and_distance(tmp_path, capsys):
    if shutil.which("liggghts") is None:
        pytest.skip("LIGGGHTS not installed (make test installs it)")
    deck = tmp_path / "deck"
    assert main(["export", "liggghts", str(PACK), "-o", str(deck), "--kn", "1e4",
                 "--ramp-steps", "1000", "--max-steps", "2000"]) == 0
    capsys.readouterr()
    assert main(["run", "liggghts", str(deck)]) == EXIT_NOT_CONVERGED
    assert "not converged" in capsys.readouterr().err
    soft = tmp_path / "soft.h5"
    assert main(["import", "liggghts", str(deck), "-o", str(soft)]) == 0
    capsys.readouterr()
    assert main(["distance", str(soft), str(PACK), "--json"]) == EXIT_NOT_CONVERGED
    captured = capsys.readouterr()
    import json
    out = json.loads(captured.out)
    assert out["soft_run_converged"] is False
    assert "max_steps" in out["soft_run_reason"] and "residual" in out["soft_run_reason"]
    assert "not converged" in captured.err


def test_output_into_a_closed_pipe_ends_quietly():
    # `forcespace info --json PACK | head -0`: the reader is gone before the first write
    p = subprocess.Popen([sys.executable, "-m", "forcespace.cli", "info", "--json", str(PACK)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.close()
    err = p.stderr.read().decode()
    assert p.wait(timeout=120) == 0
    assert "Traceback" not in err and "BrokenPipe" not in err
