"""config.py's promise: every name in it is read (at call time), so changing one changes
what the library does."""
import ast
from pathlib import Path

import numpy as np

import forcespace
from forcespace import config
from forcespace.model.packing import Packing

SRC = Path(forcespace.__file__).parent
ROOT = SRC.parents[1]


def _names_read(roots) -> set:
    """Every NAME read as ``config.NAME`` (or imported from forcespace.config)."""
    seen = set()
    for root in roots:
        for path in root.rglob("*.py"):
            if path == SRC / "config.py":
                continue
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.Attribute) and getattr(node.value, "id", "") == "config":
                    seen.add(node.attr)
                elif isinstance(node, ast.ImportFrom) and (node.module or "").endswith("config"):
                    seen.update(a.name for a in node.names)
    return seen


def test_every_name_in_config_is_read_somewhere():
    names = {n for n in vars(config) if n.isupper()}
    unread = names - _names_read([SRC, ROOT / "studies", ROOT / "adapters"])
    assert len(names) > 40 and unread == set()


def _chain_of_three(fn_middle):
    """Disks 0-1-2 in a row on nothing: contact 0-1 carries 1 F0, contact 1-2 ``fn_middle``."""
    return Packing.from_arrays([0.0, 2.0, 4.0], [1.0, 1.0, 1.0], [1.0, 1.0, 1.0],
                               [0, 1], [1, 2], fn=[1.0, fn_middle], width=10.0)


def test_force_bearing_threshold_is_read_from_config(monkeypatch):
    p = _chain_of_three(1e-6)         # the second contact: 2e-6 of the mean normal force
    assert p.force_bearing().tolist() == [True, True]
    assert not p.rattlers().any()
    monkeypatch.setattr(config, "FORCE_BEARING", 1e-5)
    assert p.force_bearing().tolist() == [True, False]
    assert p.rattlers().tolist() == [False, False, True]
    assert p.coordination() == 2.0 * 1 / 2


def test_the_default_convergence_target_is_min_ess(monkeypatch):
    from forcespace.sampling.diagnostics import converged
    summary = {"min_ess": 150.0, "max_rhat": 1.01}
    assert converged(summary)
    monkeypatch.setattr(config, "MIN_ESS", 200.0)
    assert not converged(summary)
    assert converged(summary, target_ess=np.float64(120.0))
