"""Strict JSON: numpy values made plain, non-finite numbers written as null, atomic files."""
from __future__ import annotations

import json
import math

from .h5 import atomic_path


def jsonable(obj):
    """``obj`` with numpy scalars/arrays turned into Python ones and every
    non-finite float (NaN, +-inf) turned into None, so the result is strict JSON."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if hasattr(obj, "tolist"):          # numpy arrays and scalars
        return jsonable(obj.tolist())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def dumps(obj, **kw) -> str:
    """Strict JSON text of ``obj`` (see :func:`jsonable`)."""
    return json.dumps(jsonable(obj), allow_nan=False, **kw)


def write_json(path, obj, indent: int = 1) -> None:
    """Write ``obj`` as strict JSON to ``path`` atomically (temporary file, then rename)."""
    with atomic_path(path) as tmp, open(tmp, "w") as fh:
        fh.write(dumps(obj, indent=indent))
