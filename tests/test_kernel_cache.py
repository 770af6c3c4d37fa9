"""The numba cache of forcespace's kernels is stamped with all kernel sources (a stale
callee once ran for a session), without touching the environment."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import forcespace
from forcespace.kernels import kernel_source_hash

PKG = Path(forcespace.__file__).parent


def test_kernel_edits_change_the_stamp_and_other_edits_do_not(tmp_path):
    copy = tmp_path / "forcespace"
    shutil.copytree(PKG, copy, ignore=shutil.ignore_patterns("__pycache__"))
    before = kernel_source_hash.__wrapped__(copy)
    assert before == kernel_source_hash()
    cli = copy / "cli" / "__init__.py"
    cli.write_text(cli.read_text() + "\n# comment\n")
    assert kernel_source_hash.__wrapped__(copy) == before      # no kernel in the CLI
    nlgs = copy / "engine" / "nlgs.py"
    nlgs.write_text(nlgs.read_text() + "\n# a comment in a kernel module\n")
    assert kernel_source_hash.__wrapped__(copy) != before      # a callee of the step changed


def test_kernels_are_cached_under_the_source_stamp_and_the_environment_is_untouched(tmp_path):
    code = ("import os, forcespace; "
            "from forcespace.model.walls import contact_mu; "
            "print(os.environ.get('NUMBA_CACHE_DIR')); contact_mu(True, 0.1, 0.2); "
            "loc = contact_mu._cache._impl.locator; "
            "from forcespace.kernels import kernel_source_hash as h; "
            "print(type(loc).__name__, loc.get_source_stamp() == h(), "
            "loc.get_cache_path().startswith(os.environ['NUMBA_CACHE_DIR']))")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, check=True).stdout.split()
    assert out[0] == str(tmp_path)                  # importing forcespace changed nothing
    assert out[1].startswith("Forcespace") and out[2:] == ["True", "True"]
    assert any(tmp_path.rglob("*.nbi"))             # the cache was written where numba puts it


def test_a_first_run_says_it_compiles_and_a_cached_one_does_not(tmp_path):
    """issue 47: the first `pack` sat at 0 % for 45-60 s of compilation without a word.
    With an empty cache the kernels of a module are listed as uncached and the notice is
    printed; once they ran (compiled and cached), they are not and it is silent."""
    code = ("import io, sys; from forcespace.kernels import uncached_kernels, compile_notice; "
            "from forcespace.model.walls import contact_mu; pk = ('forcespace.model.walls',); "
            "before = uncached_kernels(pk); s = io.StringIO(); said = compile_notice(pk, s); "
            "contact_mu(True, 0.1, 0.2); "
            "print('forcespace.model.walls.contact_mu' in before, said, 'compiling' in "
            "s.getvalue(), uncached_kernels(pk), compile_notice(pk, io.StringIO()))")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    run = [sys.executable, "-c", code]
    first = subprocess.run(run, env=env, capture_output=True, text=True, check=True).stdout
    assert first.split() == ["True", "True", "True", "[]", "False"]
    again = subprocess.run(run, env=env, capture_output=True, text=True, check=True).stdout
    assert again.split()[:2] == ["False", "False"]
