"""CLI command ``study``: run a study's tasks (local pool or Dask), then summarise."""
from __future__ import annotations

import importlib


def register(sub) -> None:
    from . import STUDIES
    p = sub.add_parser("study", help="run a study sweep (resumable; local pool or Dask)")
    p.add_argument("name", choices=sorted(STUDIES))
    p.add_argument("--quick", action="store_true", help="a small version (seconds to a minute)")
    p.add_argument("--scheduler", metavar="ADDRESS", default=None,
                   help="run on an existing Dask cluster (e.g. tcp://host:8786)")
    p.add_argument("--workers", type=int, default=None, metavar="K",
                   help="local worker processes (default: the number of cores)")
    p.add_argument("-o", "--output", default=None, metavar="DIR",
                   help="study directory (default studies/NAME; with --quick "
                        "studies/out/NAME-quick); REPORT.md is written beside it")
    p.add_argument("--report-only", action="store_true",
                   help="run nothing: summarise the tasks already done in the study directory "
                        "(tables, figures, verdicts) and rebuild REPORT.md")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_study)


def cmd_study(args) -> int:
    from forcespace.errors import require_int
    from forcespace.io.jsonfile import dumps
    from forcespace.sweep import done_tasks, run_tasks

    from . import STUDIES

    if args.workers is not None:
        require_int("--workers", "workers", args.workers, 1)
    mod = importlib.import_module(STUDIES[args.name])
    out = args.output or (f"studies/out/{args.name}-quick" if args.quick
                          else f"studies/{args.name}")
    if args.report_only:
        results = done_tasks(mod.tasks(args.quick), out)
    else:
        results = run_tasks(mod.tasks(args.quick), out, workers=args.workers,
                            scheduler=args.scheduler, progress=not args.quiet)
    print(dumps(mod.summarize(results, out), indent=2))
    return 0
