"""The numba cache is keyed by the kernel sources (a stale callee once ran for a session)."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import forcespace
from forcespace.kernel_cache import kernel_source_hash

PKG = Path(forcespace.__file__).parent


def test_kernel_edits_change_the_cache_key_and_other_edits_do_not(tmp_path):
    for f in PKG.glob("*.py"):
        shutil.copy(f, tmp_path / f.name)
    before = kernel_source_hash(tmp_path)
    assert before == kernel_source_hash(PKG)
    (tmp_path / "cli.py").write_text((tmp_path / "cli.py").read_text() + "\n# comment\n")
    assert kernel_source_hash(tmp_path) == before           # no kernel in cli.py
    nlgs = tmp_path / "nlgs.py"
    nlgs.write_text(nlgs.read_text().replace("relaxation = 1.0", "relaxation = 1.0 ", 1))
    assert kernel_source_hash(tmp_path) != before           # a callee of dynamics changed


def test_import_points_numba_at_the_versioned_directory(tmp_path):
    code = ("import forcespace, os, numba.core.config as c; "
            "from forcespace.nlgs import nlgs_solve; "
            "print(os.environ['NUMBA_CACHE_DIR']); print(c.CACHE_DIR)")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, check=True).stdout.split()
    want = str(tmp_path / kernel_source_hash())
    assert out == [want, want]
    env["NUMBA_CACHE_DIR"] = want                            # a worker process: unchanged
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, check=True).stdout.split()
    assert out == [want, want]
