"""The studies' task runner: sets of independent tasks run on a local process pool or a
Dask cluster.

A task is one call ``function(**params, workdir=DIR)`` that returns a JSON-able
dict; its result is written atomically to ``OUT/tasks/NAME.json`` (with the task's
parameters, the code version and the scene it ran) and its files (packings,
ensembles) go under ``OUT/tasks/NAME/``. A task whose JSON says ``"ok": true`` is
not run again, so a study resumes after any interruption; a failed task (``"ok":
false``) is run again by the next run unless ``retry=False``.

Where tasks run: a local pool of ``workers`` processes (fresh interpreters, stopped
with the study: a killed study leaves no worker running), or, given ``scheduler``
(an address such as ``tcp://host:8786``, or a ``distributed.Client``), an existing
Dask cluster (``pip install 'forcespace[dask]'``). Every task runs with one BLAS
thread wherever it runs (threadpoolctl), so a resumed study equals an uninterrupted
one bit for bit. On Dask the study directory is passed as an absolute path and must
be on a filesystem the workers share with the client: that is checked from every
worker before any task is sent.

Locks: the study directory is locked for the whole run (a second run into the same
directory is refused at once), and each task is locked while it runs (whoever calls
:func:`execute`: a task is never run twice at the same time). Lock files are removed
when released. Progress: one bar counting tasks.
"""
from __future__ import annotations

import contextlib
import importlib
import json
import os
import re
import secrets
import sys
import threading
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from multiprocessing import get_context
from pathlib import Path

from forcespace.errors import ForcespaceError, InputError, require_int
from forcespace.extend import (check_name_length, clean_stale_temps, file_lock, jsonable,
                               probe_writable, write_json)


BLAS_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
STUDY_LOCK = ".forcespace-study.lock"
CONNECT_TIMEOUT = 10.0     # [s] to reach a Dask scheduler
WORKER_TIMEOUT = 60.0      # [s] a Dask cluster may go without any worker before the study stops


class ClusterError(ForcespaceError):
    """The workers a study runs on are unusable: a Dask scheduler that cannot be reached or
    is not one, no worker left within the study's timeout, a local worker process that
    died. The tasks done so far are kept; rerunning resumes (CLI exit 4)."""

    exit_code = 4
    kind = "cluster"


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

    def lock_path(self, out) -> Path:
        return Path(out) / "tasks" / f".{self.name}.lock"


# ---------------------------------------------------------------- one BLAS thread

_blas_guard = threading.Lock()
_blas_users = 0
_blas_limiter = None


@contextlib.contextmanager
def one_blas_thread():
    """Run the block with one BLAS/OpenMP thread in this process (threadpoolctl).

    Thread pools are process-wide, so concurrent tasks in threads of one process (a
    Dask worker with several threads) share one limit, set by the first and lifted by
    the last; the result of a task never depends on the thread count it ran with.
    """
    global _blas_users, _blas_limiter
    from threadpoolctl import threadpool_limits

    with _blas_guard:
        if _blas_users == 0:
            _blas_limiter = threadpool_limits(limits=1)
        _blas_users += 1
    try:
        yield
    finally:
        with _blas_guard:
            _blas_users -= 1
            if _blas_users == 0 and _blas_limiter is not None:
                _blas_limiter.restore_original_limits()
                _blas_limiter = None


# ---------------------------------------------------------------- results on disk

def _provenance(task: Task) -> dict:
    """Code version and scene of a task (what made its numbers)."""
    from forcespace import __version__
    from forcespace.extend import code_version

    out = {"code_version": code_version(), "forcespace_version": __version__,
           "function": task.function, "function_source": _package_hash(task.function)}
    scene = task.params.get("scene")
    if isinstance(scene, str):
        import hashlib

        from forcespace import load_scene
        try:
            s = load_scene(scene)
            out["scene"] = {"name": scene, "source": s.source,
                            "sha1": hashlib.sha1(s.text.encode()).hexdigest()}
        except ForcespaceError:
            out["scene"] = {"name": scene}
    return out


def _package_hash(function: str) -> str | None:
    """SHA-1 (12 hex digits) of the .py files of the package that holds ``function``
    ("module:name"; e.g. the studies plug-in, which ``code_version`` does not cover)."""
    import hashlib
    import importlib.util

    top = function.split(":")[0].split(".")[0]
    try:
        spec = importlib.util.find_spec(top)
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.submodule_search_locations:
        return None
    root = Path(list(spec.submodule_search_locations)[0])
    h = hashlib.sha1()
    for path in sorted(root.rglob("*.py")):
        h.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes())
    return f"{top}+src.{h.hexdigest()[:12]}"


def _same_params(stored, params) -> bool:
    return json.loads(json.dumps(jsonable(stored))) == json.loads(json.dumps(jsonable(params)))


def read_result(task: Task, out) -> dict | None:
    """The result JSON of ``task`` under ``out`` (None if absent). InputError naming the
    file when it is not a result of this task: unreadable, not a JSON object, another
    task's, or made with other parameters."""
    path = task.result_path(out)
    if not path.is_file():
        return None

    def bad(what):
        return InputError(path, "(task result)", f"{what}; delete it to run the task again")

    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise bad(f"is not a readable task result ({type(exc).__name__}: {exc})") from None
    if not isinstance(doc, dict):
        raise bad(f"is a JSON {type(doc).__name__}, not a task result (a JSON object)")
    if doc.get("task") != task.name or not isinstance(doc.get("ok"), bool):
        raise bad(f"is not the result of task {task.name!r} (needs \"task\": "
                  f"{task.name!r} and \"ok\": true/false)")
    if "params" in doc and not _same_params(doc["params"], task.params):
        raise InputError(path, "params", "were not this study's parameters (another study, "
                         "or --quick against a full run, wrote this directory); choose "
                         "another -o, or delete the file to run the task again",
                         got=doc["params"])
    return doc


def done_tasks(tasks: list[Task], out, failed: bool = True) -> list[dict]:
    """The results of the tasks already run under ``out``, in task order (with
    ``failed=False``, only those that succeeded). InputError names an unusable file."""
    results = [read_result(t, out) for t in tasks]
    return [r for r in results if r is not None and (failed or r["ok"])]


def execute(task: Task, out: str) -> dict:
    """Run one task and write its result JSON atomically (in a worker, or in-process).

    Holds the task's lock while it runs: a caller that finds the task running elsewhere
    waits for it and returns that result instead of running it again. Runs with one BLAS
    thread. A task that raises is a result too (``"ok": false`` with the error), not a
    crash of the study.
    """
    task.result_path(out).parent.mkdir(parents=True, exist_ok=True)
    with file_lock(task.lock_path(out)):
        done = read_result(task, out)
        if done is not None and done["ok"]:
            return done
        module, name = task.function.split(":")
        wd = task.workdir(out)
        wd.mkdir(parents=True, exist_ok=True)
        result = {"task": task.name, "params": task.params, "ok": True, **_provenance(task)}
        t0, cpu0 = time.perf_counter(), _cpu_seconds()
        try:
            with one_blas_thread():
                fn = getattr(importlib.import_module(module), name)
                result.update(fn(**task.params, workdir=wd))
        except ForcespaceError as exc:     # a task that fails is a result too, not a crash
            result.update(ok=False, error=f"{type(exc).__name__}: {exc}")
        except Exception as exc:           # a bug: recorded with its traceback, study goes on
            result.update(ok=False, error=f"{type(exc).__name__}: {exc} (a bug: traceback "
                          "in this file)", traceback=traceback.format_exc())
        result["wall_seconds"] = time.perf_counter() - t0
        result["cpu_seconds"] = _cpu_seconds() - cpu0
        write_json(task.result_path(out), result)
        return result


def _cpu_seconds() -> float:
    """CPU seconds (user + sys) of the calling thread and of the programs it has waited
    for (LIGGGHTS runs): a task's own CPU time, whatever else shares the machine. Every
    kernel, LP and BLAS call of a task runs in its thread (one BLAS thread, HiGHS with
    threads = 1). In a Dask worker with several threads, programs another thread ran
    count too (only the selection study runs any)."""
    try:
        import resource
    except ImportError:                  # not on POSIX: the thread's own time only
        return time.thread_time()
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.thread_time() + kids.ru_utime + kids.ru_stime


# ---------------------------------------------------------------- the study directory

def check_study_dir(out, create: bool = True, field: str = "-o/--output") -> Path:
    """The study directory as an absolute path, checked before any work: not a file,
    device or symbolic link; creatable (``create``) or existing, and writable."""
    d = Path(os.path.abspath(out))
    check_name_length(d, field)
    if d.is_symlink():
        raise InputError(d, field, "is a symbolic link; give the study directory itself")
    if d.exists() and not d.is_dir():
        raise InputError(d, field, "exists and is not a directory (a study directory holds "
                         "the task results, tables and figures)")
    if not d.exists():
        if not create:
            raise InputError(d, field, "does not exist: no study was run here")
        try:
            d.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError(d, field, f"cannot be created ({exc.strerror})") from None
    probe_writable(d, d, field)
    return d


def _clean_stale(out: Path) -> None:
    """Temporary files of task results left by killed runs (call under the study lock)."""
    tasks = out / "tasks"
    if tasks.is_dir():
        for f in tasks.glob(".*.json.*.tmp"):
            with contextlib.suppress(OSError):
                f.unlink()
    for name in ("REPORT.md", "verdicts.json"):
        clean_stale_temps(out / name)


_held_studies: dict = {}      # study directory -> depth, for this process


@contextlib.contextmanager
def study_lock(out):
    """Hold the lock of a study directory (InputError at once if another run holds it).
    Re-entrant within a process (the CLI holds it around running and summarising)."""
    out = Path(out)
    key = os.path.abspath(out)
    if _held_studies.get(key):
        _held_studies[key] += 1
        try:
            yield out
        finally:
            _held_studies[key] -= 1
        return
    busy = InputError(out, "(lock)", "another forcespace study is running in this directory; "
                      "wait for it to finish, or choose another -o")
    with file_lock(out / STUDY_LOCK, blocking=False, busy=busy):
        _held_studies[key] = 1
        try:
            yield out
        finally:
            _held_studies.pop(key, None)


def run_tasks(tasks: list[Task], out, workers: int | None = None, scheduler=None,
              progress: bool = True, retry: bool = True,
              connect_timeout: float = CONNECT_TIMEOUT,
              worker_timeout: float = WORKER_TIMEOUT) -> list[dict]:
    """Run the tasks not yet done under ``out``; returns all results in task order.

    ``retry``: run failed tasks (``"ok": false``) again (default), else keep their
    results. ``workers``: local processes (default: one per core, at most one per
    task). ``scheduler``: a Dask scheduler address or Client instead of the local pool;
    ``connect_timeout`` [s] to reach it; the study stops with :class:`ClusterError`
    when no worker has been connected for ``worker_timeout`` [s] (tasks done so far
    are kept: rerun to resume).
    """
    names = [t.name for t in tasks]
    if len(set(names)) != len(names):
        raise InputError("study", "tasks", "task names must be unique")
    if workers is not None:
        require_int("study", "workers", workers, 1)
    for name, v in (("connect_timeout", connect_timeout), ("worker_timeout", worker_timeout)):
        if not (isinstance(v, (int, float)) and v > 0 and v < float("inf")):
            raise InputError("study", name, "must be a finite number of seconds > 0", got=v)
    if scheduler is not None:
        check_scheduler_address(scheduler)
    out = check_study_dir(out)
    with study_lock(out):
        _clean_stale(out)
        results = {r["task"]: r for r in done_tasks(tasks, out)}
        todo = [t for t in tasks if t.name not in results
                or (retry and not results[t.name]["ok"])]
        bar = None
        if progress:
            from tqdm import tqdm
            bar = tqdm(total=len(tasks), initial=len(tasks) - len(todo), desc="tasks",
                       unit="task", file=sys.stderr)
        try:
            for res in _map(todo, str(out), workers, scheduler, connect_timeout,
                            worker_timeout):
                results[res["task"]] = res
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()
    return [results[n] for n in names]


def _map(tasks, out, workers, scheduler, connect_timeout, worker_timeout):
    """Yield task results as they complete, locally or on a Dask cluster."""
    if not tasks:
        return
    if scheduler is not None:
        yield from _map_dask(tasks, out, scheduler, connect_timeout, worker_timeout)
        return
    n = min(workers or os.cpu_count() or 1, len(tasks))
    if n <= 1:
        for t in tasks:
            yield execute(t, out)
        return
    yield from _map_pool(tasks, out, n)


# ---------------------------------------------------------------- local pool

def _watch_parent() -> None:
    """In a pool worker: exit as soon as the study process that started it is gone (even
    killed with SIGKILL), instead of running on and writing task files."""
    import multiprocessing
    from multiprocessing.connection import wait

    parent = multiprocessing.parent_process()
    if parent is None:
        return
    wait([parent.sentinel])
    os._exit(1)


def _worker_init() -> None:
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)    # Ctrl-C: the study process stops us
    threading.Thread(target=_watch_parent, daemon=True, name="forcespace-parent-watch").start()


def _terminate(pool: ProcessPoolExecutor) -> None:
    """Stop a pool's worker processes now (running tasks included)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    for p in procs:
        with contextlib.suppress(Exception):
            p.terminate()
    for p in procs:
        with contextlib.suppress(Exception):
            p.join(5)
    pool.shutdown(wait=False, cancel_futures=True)


def _map_pool(tasks, out, n):
    # fresh interpreters with one BLAS thread each: n workers on n cores; forked
    # workers would inherit the parent's BLAS thread pools and oversubscribe the cores
    saved = {k: os.environ.get(k) for k in BLAS_THREAD_VARIABLES}
    os.environ.update({k: "1" for k in BLAS_THREAD_VARIABLES})
    pool = ProcessPoolExecutor(max_workers=n, mp_context=get_context("spawn"),
                               initializer=_worker_init)
    try:
        futures = {pool.submit(execute, t, out): t for t in tasks}
        try:
            for f in as_completed(futures):
                try:
                    yield f.result()
                except BrokenProcessPool:
                    raise ClusterError(f"a local worker process died while running task "
                                       f"{futures[f].name} (killed, or out of memory?); the "
                                       "tasks done so far are kept: rerun to resume") from None
        except BaseException:
            _terminate(pool)
            raise
        pool.shutdown(wait=True)
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


# ---------------------------------------------------------------- Dask

_ADDRESS = re.compile(r"(?:(?P<scheme>[A-Za-z][A-Za-z0-9+.-]*)://)?"
                      r"(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9][A-Za-z0-9._-]*)"
                      r":(?P<port>[0-9]+)")
SCHEMES = ("tcp", "tls", "ucx", "ws", "wss")


def check_scheduler_address(scheduler) -> str:
    """A Dask scheduler address ``[tcp://]HOST:PORT`` (InputError otherwise), or a Client."""
    if not isinstance(scheduler, str):
        return scheduler          # a distributed.Client
    allowed = ("must be a Dask scheduler address tcp://HOST:PORT, as `dask scheduler` "
               "prints it")
    m = _ADDRESS.fullmatch(scheduler.strip())
    if not m:
        raise InputError("command line", "--scheduler", allowed, got=scheduler)
    scheme = (m["scheme"] or "tcp").lower()
    if scheme not in SCHEMES:
        raise InputError("command line", "--scheduler", f"{allowed} ({scheme}:// is not a "
                         "Dask protocol; the dashboard's http:// address is not the "
                         "scheduler's)", got=scheduler)
    if not 1 <= int(m["port"]) <= 65535:
        raise InputError("command line", "--scheduler", f"{allowed}: the port must be "
                         "1..65535", got=scheduler)
    return scheduler.strip()


def _connect(scheduler, timeout: float):
    try:
        from distributed import Client
    except ImportError:
        raise InputError("command line", "--scheduler", "needs dask.distributed: "
                         "pip install 'forcespace[dask]'") from None
    if isinstance(scheduler, Client):
        return scheduler
    address = check_scheduler_address(scheduler)
    _probe_scheduler(address, timeout)
    try:
        return Client(address, timeout=timeout, set_as_default=False)
    except MemoryError:
        raise ClusterError(f"{address} answered, but not as a Dask scheduler (its reply was "
                           "not Dask's protocol); give the address `dask scheduler` prints") \
            from None
    except Exception as exc:
        raise ClusterError(f"cannot reach a Dask scheduler at {address} within {timeout:g} s "
                           f"({type(exc).__name__}: {_first_line(exc)})") from None


def _probe_scheduler(address: str, timeout: float) -> None:
    """ClusterError unless a Dask peer answers the handshake at ``address`` within
    ``timeout`` seconds. (distributed bounds the connection by its timeout but not the
    handshake that follows: a peer that accepts and never speaks held a Client for 630 s.)
    Runs in a thread of its own, so a caller's running event loop is left alone."""
    import asyncio
    from concurrent.futures import ThreadPoolExecutor

    from distributed.comm import connect

    async def handshake():
        # the outer bound is wider than connect's own: a refused port is retried by
        # connect until its timeout and must end as its OSError (cannot reach), not as
        # the outer TimeoutError (under load the two raced: "accepted the connection")
        comm = await asyncio.wait_for(connect(address, timeout=timeout), 2 * timeout + 1)
        await comm.close()

    with ThreadPoolExecutor(1) as pool:
        try:
            pool.submit(asyncio.run, handshake()).result()
        except asyncio.TimeoutError:
            raise ClusterError(f"{address} accepted the connection but did not answer as a "
                               f"Dask scheduler within {timeout:g} s; give the address "
                               "`dask scheduler` prints") from None
        except OSError as exc:
            raise ClusterError(f"cannot reach a Dask scheduler at {address} within "
                               f"{timeout:g} s ({type(exc).__name__}: {_first_line(exc)})") \
                from None
        except Exception:
            raise ClusterError(f"{address} answered, but not as a Dask scheduler (its reply "
                               "was not Dask's protocol); give the address `dask scheduler` "
                               "prints") from None


def _first_line(exc) -> str:
    text = str(exc).strip().splitlines()
    return text[0] if text else ""


def _probe_worker(out: str, token: str) -> str | None:
    """On a Dask worker: None if it sees the client's study directory (the probe file the
    client wrote there) and can write into it, else what is wrong."""
    probe = Path(out) / f".forcespace-probe-{token}"
    try:
        if probe.read_text() != token:
            return f"{probe} has other content: not the client's study directory"
    except OSError as exc:
        return (f"it does not see the study directory {out} ({exc.strerror}): the workers "
                "need a filesystem shared with the client, at the same path")
    try:
        mine = Path(out) / f".forcespace-probe-{token}-{os.getpid()}.tmp"
        mine.write_text("ok")
        mine.unlink()
    except OSError as exc:
        return f"it cannot write into {out} ({exc.strerror})"
    return None


def _check_workers(client, out: str, worker_timeout: float) -> None:
    try:
        client.wait_for_workers(1, timeout=worker_timeout)
    except Exception:
        raise ClusterError(f"no Dask worker is connected to the scheduler "
                           f"{client.scheduler.address} (waited {worker_timeout:g} s)") from None
    token = secrets.token_hex(8)
    probe = Path(out) / f".forcespace-probe-{token}"
    probe.write_text(token)
    try:
        answers = client.run(_probe_worker, out, token)
    except Exception as exc:
        raise ClusterError(f"the Dask workers did not answer a check of the study directory "
                           f"({type(exc).__name__}: {_first_line(exc)})") from None
    finally:
        with contextlib.suppress(OSError):
            probe.unlink()
    for worker, problem in sorted(answers.items()):
        if problem:
            raise InputError(out, "-o/--output", f"Dask worker {worker}: {problem}")


def _map_dask(tasks, out, scheduler, connect_timeout, worker_timeout):
    client = _connect(scheduler, connect_timeout)
    owned = client is not scheduler
    try:
        _check_workers(client, out, worker_timeout)
        token = secrets.token_hex(4)
        futures = {client.submit(execute, t, out, pure=False,
                                 key=f"forcespace-{t.name}-{token}"): t for t in tasks}
        pending = set(futures)
        seen = time.monotonic()
        while pending:
            done = {f for f in pending if f.done()}
            pending -= done
            for f in done:
                yield _dask_result(f, futures[f], out)
            if not done:
                time.sleep(0.2)
            if not pending:
                break
            try:
                n_workers = len(client.nthreads())      # asks the scheduler now
            except Exception as exc:
                raise ClusterError(f"lost the Dask scheduler {client.scheduler.address} "
                                   f"({type(exc).__name__}: {_first_line(exc)}); "
                                   f"{len(pending)} tasks not done: rerun to resume") from None
            now = time.monotonic()
            if n_workers:
                seen = now
            elif now - seen > worker_timeout:
                raise ClusterError(f"every Dask worker of {client.scheduler.address} is gone "
                                   f"(none for {worker_timeout:g} s); {len(pending)} tasks not "
                                   "done: rerun to resume")
    finally:
        if owned:
            with contextlib.suppress(Exception), _quiet_distributed():
                client.close(timeout=5)


@contextlib.contextmanager
def _quiet_distributed():
    """distributed's own log lines (reconnect attempts while closing a client whose
    scheduler is gone) would add to the study's one-line error: muted while closing."""
    import logging
    loggers = [logging.getLogger(n) for n in ("distributed", "distributed.client",
                                              "distributed.comm", "distributed.core")]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels):
            lg.setLevel(level)


def _dask_result(future, task: Task, out: str) -> dict:
    """A finished future's result; a task that killed its workers is a failed task
    (written, so the next run retries it)."""
    try:
        return future.result()
    except Exception as exc:
        name = type(exc).__name__
        if name not in ("KilledWorker", "CancelledError", "FutureCancelledError"):
            raise
        result = {"task": task.name, "params": task.params, "ok": False,
                  **_provenance(task),
                  "error": f"{name}: the Dask worker running it died or left "
                           f"({_first_line(exc)})", "wall_seconds": None}
        write_json(task.result_path(out), result)
        return result
