"""CLI command ``study``: run a study's tasks (local pool or Dask), then summarise;
``study report``: combine study directories into one report."""
from __future__ import annotations

import importlib
from pathlib import Path

DESCRIPTION = {
    "fig1": "eta and z against mu, both samplers (the paper's Fig. 1)",
    "fig2": "elementary clusters and localisation against mu (the paper's Fig. 2)",
    "fig3": "distances from the centre of S, cross-section, uniformity (the paper's Fig. 3)",
    "pointforce": "depth of the rearrangement under a point force, against mu",
    "selection": "where in S a soft code lands: the elastic selection",
    "size": "uniform eta, dim S and domains against the number of disks",
    "measured": "measured networks: the readers' round trip, noisy networks checked against S",
}


def register(sub) -> None:
    from .runner import CONNECT_TIMEOUT, WORKER_TIMEOUT

    from . import STUDIES
    p = sub.add_parser("study", help="run a study (resumable; local pool or Dask), or "
                       "combine study directories into one report",
                       description="`forcespace study NAME` runs a study into its directory "
                       "(tasks, tables, figures, verdicts.json and REPORT.md, all inside it); "
                       "`forcespace study report DIR... -o REPORT.md` combines studies.")
    names = p.add_subparsers(dest="study", metavar="NAME")
    names.required = True
    for name in sorted(STUDIES):
        q = names.add_parser(name, help=DESCRIPTION.get(name, name))
        q.add_argument("--quick", action="store_true",
                       help="a small version (about a minute): a smoke test of the code, its "
                            "verdicts are marked so")
        q.add_argument("--scheduler", metavar="ADDRESS", default=None,
                       help="run on an existing Dask cluster (tcp://HOST:PORT, as `dask "
                            "scheduler` prints it); the workers must share the study "
                            "directory's filesystem at the same path")
        q.add_argument("--workers", type=int, default=None, metavar="K",
                       help="local worker processes (default: the number of cores)")
        q.add_argument("-o", "--output", default=None, metavar="DIR",
                       help=f"study directory (default ./{name}, with --quick "
                            f"./{name}-quick); everything is written inside it")
        q.add_argument("--report-only", action="store_true",
                       help="run nothing: summarise the tasks already done in the study "
                            "directory (tables, figures, verdicts.json, REPORT.md)")
        q.add_argument("--no-retry", dest="retry", action="store_false",
                       help="keep the results of tasks that failed in an earlier run "
                            "(default: run them again)")
        q.add_argument("--connect-timeout", type=float, default=CONNECT_TIMEOUT, metavar="S",
                       help=f"with --scheduler: seconds to reach it (default {CONNECT_TIMEOUT:g})")
        q.add_argument("--worker-timeout", type=float, default=WORKER_TIMEOUT, metavar="S",
                       help="with --scheduler: stop (exit 4) when no worker has been "
                            f"connected for S seconds (default {WORKER_TIMEOUT:g})")
        q.add_argument("--quiet", action="store_true", help="no progress bar")
        q.set_defaults(func=cmd_study, study_name=name)
    r = names.add_parser("report", help="combine study directories into one report",
                         description="Write one report of the claims, our numbers and the "
                         "verdicts of the study directories DIR (from their verdicts.json). "
                         "An existing file is replaced only if forcespace wrote it.")
    r.add_argument("dirs", nargs="+", metavar="DIR", help="study directories")
    r.add_argument("-o", "--output", required=True, metavar="REPORT.md")
    r.set_defaults(func=cmd_report)


def _study_dir(args) -> Path:
    """The study directory, checked before any work (a file, device, symlink, read-only
    place, another study's directory, or a directory that is not a study's is refused)."""
    import json
    from pathlib import Path

    from forcespace.errors import InputError
    from forcespace.extend import check_name_length

    from .report import STUDY_FILE, check_report_file, study_info
    from .runner import check_study_dir

    name = args.study_name
    out = Path(args.output or (f"{name}-quick" if args.quick else name))
    check_name_length(out)           # before any look at it
    if args.report_only:
        d = check_study_dir(out, create=False)
        if not any((d / "tasks").glob("*.json")):
            raise InputError(d, "tasks", f"no task of study {name} has been run here: "
                             "nothing to summarise (run the study first)")
    else:
        d = Path(out).absolute()
        # forcespace's own hidden files (the study lock, a writability probe) do not make a
        # directory foreign: a study starting there at the same moment holds the lock
        if d.is_dir() and any(not e.name.startswith(".") for e in d.iterdir()) and not (
                (d / STUDY_FILE).is_file() or (d / "tasks").is_dir()
                or (d / "verdicts.json").is_file()):
            raise InputError(d, "-o/--output", "is a non-empty directory that is not a study "
                             "directory; choose a new or empty directory (nothing was changed)")
        d = check_study_dir(out)
    info = study_info(d)
    if not info and (d / "verdicts.json").is_file():     # a study directory from before
        try:
            info = {"study": json.loads((d / "verdicts.json").read_text())["study"]}
        except (OSError, ValueError, KeyError, TypeError):
            info = {}
    if info.get("study", name) != name:
        raise InputError(d, "-o/--output", f"is the directory of study {info['study']!r}, not "
                         f"{name!r}; choose another directory")
    if "quick" in info and bool(info["quick"]) != bool(args.quick):
        mode = "a quick" if info["quick"] else "a full"
        raise InputError(d, "-o/--output", f"holds {mode} run of {name}; "
                         f"{'add' if info['quick'] else 'drop'} --quick or choose another "
                         "directory")
    check_report_file(d / "REPORT.md")
    return d


def _write_study_file(d, name: str, quick: bool, mod, n_tasks: int) -> None:
    from forcespace import __version__
    from forcespace.extend import code_version, write_json

    from .report import STUDY_FILE

    config = mod.config(quick) if hasattr(mod, "config") else None
    doc = {"study": name, "quick": bool(quick), "tasks": n_tasks, "config": config,
           "scene": (config or {}).get("scene"), "code_version": code_version(),
           "forcespace_version": __version__,
           "note": "written by `forcespace study`; quick runs are smoke tests of the code"}
    write_json(d / STUDY_FILE, doc)


def cmd_study(args) -> int:
    import signal
    import sys
    import threading

    from forcespace.errors import InputError, NumericalError, require_int
    from forcespace.extend import dumps
    from .runner import (check_scheduler_address, done_tasks, run_tasks,
                                  study_lock)

    from . import STUDIES
    from .report import SMOKE

    name = args.study_name
    if args.workers is not None:
        require_int("command line", "--workers", args.workers, 1)
    for opt, v in (("--connect-timeout", args.connect_timeout),
                   ("--worker-timeout", args.worker_timeout)):
        if not (v > 0 and v < float("inf")):
            raise InputError("command line", opt, "must be a finite number of seconds > 0",
                             got=v)
    if args.scheduler is not None:
        check_scheduler_address(args.scheduler)
        _mute_dask_client()
    mod = importlib.import_module(STUDIES[name])
    tasks = mod.tasks(args.quick)
    out = _study_dir(args)

    def stop(signum, frame):      # `kill`: stop the workers and exit as on Ctrl-C
        raise KeyboardInterrupt
    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, stop) if main else None
    try:
        with study_lock(out):
            _write_study_file(out, name, args.quick, mod, len(tasks))
            if args.report_only:
                results = done_tasks(tasks, out)
            else:
                results = run_tasks(tasks, out, workers=args.workers, scheduler=args.scheduler,
                                    progress=not args.quiet, retry=args.retry,
                                    connect_timeout=args.connect_timeout,
                                    worker_timeout=args.worker_timeout)
            failed = [r for r in results if not r["ok"]]
            for r in failed:
                print(f"forcespace study {name}: task {r['task']} failed: {r.get('error')}",
                      file=sys.stderr)
            if results and len(failed) == len(results):
                raise NumericalError(f"none of the {len(results)} tasks of {name} in {out} "
                                     "succeeded (each failure is listed above); nothing to "
                                     "summarise; rerun to retry them")
            summary = mod.summarize(results, out)
    finally:
        if main:
            signal.signal(signal.SIGTERM, previous)
    if args.quick and isinstance(summary.get("verdicts"), list):
        summary["verdicts"] = [SMOKE for _ in summary["verdicts"]]
    summary.update({"study": name, "quick": bool(args.quick), "directory": str(out),
                    "report": str(out / "REPORT.md")})
    print(dumps(summary, indent=2))
    if failed:
        print(f"forcespace study {name}: {len(failed)} of {len(results)} tasks failed (listed "
              "above; the report leaves them out); rerun to retry them", file=sys.stderr)
    return 0


def _mute_dask_client() -> None:
    """The client's own log lines (reconnecting to a lost scheduler, ...) would break the
    one-line contract: muted, after distributed set up its logging on import."""
    import logging
    try:
        import distributed  # noqa: F401
    except ImportError:
        return              # the run says so in one line
    for n in ("distributed", "distributed.client", "distributed.core", "distributed.comm"):
        logging.getLogger(n).setLevel(logging.CRITICAL + 1)


def cmd_report(args) -> int:
    from .report import write_report

    path = write_report(args.dirs, args.output)
    print(f"wrote {path}")
    return 0
