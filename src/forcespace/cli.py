"""The ``forcespace`` command line.

Built-in sub-commands live in ``forcespace.cli_*`` modules, each with a
``register(subparsers)`` function; plug-ins (the DEM adapters) add theirs
through the ``forcespace.commands`` entry-point group, so forcespace never
imports them. Every command returns an exit code; user errors
(:class:`~forcespace.errors.ForcespaceError`) print one line, no traceback.
"""
from __future__ import annotations

import argparse
import importlib
import json
import sys
from importlib.metadata import entry_points

from . import __version__
from .errors import ForcespaceError

BUILTIN = ("forcespace.cli_packing", "forcespace.cli_ensemble")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="forcespace",
        description="Jammed rigid-disk packings and their force ensembles.")
    parser.add_argument("--version", action="version", version=f"forcespace {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in BUILTIN:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name != name:
                raise
            continue
        module.register(sub)
    for ep in entry_points(group="forcespace.commands"):
        try:
            ep.load()(sub)
        except ModuleNotFoundError:
            continue  # plug-in not installed in this environment
    return parser


def print_json(obj) -> None:
    """Print ``obj`` as JSON (numpy scalars converted)."""
    def default(o):
        if hasattr(o, "item"):
            return o.item()
        if hasattr(o, "tolist"):
            return o.tolist()
        raise TypeError(type(o))
    print(json.dumps(obj, indent=2, default=default, allow_nan=True))


def print_result(obj: dict, as_json: bool) -> None:
    """Print a command's result: JSON, or one aligned ``key: value`` line per entry."""
    if as_json:
        print_json(obj)
        return
    width = max((len(k) for k in obj), default=0)
    for k, v in obj.items():
        print(f"{k:>{width}}: {v}")


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except ForcespaceError as exc:
        print(f"forcespace {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
