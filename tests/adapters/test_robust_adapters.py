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
    from forcespace.io.packing_file import read_packing
    assert read_packing(soft, kind="soft_network").meta["packing_fingerprint"] == \
        read_packing(PACK).fingerprint                 # the deck names its packing
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


def test_distance_refuses_a_soft_network_of_another_packing_in_one_line(tmp_path, capsys):
    # distance took a soft network of another packing: with the same number of disks it
    # exited 0 with a distance (1.36, "not inside S"), with another a traceback (issue 48)
    import dataclasses

    import h5py
    from forcespace.io.packing_file import read_packing, write_packing
    from forcespace_adapters.distance import check_made_from
    pack = ROOT / "tests" / "data" / "paper_fast_n100_mu1_seed2.h5"
    rigid = read_packing(pack)
    other_same_n = tmp_path / "mirrored.h5"          # the same disks, mirrored in x
    write_packing(dataclasses.replace(rigid, x=rigid.width - rigid.x), other_same_n)
    other_n = ROOT / "tests" / "data" / "paper_mu1_seed2.h5"
    soft = tmp_path / "sel.h5"
    assert main(["select", str(pack), "--plate", "-o", str(soft)]) == 0
    assert read_packing(soft, kind="soft_network").meta["packing_fingerprint"] == \
        rigid.fingerprint != read_packing(other_same_n).fingerprint
    capsys.readouterr()

    def refused(field):
        for other in (other_same_n, other_n):
            assert main(["distance", str(soft), str(other)]) == 2
            err = capsys.readouterr().err.strip().splitlines()
            assert len(err) == 1 and str(soft) in err[0] and field in err[0], err
            assert "Traceback" not in err[0]
        check_made_from(rigid, read_packing(soft, kind="soft_network"))   # its own passes

    assert main(["distance", str(soft), str(pack), "--json"]) == 0
    capsys.readouterr()
    refused("meta/packing_fingerprint")
    with h5py.File(soft, "r+") as f:     # a file written before the fingerprint was kept:
        del f["meta"].attrs["packing_fingerprint"]     # its disks must be the packing's
    refused(": disks")
