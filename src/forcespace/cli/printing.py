"""What the commands print: a result as JSON or as aligned ``key: value`` lines."""
from __future__ import annotations

from ..io.jsonfile import dumps


def print_json(obj) -> None:
    """Print ``obj`` as strict JSON (numpy converted; NaN/inf printed as null)."""
    print(dumps(obj, indent=2))


def print_result(obj: dict, as_json: bool) -> None:
    """Print a command's result: JSON, or one aligned ``key: value`` line per entry."""
    if as_json:
        print_json(obj)
        return
    width = max((len(k) for k in obj), default=0)
    for k, v in obj.items():
        print(f"{k:>{width}}: {v}")
