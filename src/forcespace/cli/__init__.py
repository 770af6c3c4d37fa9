"""The ``forcespace`` command line.

Built-in sub-commands live in ``forcespace.cli_*`` modules, each with a
``register(subparsers)`` function; plug-ins (the DEM adapters) add theirs
through the ``forcespace.commands`` entry-point group, so forcespace never
imports them. Every command returns an exit code, one line on stderr and no traceback:

* 0: success;
* 2 (``EXIT_INPUT``): bad input (:class:`~forcespace.errors.InputError`, or any
  other :class:`~forcespace.errors.ForcespaceError`): the line names the file,
  the field and what is allowed;
* 3 (``EXIT_NOT_CONVERGED``): a numerical method did not converge or produced a
  non-finite value (:class:`~forcespace.errors.NumericalError`): the line says
  what was reached and why it stopped;
* 4 (``EXIT_CLUSTER``): the workers of a study are unusable
  (:class:`~forcespace.errors.ClusterError`: a Dask scheduler that cannot be reached or
  is not one, every worker gone, a local worker process that died); rerun to resume;
* 130: interrupted (Ctrl-C).
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys
from importlib.metadata import entry_points

from .. import __version__
from ..errors import ClusterError, ForcespaceError, NumericalError
from ..io.jsonfile import dumps

EXIT_INPUT = 2
EXIT_NOT_CONVERGED = 3
EXIT_CLUSTER = 4

BUILTIN = ("forcespace.cli.packing", "forcespace.cli.space", "forcespace.cli.scene", "forcespace.cli.viewers")


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


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except NumericalError as exc:
        print(f"forcespace {args.command}: not converged: {exc}", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    except ClusterError as exc:
        print(f"forcespace {args.command}: cluster: {exc}", file=sys.stderr)
        return EXIT_CLUSTER
    except ForcespaceError as exc:
        print(f"forcespace {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except BrokenPipeError:
        # the reader (e.g. `| head`) went away: stop quietly, as Unix tools do
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except KeyboardInterrupt as exc:
        print("interrupted" + (f"; {exc}" if str(exc) else ""), file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
