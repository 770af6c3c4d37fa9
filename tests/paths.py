"""Paths of the repository's own files, independent of the working directory."""
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
QUICK = ROOT / "inputs" / "quick.toml"
PAPER = ROOT / "inputs" / "paper.toml"
PACKINGS = ROOT / "studies" / "packings"
INPUTS = ROOT / "inputs"
DATA = ROOT / "tests" / "data"
