"""What the commands print: a result as JSON or as aligned ``key: value`` lines."""
from __future__ import annotations

from ..io.jsonfile import dumps


def print_json(obj) -> None:
    """Print ``obj`` as strict JSON (numpy converted; NaN/inf printed as null)."""
    print(dumps(obj, indent=2))


def print_result(obj: dict, as_json: bool) -> None:
    """Print a command's result: JSON (its "units" entry, if any, a dict beside the
    numbers), or one aligned ``key: value [unit]`` line per entry."""
    if as_json:
        print_json(obj)
        return
    units = obj.get("units") if isinstance(obj.get("units"), dict) else {}
    shown = {k: v for k, v in obj.items() if k != "units" or not units}
    width = max((len(k) for k in shown), default=0)
    for k, v in shown.items():
        unit = units.get(k)
        shown_unit = unit and unit != "1" and v is not None
        print(f"{k:>{width}}: {v}" + (f" [{unit}]" if shown_unit else ""))
