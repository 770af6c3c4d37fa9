"""Rows of the studies' JSON-lines files (one JSON object per line), appended as each
result is made so that a rerun resumes; imports nothing heavy (a study may set thread
counts before it imports forcespace)."""
from __future__ import annotations

import json
from pathlib import Path


def read_rows(path, required: bool = False) -> list[dict]:
    """The rows of a JSON-lines file (blank lines skipped), [] while it does not exist
    (``required``: FileNotFoundError naming the file instead)."""
    path = Path(path)
    if required and not path.is_file():
        raise FileNotFoundError(f"{path}: no such rows file (JSON lines)")
    return [json.loads(ln) for ln in path.read_text().splitlines() if ln.strip()] \
        if path.is_file() else []


def append_row(path, row: dict) -> None:
    """Append ``row`` to a JSON-lines file as one line (the file is made if missing)."""
    with open(path, "a") as fh:
        fh.write(json.dumps(row) + "\n")
