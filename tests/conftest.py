"""Shared test set-up: every test runs in its own empty working directory.

So no test can depend on being started from the repository root (paths to the
repository's files come from ``tests/paths.py``), and none can litter it.
Markers (registered in pyproject.toml): ``hard``, ``slow``, ``external``;
``make test`` runs them all.
"""
import pytest


@pytest.fixture(autouse=True)
def _elsewhere(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
