"""The ``forcespace`` command line.

Built-in sub-commands live in the modules of ``BUILTIN`` (``forcespace.cli.packing``,
...), each with a ``register(subparsers)`` function; plug-ins (the DEM adapters) add theirs
through the ``forcespace.commands`` entry-point group, so forcespace never
imports them. Every command returns an exit code, one line on stderr and no traceback:

* 0: success;
* 2 (``EXIT_INPUT``): bad input (:class:`~forcespace.errors.InputError`, or any
  other :class:`~forcespace.errors.ForcespaceError`): the line names the file,
  the field and what is allowed;
* 3 (``EXIT_NOT_CONVERGED``): a numerical method did not converge or produced a
  non-finite value (:class:`~forcespace.errors.NumericalError`): the line says
  what was reached and why it stopped;
* 4 (``EXIT_CLUSTER``): the workers of a study are unusable (the studies' plug-in's
  ``ClusterError``: a Dask scheduler that cannot be reached or is not one, every
  worker gone, a local worker process that died); rerun to resume;
* 130: interrupted (Ctrl-C).

A plug-in's error reaches the user the same way: a ForcespaceError subclass whose
``exit_code`` and ``kind`` say how.

Every command runs with one BLAS thread unless the environment sets a count
(``BLAS_THREAD_VARIABLES``): the same command then gives the same numbers on every
machine, and a loaded one does not slow threaded BLAS down many times over (README,
"BLAS threads").
"""
from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import sys
from importlib.metadata import entry_points

from .. import __version__
from ..errors import ForcespaceError, NumericalError
from .printing import print_json, print_result  # noqa: F401 (the commands' printing)

EXIT_INPUT = ForcespaceError.exit_code              # 2
EXIT_NOT_CONVERGED = NumericalError.exit_code       # 3
EXIT_CLUSTER = 4                                    # the studies' ClusterError
# environment variables that set the BLAS/OpenMP thread count; with none of them set the
# commands run with one BLAS thread
BLAS_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                         "BLIS_NUM_THREADS")

BUILTIN = ("forcespace.cli.packing", "forcespace.cli.space", "forcespace.cli.scene", "forcespace.cli.viewers",
           "forcespace.cli.measured")


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


def blas_threads():
    """A context with one BLAS thread, unless the environment sets a thread count
    (then nothing changes)."""
    if any(os.environ.get(v, "").strip() for v in BLAS_THREAD_VARIABLES):
        return contextlib.nullcontext()
    from threadpoolctl import threadpool_limits
    return threadpool_limits(limits=1)


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        with blas_threads():
            return int(args.func(args) or 0)
    except ForcespaceError as exc:      # InputError 2, NumericalError 3, ClusterError 4
        print(f"forcespace {args.command}: {exc.kind}: {exc}", file=sys.stderr)
        return exc.exit_code
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
