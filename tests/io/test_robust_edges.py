"""Files edited by hand, broken files and late failures (issue 21): each is one line,
names the file and the field, and comes before any work."""
import shutil

import h5py
import numpy as np
import pytest

from forcespace.cli import main
from forcespace.io import ensemble_file as ef
from paths import DATA

PACK = DATA / "paper_mu1_seed2.h5"


def one_line(capsys):
    err = [x for x in capsys.readouterr().err.strip().splitlines() if x.strip()]
    assert len(err) == 1 and "Traceback" not in err[0], err
    return err[0]


@pytest.fixture(scope="module")
def ensemble_file(tmp_path_factory):
    """A 6-sample hit-and-run file of the 28 R slice of a paper packing (dim S = 1)."""
    d = tmp_path_factory.mktemp("ens")
    path = d / "e.h5"
    assert main(["sample", str(PACK), "--sampler", "hit-and-run", "-n", "6", "-o", str(path),
                 "--quiet", "--checkpoint-every", "3"]) == 0
    return path


def edit(src, dst, how, forge_checksums=False):
    shutil.copy(src, dst)
    with h5py.File(dst, "r+") as f:
        X = f["samples"][()]
        if how == "fn*3,ft+0.5":
            X[2, :, 0] *= 3.0
            X[2, :, 1] += 0.5
        elif how == "negative fn":
            X[2, 5, 0] = -abs(X[2, 5, 0]) - 0.1
        elif how == "every ft*10":
            X[:, :, 1] *= 10.0
        f["samples"][...] = X
        if forge_checksums:        # a careful editor (or an old file): checksums match again
            f["sample_checksum"][...] = ef.sample_checksums(X.reshape(X.shape[0], -1))
    return dst


EDITS = ["fn*3,ft+0.5", "negative fn", "every ft*10"]


@pytest.mark.parametrize("how", EDITS)
def test_ensemble_refuses_a_hand_edited_sample_and_names_it(ensemble_file, tmp_path, capsys,
                                                            how):
    bad = edit(ensemble_file, tmp_path / "bad.h5", how)
    assert main(["ensemble", str(bad), "--json"]) == 2
    line = one_line(capsys)
    first = "samples[0]" if how == "every ft*10" else "samples[2]"
    assert f"{bad}: {first}: was changed after it was written" in line


@pytest.mark.parametrize("forge", [False, True])
@pytest.mark.parametrize("how", EDITS)
def test_sample_refuses_to_resume_onto_a_hand_edited_file(ensemble_file, tmp_path, capsys,
                                                          how, forge):
    bad = edit(ensemble_file, tmp_path / "bad.h5", how, forge_checksums=forge)
    before = bad.read_bytes()
    assert main(["sample", str(PACK), "--sampler", "hit-and-run", "-n", "8", "-o", str(bad),
                 "--quiet"]) == 2
    line = one_line(capsys)
    first = "samples[0]" if how == "every ft*10" else "samples[2]"
    assert f"{bad}: {first}:" in line
    assert ("is not in S of this problem" if forge else "was changed") in line
    assert bad.read_bytes() == before


def test_an_ensemble_file_without_its_checksums_is_refused(ensemble_file, tmp_path, capsys):
    # an edited file whose sample_checksum dataset was deleted passed: eta 0.56, true 0.06
    # (issue 48)
    bad = edit(ensemble_file, tmp_path / "bad.h5", "every ft*10")
    with h5py.File(bad, "r+") as f:
        del f["sample_checksum"]
    before = bad.read_bytes()
    for args in (["ensemble", str(bad), "--json"],
                 ["sample", str(PACK), "--sampler", "hit-and-run", "-n", "8", "-o", str(bad),
                  "--quiet"]):
        assert main(args) == 2
        assert f"{bad}: sample_checksum: missing" in one_line(capsys)
    assert bad.read_bytes() == before
    with h5py.File(bad, "r+") as f:      # any other missing part is named by its name
        del f["sample_chain"]
    assert main(["ensemble", str(bad)]) == 2
    assert f"{bad}: sample_chain: missing" in one_line(capsys)


def test_a_nan_in_the_stored_chain_state_is_the_files_fault(ensemble_file, tmp_path, capsys):
    bad = tmp_path / "nan.h5"
    shutil.copy(ensemble_file, bad)
    with h5py.File(bad, "r+") as f:
        w = f["checkpoint/w"][()]
        w.flat[0] = np.nan
        f["checkpoint/w"][...] = w
    assert main(["sample", str(PACK), "--sampler", "hit-and-run", "-n", "8", "-o", str(bad),
                 "--quiet"]) == 2
    line = one_line(capsys)
    assert f"{bad}: checkpoint/w: must be finite" in line and "violates" not in line


def test_a_packing_with_negated_normal_forces_is_refused_on_read(tmp_path, capsys):
    bad = tmp_path / "neg.h5"
    shutil.copy(PACK, bad)
    with h5py.File(bad, "r+") as f:
        F = f["forces"][()]
        F[:, 0] *= -1
        f["forces"][...] = F
    for cmd in (["info", str(bad)], ["analyze", str(bad)]):
        assert main(cmd) == 2
        line = one_line(capsys)
        assert f"{bad}: forces[" in line and "normal forces must be >= 0" in line


def test_format_version_that_is_not_an_integer_is_one_line(tmp_path, capsys):
    bad = tmp_path / "fv.h5"
    shutil.copy(PACK, bad)
    with h5py.File(bad, "r+") as f:
        f.attrs["format_version"] = "two"
    assert main(["info", str(bad)]) == 2
    assert f"{bad}: format_version = 'two': must be an integer" in one_line(capsys)


@pytest.mark.parametrize("cmd", [["draw", "--difference"], ["section", "-n", "5"], ["draw"]])
def test_a_figure_format_matplotlib_cannot_write_is_refused_before_the_work(
        tmp_path, capsys, monkeypatch, cmd):
    import forcespace.io.packing_file as pf
    monkeypatch.setattr(pf, "read_packing", lambda *a, **k: pytest.fail("worked first"))
    out = tmp_path / "x.h5"
    assert main([cmd[0], str(PACK), *cmd[1:], "-o", str(out)]) == 2
    line = one_line(capsys)
    assert f"{out}: -o/--output = '.h5': must name a figure file" in line
    assert not out.exists()


def test_no_lock_file_is_left_after_a_successful_run(tmp_path):
    out = tmp_path / "p.h5"
    assert main(["sample", str(PACK), "--sampler", "relax", "-n", "2", "-o", str(out),
                 "--quiet"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.h5"]


def test_locks_are_filelock_not_fcntl():
    """fcntl exists only on POSIX: forcespace must not import it (Windows)."""
    from paths import ROOT
    for d in ("src", "studies", "adapters"):
        for f in (ROOT / d).rglob("*.py"):
            if "out" in f.relative_to(ROOT / d).parts[:1]:
                continue            # studies/out: scratch (e.g. old sources a bench exports)
            assert "import fcntl" not in f.read_text(), f


def test_the_lock_is_exclusive_and_its_file_goes_with_it(tmp_path):
    from forcespace.errors import InputError
    from forcespace.io.outputs import file_lock, output_lock
    out = tmp_path / "x.h5"
    with output_lock(out):
        assert (tmp_path / ".x.h5.lock").exists()
        with pytest.raises(InputError, match="another forcespace process"):
            with output_lock(out):
                pass
    assert not (tmp_path / ".x.h5.lock").exists()
    # a waiter blocked on the file while it is removed starts over on a new one, and
    # gets the lock only after the holder is done
    import threading
    import time
    order = []
    lock = tmp_path / ".y.lock"

    def waiter():
        with file_lock(lock):
            order.append("waiter")
            time.sleep(0.1)
    with file_lock(lock):
        t = threading.Thread(target=waiter)
        t.start()
        time.sleep(0.3)
        order.append("holder")
    t.join(10)
    assert order == ["holder", "waiter"]
    assert not lock.exists()
