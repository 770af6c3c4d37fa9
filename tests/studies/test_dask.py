"""Studies on a real Dask cluster: `dask scheduler` and `dask worker` processes on loopback,
the workers started in another directory (so a relative -o would land elsewhere)."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("distributed")

TESTS = Path(__file__).resolve().parents[1]
HERE = Path(__file__).resolve().parent
DASK = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
WORKER = [sys.executable, "-m", "distributed.cli.dask_worker"]
CLI = ("import sys, forcespace_studies; forcespace_studies.STUDIES['tiny'] = 'tiny_study'; "
       "from forcespace.cli import main; sys.exit(main(['study', 'tiny', '--quiet'] + "
       "sys.argv[1:]))")


def env(**extra):
    e = dict(os.environ)
    e["PYTHONPATH"] = os.pathsep.join([str(HERE), str(TESTS), e.get("PYTHONPATH", "")])
    e.update(extra)
    return e


class Cluster:
    """A scheduler and ``n`` worker processes (no nanny: a killed worker stays dead)."""

    def __init__(self, root: Path, n: int = 1, **worker_env):
        self.procs = []
        sched_dir = root / "scheduler"
        sched_dir.mkdir(parents=True)
        info = sched_dir / "scheduler.json"
        self.procs.append(subprocess.Popen(
            DASK + ["--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                    "--scheduler-file", str(info)], cwd=sched_dir, env=env(),
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        deadline = time.monotonic() + 60
        while not (info.is_file() and info.read_text().strip().endswith("}")):
            assert time.monotonic() < deadline, "dask scheduler did not start"
            time.sleep(0.1)
        self.address = json.loads(info.read_text())["address"]
        self.workers = []
        for i in range(n):
            wdir = root / f"worker{i}"       # the workers' working directory: not the client's
            wdir.mkdir()
            w = subprocess.Popen(WORKER + [self.address, "--nthreads", "2", "--no-nanny",
                                           "--no-dashboard", "--local-directory", str(wdir)],
                                 cwd=wdir, env=env(**worker_env), stdout=subprocess.DEVNULL,
                                 stderr=subprocess.DEVNULL)
            self.procs.append(w)
            self.workers.append(w)
        from distributed import Client
        with Client(self.address, timeout=30) as c:
            c.wait_for_workers(n, timeout=60)

    def close(self):
        for p in reversed(self.procs):
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
        for p in self.procs:
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()


@pytest.fixture
def cluster(tmp_path):
    made = []

    def make(n=1, **worker_env):
        c = Cluster(tmp_path / f"cluster{len(made)}", n, **worker_env)
        made.append(c)
        return c
    yield make
    for c in made:
        c.close()


def test_a_study_on_dask_processes_equals_the_local_pool(tmp_path, cluster):
    c = cluster(n=1)
    r = subprocess.run([sys.executable, "-c", CLI, "-o", "local", "--workers", "2"],
                       cwd=tmp_path, env=env(), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    # a relative -o: resolved on the client, so the tasks land in the client's directory
    r = subprocess.run([sys.executable, "-c", CLI, "-o", "remote", "--scheduler", c.address],
                       cwd=tmp_path, env=env(), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert len(list((tmp_path / "remote" / "tasks").glob("*.json"))) == 6
    assert not list((tmp_path / "cluster0").rglob("tasks"))
    # the same table, bit for bit (one BLAS thread per task wherever it runs)
    assert (tmp_path / "remote" / "tiny.csv").read_bytes() == \
        (tmp_path / "local" / "tiny.csv").read_bytes()
    pids = {line.split()[1] for line in (tmp_path / "remote" / "runs.log").read_text()
            .splitlines()}
    assert pids == {str(c.workers[0].pid)}


def test_a_cluster_whose_workers_are_gone_ends_the_study_with_exit_4(tmp_path, cluster):
    c = cluster(n=1, TINY_STUDY_SLEEP="2")
    out = tmp_path / "s"
    t0 = time.monotonic()
    p = subprocess.Popen([sys.executable, "-c", CLI, "-o", str(out), "--scheduler", c.address,
                          "--worker-timeout", "5"], env=env(), stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not (out / "runs.log").is_file():
            assert time.monotonic() < deadline and p.poll() is None
            time.sleep(0.05)
        c.workers[0].kill()
        t_kill = time.monotonic()
        _, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 4
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "every Dask worker" in lines[0] and "rerun to resume" in \
        lines[0], err
    assert time.monotonic() - t_kill < 5 + 20
    assert t0 < t_kill


def test_a_lost_scheduler_ends_the_study_with_exit_4(tmp_path, cluster):
    c = cluster(n=1, TINY_STUDY_SLEEP="2")
    out = tmp_path / "s"
    p = subprocess.Popen([sys.executable, "-c", CLI, "-o", str(out), "--scheduler", c.address,
                          "--connect-timeout", "3"], env=env(), stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not (out / "runs.log").is_file():
            assert time.monotonic() < deadline and p.poll() is None
            time.sleep(0.05)
        c.procs[0].kill()                    # the scheduler
        _, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 4
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "lost the Dask scheduler" in lines[0], err


def test_a_scheduler_without_workers_is_one_line(tmp_path, cluster):
    c = cluster(n=1)
    c.workers[0].kill()
    c.workers[0].wait(10)
    r = subprocess.run([sys.executable, "-c", CLI, "-o", str(tmp_path / "s"), "--scheduler",
                        c.address, "--worker-timeout", "3"], env=env(), capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 4
    assert "no Dask worker is connected" in r.stderr.strip().splitlines()[-1]


def test_a_worker_that_does_not_see_the_study_directory_is_named(tmp_path):
    from forcespace_studies.runner import _probe_worker
    msg = _probe_worker(str(tmp_path / "elsewhere"), "abc")
    assert "does not see the study directory" in msg and "shared" in msg
    (tmp_path / ".forcespace-probe-abc").write_text("abc")
    assert _probe_worker(str(tmp_path), "abc") is None
