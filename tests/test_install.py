"""A fresh install works as the README promises: a non-editable ``pip install`` of the
repository into a new virtual environment, then, from an empty directory outside the
repository, a bundled scene is jammed, a quick study runs and the README's Python
example runs."""
import os
import re
import subprocess
import venv

import pytest

from paths import ROOT

pytestmark = pytest.mark.slow


def _run(args, cwd, timeout=900, env=None):
    r = subprocess.run(args, cwd=cwd, capture_output=True, text=True, timeout=timeout,
                       env=env)
    assert r.returncode == 0, f"{args}: {r.stdout[-2000:]}\n{r.stderr[-3000:]}"
    return r


def test_pip_install_then_pack_study_and_readme_example(tmp_path):
    env_dir = tmp_path / "venv"
    venv.create(env_dir, with_pip=True)
    bin_ = env_dir / "bin"
    env = {k: v for k, v in os.environ.items() if not k.startswith(("VIRTUAL_ENV", "PYTHON"))}
    env["PATH"] = f"{bin_}{os.pathsep}{env.get('PATH', '')}"
    env["MPLBACKEND"] = "Agg"
    work = tmp_path / "empty"
    work.mkdir()
    _run([bin_ / "python", "-m", "pip", "install", "--quiet", str(ROOT)], work, env=env)
    # the installed copy, not the source tree, answers
    where = _run([bin_ / "python", "-c", "import forcespace; print(forcespace.__file__)"],
                 work, env=env).stdout
    assert str(env_dir) in where and str(ROOT) not in where
    _run([bin_ / "forcespace", "pack", "quick", "-o", "q.h5", "--quiet"], work, env=env)
    assert (work / "q.h5").stat().st_size > 10_000
    _run([bin_ / "forcespace", "study", "fig1", "--quick", "-o", "f1", "--quiet"], work,
         env=env)
    for name in ("fig1.csv", "fig1.png", "verdicts.json", "REPORT.md"):
        assert (work / "f1" / name).is_file(), name
    assert sorted(q.name for q in work.iterdir()) == ["f1", "q.h5"]   # nothing outside -o
    text = (ROOT / "README.md").read_text()
    code = re.search(r"## Python API\s+```python\n(.*?)```", text, re.S).group(1)
    out = _run([bin_ / "python", "-c", code], work, env=env).stdout
    assert re.search(r"dim S = [1-9]\d*, eta = ", out)
    assert (work / "quick_ensemble.png").is_file()
    # no file of the installed package was written by the runs (results go to the cwd)
    site = next(env_dir.glob("lib/python*/site-packages/forcespace"))
    assert not [p for p in site.rglob("*") if p.suffix in (".h5", ".csv", ".png")]
