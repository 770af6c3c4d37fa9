"""Study sweeps: the quick fig1 study on the local pool and on a Dask LocalCluster."""
import json

import pytest

from forcespace.cli import main
from forcespace.studies import fig1
from forcespace.study import Task, run_tasks

KEYS = ("mu", "mu_sample", "seed", "z", "dim_S", "degree_of_indeterminacy",
        "dof_excess_full", "eta_hit_and_run", "eta_relax")


def rows(results):
    return [{k: row[k] for k in KEYS} for r in results for row in r["rows"]]


@pytest.mark.slow
def test_fig1_quick_local_pool_resumes_and_equals_dask(tmp_path, capsys):
    local = tmp_path / "local"
    assert main(["study", "fig1", "--quick", "--workers", "2", "-o", str(local),
                 "--quiet"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["failed"] == 0 and summary["rows"] == 12
    assert (local / "fig1.csv").is_file() and (local / "fig1.png").is_file()
    tasks = fig1.tasks(quick=True)
    done = run_tasks(tasks, local, progress=False)        # everything is skipped now
    # physics of the quick sweep: z falls with mu, frictionless packings are isostatic
    r = rows(done)
    assert all(x["z"] == 4.0 for x in r if x["mu"] == 0.0)
    assert all(x["dim_S"] >= 0 and x["eta_hit_and_run"] >= 0 for x in r)
    # with friction switched on, eta of the same packing grows with mu (the squares)
    for seed in (1, 2):
        sq = sorted((x["mu_sample"], x["eta_hit_and_run"]) for x in r
                    if x["mu"] == 0.0 and x["seed"] == seed)
        assert [e for _, e in sq] == sorted(e for _, e in sq)
    # the same tasks through a Dask cluster on loopback give the same numbers
    distributed = pytest.importorskip("distributed")
    sub = [t for t in tasks if t.name in ("mu0.1_s1", "mu1_s2")]
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  protocol="tcp", host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        remote = run_tasks(sub, tmp_path / "dask", scheduler=cluster.scheduler_address,
                           progress=False)
    assert rows(remote) == rows([x for x in done if x["task"] in ("mu0.1_s1", "mu1_s2")])


def test_a_failing_task_is_a_result_and_names_must_be_unique(tmp_path):
    bad = Task("bad", "forcespace.studies.fig1:packing_task",
               dict(scene="quick", n_disks=0, slice_height=10.0, samples=2, mu=0.1, seed=1))
    (res,) = run_tasks([bad], tmp_path, progress=False)
    assert res["ok"] is False and "disks.n" in res["error"]
    assert (tmp_path / "tasks" / "bad.json").is_file()
    from forcespace.errors import InputError
    with pytest.raises(InputError, match="unique"):
        run_tasks([bad, bad], tmp_path, progress=False)
