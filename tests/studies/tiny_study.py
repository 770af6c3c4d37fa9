"""A tiny study for the runner's tests: hit-and-run on hand-built grooves (no jamming).

Each task logs that it ran (one line appended to ``OUT/runs.log``), records the BLAS
threads it saw, sleeps ``TINY_STUDY_SLEEP`` seconds (so a test can interrupt a run),
fails on purpose if it is ``TINY_STUDY_FAIL`` (until ``OUT/heal`` exists), and samples S into
``workdir/har.h5`` (``TINY_STUDY_TARGET_ESS``: until that ESS, thin 1); a task named by
``TINY_STUDY_FAIL_AFTER`` fails after its sampling (until ``OUT/heal`` exists; not a
parameter, as it changes no result). Registered by the tests as study ``tiny``
(``STUDIES["tiny"]``).
"""
import json
import os
import time
from pathlib import Path

from forcespace_studies.runner import Task

FULL = dict(thetas=(0.3, 0.5, 0.7, 0.4, 0.6, 0.2), samples=12)
QUICK = dict(thetas=(0.3, 0.5), samples=6)


def config(quick: bool) -> dict:
    cfg = dict(QUICK if quick else FULL)
    cfg["fail"] = os.environ.get("TINY_STUDY_FAIL", "")
    cfg["target_ess"] = float(os.environ.get("TINY_STUDY_TARGET_ESS", 0)) or None
    return cfg


def tasks(quick: bool = False) -> list:
    cfg = config(quick)
    return [Task(f"t{i}", "tiny_study:task",
                 dict(theta=th, mu=0.2, samples=cfg["samples"], seed=i,
                      fail=cfg["fail"] == f"t{i}",
                      **({"target_ess": cfg["target_ess"]} if cfg["target_ess"] else {})))
            for i, th in enumerate(cfg["thetas"])]


def task(theta, mu, samples, seed, fail, workdir, target_ess=None) -> dict:
    import forcespace as fs
    from ensemble_cases import grooves
    from forcespace.errors import NumericalError
    from threadpoolctl import threadpool_info

    wd = Path(workdir)
    with open(wd.parents[1] / "runs.log", "a") as fh:
        fh.write(f"{wd.name} {os.getpid()}\n")
    if fail and not (wd.parents[1] / "heal").exists():
        raise NumericalError(f"task {wd.name} failed on purpose")
    time.sleep(float(os.environ.get("TINY_STUDY_SLEEP", 0)))   # not a parameter: no result
    _, prob = grooves([theta, theta + 0.1], mu=mu)
    har = (fs.HitAndRun(n=samples, seed=seed) if target_ess is None else
           fs.HitAndRun(n=100_000, seed=seed, thin=1, target_ess=target_ess)
           ).compute(prob, output=wd / "har.h5")
    if os.environ.get("TINY_STUDY_FAIL_AFTER") == wd.name and \
            not (wd.parents[1] / "heal").exists():
        raise NumericalError(f"task {wd.name} failed on purpose after its sampling")
    threads = max((i["num_threads"] for i in threadpool_info()
                   if i["user_api"] == "blas"), default=1)
    return {"rows": [{"theta": theta, "seed": seed, "eta": har.ensemble.eta,
                      "n": har.ensemble.n_samples, "dim_S": har.summary().get("dim_S")}],
            "blas_threads": threads}


def summarize(results, out) -> dict:
    from forcespace_studies.report import RULES_VERSION, Verdict, write_csv, write_section

    out = Path(out)
    rows = [dict(row, task=r["task"]) for r in results if r["ok"] for row in r["rows"]]
    write_csv(out / "tiny.csv", rows, ["task", "theta", "seed", "eta", "n", "dim_S"])
    write_section(out, "tiny", "A tiny study", json.dumps({"rows": len(rows)}),
                  [Verdict("tiny", "grooves are indeterminate with friction",
                           f"{len(rows)} grooves", "reproduced")], {"rows": len(rows)}, [],
                  rules_version=RULES_VERSION)
    return {"tasks": len(results), "failed": sum(not r["ok"] for r in results),
            "rows": len(rows), "verdicts": ["reproduced"]}
