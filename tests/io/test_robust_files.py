"""No lost data: outputs checked before work, locked, atomic; every file validated on read."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from ensemble_cases import grooves, pyramid
from forcespace.io import ensemble_file as ef
from forcespace.io.ensemble_file import fingerprint, read_file
from forcespace.sampling.diagnostics import read_ensemble
from forcespace.sampling.relax_walk import RelaxWalk
from forcespace.cli import main
from forcespace.io.outputs import output_lock
from forcespace.io.packing_file import write_packing

from paths import ROOT  # noqa: E402
PACK = ROOT / "studies" / "packings" / "paper_mu0.1.h5"


def one_line(capsys):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0], err
    return err[0]


def test_pack_refuses_to_overwrite_its_own_scene(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    shutil.copy(ROOT / "inputs" / "quick.toml", scene)
    before = scene.read_bytes()
    assert main(["pack", str(scene), "-o", str(scene)]) == 2
    assert "is also an input" in one_line(capsys)
    assert scene.read_bytes() == before


@pytest.mark.parametrize("target", ["symlink", "device", "directory", "readonly", "trailing"])
def test_bad_output_targets_are_refused_before_any_work(tmp_path, capsys, monkeypatch, target):
    import forcespace.engine.protocol as jamming
    monkeypatch.setattr(jamming, "build_packing",
                        lambda *a, **k: pytest.fail("simulated before the output was checked"))
    keep = tmp_path / "precious.h5"
    keep.write_text("user data")
    if target == "symlink":
        out = tmp_path / "link.h5"
        out.symlink_to(keep)
    elif target == "device":
        out = Path(os.devnull)
    elif target == "directory":
        out = tmp_path / "adir"
        out.mkdir()
    elif target == "readonly":
        if os.geteuid() == 0:
            pytest.skip("root writes into read-only directories")
        ro = tmp_path / "ro"
        ro.mkdir()
        ro.chmod(0o500)
        out = ro / "p.h5"
    else:
        out = str(tmp_path / "newdir") + os.sep
    assert main(["pack", str(ROOT / "inputs" / "quick.toml"), "-o", str(out), "--quiet"]) == 2
    line = one_line(capsys)
    assert str(out).rstrip(os.sep) in line
    assert keep.read_text() == "user data"


def test_a_failed_write_is_one_clean_error_and_leaves_no_temp_file(tmp_path):
    # a file-size limit stands in for a full disk; HDF5 writing to disk used to leave an
    # unclosable file id that crashed the interpreter at exit (segfault) and a .tmp orphan
    write_packing_src = (
        "import resource, signal, sys\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "from forcespace.cli import main\n"
        "def sample(n, out):\n"
        "    return main(['sample', sys.argv[1], '--sampler', 'relax', '-n', n,\n"
        "                 '--slice', '28', '-o', out, '--quiet'])\n"
        "# the kernels compiled (and numba's cache written) before the limit: with a\n"
        "# cold cache the limit stopped numba's own cache files (Errno 27) instead\n"
        "assert sample('2', sys.argv[3]) == 0\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (20000, 20000))\n"
        "sys.exit(sample('400', sys.argv[2]))\n")
    out = tmp_path / "e.h5"
    (tmp_path / "warm").mkdir()
    r = subprocess.run([sys.executable, "-c", write_packing_src, str(PACK), str(out),
                        str(tmp_path / "warm" / "w.h5")],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 2, r.stderr[-2000:]
    assert "could not be written" in r.stderr and "File too large" in r.stderr
    assert not list(tmp_path.glob(".*.tmp"))


def test_stale_temp_files_of_a_killed_run_are_removed(tmp_path):
    _, prob = grooves([np.pi / 6, np.pi / 5], 0.3)
    out = tmp_path / "e.h5"
    stale = tmp_path / ".e.h5.k1ll3d.tmp"
    stale.write_bytes(b"half a checkpoint")
    other = tmp_path / ".other.h5.abc.tmp"
    other.write_bytes(b"not ours")
    RelaxWalk(3, seed=1).compute(prob, output=out)     # takes the lock: cleans its temps
    assert not stale.exists() and other.exists()


def test_a_second_writer_is_refused(tmp_path, capsys):
    p, _ = pyramid(3, 0.6)
    write_packing(p, tmp_path / "p.h5")
    out = tmp_path / "e.h5"
    with output_lock(out):          # another process holds the output
        assert main(["sample", str(tmp_path / "p.h5"), "--full", "--sampler", "hit-and-run",
                     "-n", "5", "-o", str(out), "--quiet"]) == 2
        assert "another forcespace process" in one_line(capsys)
    assert not out.exists()
    assert main(["sample", str(tmp_path / "p.h5"), "--full", "--sampler", "hit-and-run",
                 "-n", "5", "-o", str(out), "--quiet"]) == 0   # released: it runs


def test_appends_come_at_growing_intervals(tmp_path, monkeypatch):
    _, prob = grooves([np.pi / 6, np.pi / 5], 0.3)
    calls = []
    real = ef.append
    monkeypatch.setattr(ef, "append", lambda *a, **k: calls.append(1) or real(*a, **k))
    RelaxWalk(300, seed=1, checkpoint_every=1).compute(prob, output=tmp_path / "e.h5").summary()
    assert read_ensemble(tmp_path / "e.h5").n_samples == 300
    # every sample was rewritten into the file 300 times before (quadratic I/O)
    assert len(calls) <= 60


def test_export_never_deletes_a_directory_it_did_not_create(tmp_path, capsys):
    pytest.importorskip("forcespace_adapters")
    d = tmp_path / "mine"
    d.mkdir()
    (d / "notes.txt").write_text("my notes")
    for code in ("liggghts", "pymunk"):
        assert main(["export", code, str(PACK), "-o", str(d)]) == 2
        assert "did not create" in one_line(capsys)
        assert (d / "notes.txt").read_text() == "my notes"
    own = tmp_path / "deck"
    assert main(["export", "liggghts", str(PACK), "-o", str(own)]) == 0
    assert main(["export", "liggghts", str(PACK), "-o", str(own)]) == 0   # its own: replaced
    assert (own / ".forcespace-run").is_file()



@pytest.mark.parametrize("command", [["view", str(PACK)], ["export", "liggghts", str(PACK)],
                                     ["export", "pymunk", str(PACK)]])
def test_a_users_file_in_a_directory_forcespace_made_survives(tmp_path, capsys, monkeypatch,
                                                              command):
    # view -o DIR and export ... -o DIR deleted files a user had put into a directory
    # forcespace made (exit 0); view -o . inside it emptied it, view -o .. from a sub-
    # directory deleted the whole tree (issue 48)
    if command[0] == "export":
        pytest.importorskip("forcespace_adapters")
    d = tmp_path / "out"
    assert main(command + ["-o", str(d)]) == 0
    assert main(command + ["-o", str(d)]) == 0         # nothing but its own: replaced
    capsys.readouterr()
    (d / "sub").mkdir()
    (d / "sub" / "notes.txt").write_text("my notes")
    assert main(command + ["-o", str(d)]) == 2
    err = one_line(capsys)
    assert str(d) in err and "'sub'" in err and "not forcespace's" in err
    assert (d / "sub" / "notes.txt").read_text() == "my notes"
    shutil.rmtree(d / "sub")
    monkeypatch.chdir(d)                              # the working directory ...
    for here in (".", str(d), "sub/..", ".."):        # ... or one that holds it
        assert main(command + ["-o", here]) == 2
        assert "working directory" in one_line(capsys)
    assert (d / ".forcespace-run").is_file() and tmp_path.is_dir()
    monkeypatch.chdir(tmp_path)
    assert main(command + ["-o", str(d)]) == 0


def test_a_liggghts_runs_own_files_let_its_deck_be_replaced(tmp_path, capsys):
    pytest.importorskip("forcespace_adapters")
    from forcespace.io.outputs import foreign_entries, own_entries
    d = tmp_path / "deck"
    assert main(["export", "liggghts", str(PACK), "-o", str(d), "--ramp-steps", "500",
                 "--max-steps", "1000"]) == 0
    assert foreign_entries(d) == [] and "in.liggghts" in own_entries(d)
    main(["run", "liggghts", str(d)])         # converged or not: its files are its own
    assert {"screen.txt", "log.liggghts", "atoms.dump", "status.json"} <= own_entries(d)
    (d / ".status.json.tmp").write_text("{")           # as a run killed while writing it
    (d / ".rigid.h5.0a1b2c3d.tmp").write_bytes(b"")    # leaves them: still its own
    assert foreign_entries(d) == []
    (d / ".notes.tmp").write_text("mine")              # not a temporary file of its own
    assert foreign_entries(d) == [".notes.tmp"]
    (d / ".notes.tmp").unlink()
    assert main(["export", "liggghts", str(PACK), "-o", str(d)]) == 0
    assert not (d / "screen.txt").exists()



LONG = "n" * 240            # the filesystem takes 255 bytes; forcespace names files after it


@pytest.mark.parametrize("argv", [
    ["pack", "quick", "--n", "6", "-o", "{o}.h5"],
    ["sample", "{p}", "--sampler", "relax", "-n", "2", "-o", "{o}.h5"],
    ["select", "{p}", "--plate", "-o", "{o}.h5"],
    ["draw", "{p}", "-o", "{o}.png"],
    ["section", "{p}", "-n", "5", "-o", "{o}.png"],
    ["view", "{p}", "-o", "{o}"],
    ["export", "liggghts", "{p}", "-o", "{o}"],
    ["export", "pymunk", "{p}", "-o", "{o}"],
    ["import", "pymunk", "nowhere", "-o", "{o}.h5"],
    ["study", "fig1", "--quick", "-o", "{o}"],
    ["study", "report", "nowhere", "-o", "{o}.md"],
    ["info", "{o}.h5"],
    ["pack", "{o}.toml", "-o", "p.h5"],
], ids=lambda a: " ".join(a[:2]) if a[0] in ("export", "import", "study") else a[0])
def test_paths_over_the_filesystems_limit_are_one_line(tmp_path, capsys, argv):
    # a name over 255 characters ended in a traceback (ENAMETOOLONG; issue 48); a name
    # that leaves no room for the lock and temporary files named after it did too
    if argv[0] in ("export", "import"):
        pytest.importorskip("forcespace_adapters")
    reads = argv[0] == "info" or argv[1].startswith("{o}")     # an input's name
    for name in ([] if reads else [LONG]) + ["m" * 300, "folder_" * 40 + "/x"]:
        args = [a.format(p=PACK, o=name) for a in argv]
        assert main(args) == 2
        line = one_line(capsys)
        assert name[:20] in line and ("bytes" in line or "looked up" in line), line
    assert list(tmp_path.iterdir()) == []


def test_a_full_disk_while_view_and_export_write_is_one_line(tmp_path, capsys, monkeypatch):
    # view on a full disk ended in a traceback (issue 48); the directory it replaces is
    # left as it was, no temporary folder stays behind
    import errno
    from forcespace.io import viewers
    d = tmp_path / "v"
    assert main(["view", str(PACK), "-o", str(d)]) == 0
    before = sorted(q.name for q in d.iterdir())
    real = viewers.write_vtk

    def full(packing, folder, ensemble=None):
        real(packing, folder, ensemble)               # some files made it ...
        raise OSError(errno.ENOSPC, "No space left on device", str(folder / "x.vtp"))

    monkeypatch.setattr(viewers, "write_vtk", full)
    capsys.readouterr()
    assert main(["view", str(PACK), "-o", str(d)]) == 2
    line = one_line(capsys)
    assert f"{d}: (write): could not be written: No space left on device" in line
    assert sorted(q.name for q in d.iterdir()) == before
    assert sorted(q.name for q in tmp_path.iterdir()) == ["v"]
    pytest.importorskip("forcespace_adapters")
    from forcespace_adapters import workflow

    def full_json(path, obj):
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(workflow, "_write_json", full_json)
    for code in ("liggghts", "pymunk"):
        assert main(["export", code, str(PACK), "-o", str(tmp_path / code)]) == 2
        assert "No space left on device" in one_line(capsys)
    assert sorted(q.name for q in tmp_path.iterdir()) == ["v"]


CORRUPTIONS = [
    ("disks", lambda f: f["disks"].__setitem__((0, 0), np.nan), "disks/x"),
    ("radius", lambda f: f["disks"].__setitem__((3, 2), -1.0), "disks/r"),
    ("mu", lambda f: f.attrs.__setitem__("mu", np.nan), "mu"),
    ("index", lambda f: f["contacts/bodies"].__setitem__((0, 1), 10_000), "contacts/bodies"),
    ("wall", lambda f: f["contacts/bodies"].__setitem__((0, 0), -7), "contacts/bodies"),
    ("normal", lambda f: f["contacts/normal"].__setitem__((0, 0), 3.0), "contacts/normal"),
    ("forces", lambda f: f["forces"].__setitem__((0, 0), np.inf), "forces"),
    ("missing", lambda f: f.__delitem__("forces"), "forces"),
    # issue 48: a contact listed twice made dim S 8 instead of 6; body indices stored as
    # floats (2.7 read as body 2) gave dim S 0
    ("duplicate", lambda f: _append_first_contact(f), "contacts/bodies"),
    ("float index", lambda f: _replace(f, "contacts/bodies", f["contacts/bodies"][()] + 0.7),
     "contacts/bodies"),
    ("float image", lambda f: _replace(f, "contacts/image", f["contacts/image"][()] * 1.0),
     "contacts/image"),
]


def _replace(f, name, data):
    del f[name]
    f[name] = data


def _append_first_contact(f):
    """Contact 0 listed twice (every contact dataset grows by its first row)."""
    for name in ("contacts/bodies", "contacts/normal", "contacts/point", "contacts/image",
                 "contacts/gap", "forces"):
        v = f[name][()]
        _replace(f, name, np.concatenate([v, v[:1]]))


@pytest.mark.parametrize("name, corrupt, field", CORRUPTIONS, ids=[c[0] for c in CORRUPTIONS])
@pytest.mark.parametrize("command", ["info", "draw", "sample", "analyze"])
def test_every_command_validates_the_packing_file(tmp_path, capsys, name, corrupt, field,
                                                  command):
    bad = tmp_path / "bad.h5"
    shutil.copy(PACK, bad)
    with h5py.File(bad, "r+") as f:
        corrupt(f)
    args = {"info": ["info", str(bad)], "draw": ["draw", str(bad), "-o", str(tmp_path / "d.png")],
            "sample": ["sample", str(bad), "--sampler", "relax", "-n", "2",
                       "-o", str(tmp_path / "e.h5")],
            "analyze": ["analyze", str(bad)]}[command]
    assert main(args) == 2
    line = one_line(capsys)
    assert str(bad) in line and field in line


def test_corrupt_sampler_checkpoint_is_one_clear_error(tmp_path, capsys):
    p, _ = pyramid(3, 0.6)
    write_packing(p, tmp_path / "p.h5")
    args = ["sample", str(tmp_path / "p.h5"), "--full", "--sampler", "relax", "-n", "4",
            "-o", str(tmp_path / "e.h5"), "--quiet"]
    assert main(args) == 0
    capsys.readouterr()
    with h5py.File(tmp_path / "e.h5", "r+") as f:
        f["checkpoint"].attrs["rng_state"] = "{truncated"
    assert main(args[:6] + ["8"] + args[7:]) == 2
    assert "rng_state" in one_line(capsys)


def test_drawing_does_not_switch_the_callers_matplotlib_backend(tmp_path):
    import matplotlib
    from forcespace.plot import draw_packing
    from forcespace.io.packing_file import read_packing
    before = matplotlib.get_backend()
    draw_packing(read_packing(PACK), tmp_path / "f.png")
    assert matplotlib.get_backend() == before
    assert (tmp_path / "f.png").stat().st_size > 0 and (tmp_path / "f.pdf").stat().st_size > 0


def test_files_record_provenance_and_a_newer_format_is_refused(tmp_path, capsys):
    from forcespace.io.h5 import FORMAT_VERSION
    from forcespace.io.packing_file import read_packing
    from forcespace.model.scene import SCHEMA_VERSION
    p = read_packing(PACK)                 # a format-1 file (no version attribute) still reads
    out = tmp_path / "p.h5"
    write_packing(p, out)
    with h5py.File(out, "r") as f:
        assert f.attrs["format_version"] == FORMAT_VERSION
        assert f.attrs["scene_schema_version"] == SCHEMA_VERSION
        assert str(f.attrs["code_version"]).startswith(str(f.attrs["forcespace_version"]))
    with h5py.File(out, "r+") as f:
        f.attrs["format_version"] = FORMAT_VERSION + 1
    assert main(["info", str(out)]) == 2
    assert "newer forcespace" in one_line(capsys)


def test_ensemble_read_without_samples_and_fingerprint_tolerates_last_bits():
    import forcespace as fs
    from ensemble_cases import grooves
    _, prob = grooves([0.5, 0.6], 0.3)
    fs.HitAndRun(n=8, seed=1).compute(prob, output="e.h5")
    head = read_file("e.h5", samples=False).ensemble
    assert head.n_samples == 0 and head.contacts.size == prob.n_contacts
    assert head.params["seed"] == 1
    # the same problem with loads off in the last bits (another BLAS thread count) is
    # the same problem; a different load is not
    import dataclasses
    jitter = dataclasses.replace(prob, b=prob.b * (1 + 1e-14))
    other = dataclasses.replace(prob, b=prob.b * 1.01)
    params = head.params
    assert fingerprint(jitter, "hit-and-run", params) == head.attrs["fingerprint"]
    assert fingerprint(other, "hit-and-run", params) != head.attrs["fingerprint"]
