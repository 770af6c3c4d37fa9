"""Study sweeps: sets of independent tasks run on a local process pool or a Dask cluster.

A task is one call ``function(**params, workdir=DIR)`` that returns a JSON-able
dict; its result is written atomically to ``OUT/tasks/NAME.json`` and its
files (packings, ensembles) go under ``OUT/tasks/NAME/``. A task whose JSON
exists is not run again, so a study resumes after any interruption. Tasks run
on a local process pool (``workers`` processes) or, given ``scheduler``
(an address such as ``tcp://host:8786``, or a ``distributed.Client``), on an
existing Dask cluster (``pip install 'forcespace[dask]'``). Progress: one bar
counting tasks.
"""
from __future__ import annotations

import fcntl
import importlib
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from multiprocessing import get_context
from dataclasses import dataclass, field
from pathlib import Path

from .errors import ForcespaceError, InputError
from .io.jsonfile import write_json


BLAS_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


@dataclass(frozen=True)
class Task:
    """One unit of a study: ``function`` ("module:name") called with ``params``."""

    name: str
    function: str
    params: dict = field(default_factory=dict)

    def result_path(self, out) -> Path:
        return Path(out) / "tasks" / f"{self.name}.json"

    def workdir(self, out) -> Path:
        return Path(out) / "tasks" / self.name


def execute(task: Task, out: str) -> dict:
    """Run one task and write its result JSON atomically (runs in a worker)."""
    module, name = task.function.split(":")
    fn = getattr(importlib.import_module(module), name)
    wd = task.workdir(out)
    wd.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    try:
        result = {"task": task.name, "params": task.params, "ok": True,
                  **fn(**task.params, workdir=wd)}
    except ForcespaceError as exc:       # a task that fails is a result too, not a crash
        result = {"task": task.name, "params": task.params, "ok": False,
                  "error": f"{type(exc).__name__}: {exc}"}
    result["wall_seconds"] = time.perf_counter() - t0
    write_json(task.result_path(out), result)
    return result


def done_tasks(tasks: list[Task], out) -> list[dict]:
    """The results of the tasks already done under ``out``, in task order."""
    return [json.loads(t.result_path(out).read_text()) for t in tasks
            if t.result_path(out).is_file()]


def run_tasks(tasks: list[Task], out, workers: int | None = None, scheduler=None,
              progress: bool = True) -> list[dict]:
    """Run the tasks not yet done under ``out``; returns all results in task order."""
    out = Path(out)
    names = [t.name for t in tasks]
    if len(set(names)) != len(names):
        raise InputError("study", "tasks", "task names must be unique")
    results = {r["task"]: r for r in done_tasks(tasks, out)}
    todo = [t for t in tasks if t.name not in results]
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(tasks), initial=len(results), desc="tasks", unit="task",
                   file=sys.stderr)
    try:
        for res in _map(todo, str(out), workers, scheduler):
            results[res["task"]] = res
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    return [results[n] for n in names]


def _map(tasks, out, workers, scheduler):
    """Yield task results as they complete, locally or on a Dask cluster."""
    if not tasks:
        return
    if scheduler is not None:
        try:
            from distributed import Client
            from distributed import as_completed as dask_completed
        except ImportError:
            raise InputError("--scheduler", "dask", "needs dask.distributed: "
                             "pip install 'forcespace[dask]'") from None
        client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
        try:
            futures = [client.submit(execute, t, out, pure=False) for t in tasks]
            for f in dask_completed(futures):
                yield f.result()
        finally:
            if client is not scheduler:
                client.close()
        return
    n = workers or min(len(tasks), os.cpu_count() or 1)
    if n <= 1:
        for t in tasks:
            yield execute(t, out)
        return
    # fresh interpreters with one BLAS thread each: n workers on n cores; forked
    # workers would inherit the parent's BLAS thread pools and oversubscribe the cores
    saved = {k: os.environ.get(k) for k in BLAS_THREAD_VARIABLES}
    os.environ.update({k: "1" for k in BLAS_THREAD_VARIABLES})
    try:
        with ProcessPoolExecutor(max_workers=n, mp_context=get_context("spawn")) as pool:
            futures = [pool.submit(execute, t, out) for t in tasks]
            for f in as_completed(futures):
                yield f.result()
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
