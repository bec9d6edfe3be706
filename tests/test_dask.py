"""Batch compression on a real Dask cluster: a ``dask.distributed.LocalCluster`` of two worker processes (skipped
when ``dask[distributed]`` is not installed; ``.ci/run`` installs the ``dask`` extra)."""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path

import pytest

distributed = pytest.importorskip("distributed")

from motionrep.io.archive import Archive  # noqa: E402
from motionrep.io import write, write_database  # noqa: E402
from motionrep.model.synthetic import chain_skeleton, synthetic_motion  # noqa: E402
from helpers import run_cli, run_cli_caught


def run(*args: str, env: dict | None = None):
    return run_cli(*args, env=env)


@pytest.fixture(scope="module")
def cluster():
    """Two worker processes of one thread each (as `dask worker --nworkers 2 --nthreads 1`)."""
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  silence_logs=50) as c:
        yield c


def _archive_bytes(path: Path) -> dict[str, bytes]:
    with Archive(path) as a:
        return {n: a.read_bytes(n) for n in a.names}


def _inputs(tmp_path: Path) -> tuple[Path, Path]:
    src = tmp_path / "clips"
    (src / "sub").mkdir(parents=True)
    for i in range(5):
        write(synthetic_motion(chain_skeleton(6 + i), frames=200 + 10 * i, fps=60, seed=i),
              (src / "sub" if i % 2 else src) / f"c{i}.bvh")
    db = tmp_path / "db.h5"
    write_database({f"m{i}": synthetic_motion(chain_skeleton(5), frames=150 + i, fps=30, seed=10 + i)
                    for i in range(3)}, db)
    return src, db


@pytest.mark.slow  # a two-process local pool and a two-process cluster start
def test_the_cluster_gives_the_same_bytes_as_the_local_pool(cluster, tmp_path):
    src, db = _inputs(tmp_path)
    for name, inputs in (("dir", [src]), ("db", [db])):
        local, remote, mrc = tmp_path / f"{name}_local.h5", tmp_path / f"{name}_dask.h5", tmp_path / f"{name}_mrc"
        r = run("compress", *inputs, "-o", local, "--codec", "svd", "--jobs", "2")
        assert r.exit_code == 0, r.output
        r = run("compress", *inputs, "-o", remote, "--codec", "svd", "--scheduler", cluster.scheduler_address)
        assert r.exit_code == 0, r.output
        assert _archive_bytes(remote) == _archive_bytes(local)
        # the scheduler from the environment, into a directory of .mrc files
        r = run("compress", *inputs, "-o", mrc, "--codec", "svd",
                env={"MOTIONREP_SCHEDULER": cluster.scheduler_address})
        assert r.exit_code == 0, r.output
        assert {p.stem: p.read_bytes() for p in mrc.iterdir()} == _archive_bytes(local)
    # workers that cannot read the files: the client sends their bytes
    sent = tmp_path / "sent.h5"
    r = run("compress", src, "-o", sent, "--codec", "svd", "--scheduler", cluster.scheduler_address, "--send-clips")
    assert r.exit_code == 0, r.output
    assert _archive_bytes(sent) == _archive_bytes(tmp_path / "dir_local.h5")


def test_the_cluster_runs_a_batch(cluster, tmp_path):
    """The quick check in the default run: a directory on the cluster, totals, resume."""
    src, _ = _inputs(tmp_path)
    out = tmp_path / "out.h5"
    r = run("compress", src, "-o", out, "--codec", "svd", "--scheduler", cluster.scheduler_address, "--json")
    assert r.exit_code == 0, r.output
    d = json.loads(r.output)
    assert d["totals"]["compressed"] == 5 and len(_archive_bytes(out)) == 5
    r = run("compress", src, "-o", out, "--codec", "svd", "--scheduler", cluster.scheduler_address, "--json",
            "--resume")
    assert {c["status"] for c in json.loads(r.output)["clips"].values()} == {"skipped"}
    r = run("compress", src, "-o", out, "--codec", "svd", "--scheduler", cluster.scheduler_address, "--jobs", "2")
    assert r.exit_code == 2


def test_standard_input_is_sent_to_the_cluster(cluster, tmp_path):
    """'-' with --scheduler: Dask workers cannot read this machine's standard input (or its temporary copy), so
    the client reads the clips and sends them, and says so in one line; the same bytes as from the file."""
    _, db = _inputs(tmp_path)
    local = tmp_path / "local.h5"
    assert run("compress", db, "-o", local, "--codec", "svd").exit_code == 0
    r = run_cli_caught("compress", "-", "-o", str(tmp_path / "piped.h5"), "--codec", "svd", "--json",
                                 "--scheduler", cluster.scheduler_address, input=db.read_bytes())
    assert r.exit_code == 0, r.output
    assert r.stderr.splitlines()[0] == ("note: <stdin> is read here and its clips sent to the Dask workers (as "
                                        "--send-clips does)")
    assert json.loads(r.stdout)["totals"]["compressed"] == 3
    assert _archive_bytes(tmp_path / "piped.h5") == _archive_bytes(local)


def test_an_unreachable_scheduler_is_one_line(tmp_path, monkeypatch):
    monkeypatch.setattr("motionrep.batch.executors.CONNECT_TIMEOUT", "1s")
    src, _ = _inputs(tmp_path)
    r = run("compress", src, "-o", tmp_path / "out.h5", "--codec", "svd", "--scheduler", "tcp://127.0.0.1:9")
    assert r.exit_code == 1 and "cannot reach the Dask scheduler tcp://127.0.0.1:9" in r.output
    assert not (tmp_path / "out.h5").exists()


@pytest.mark.slow  # kills a worker process and waits for its nanny to start another
def test_a_worker_killed_mid_run_loses_nothing(cluster, tmp_path):
    from motionrep.batch.engine import compress_clips, dask_executor
    from motionrep.pipeline.compress import Pipeline
    from motionrep.pipeline.sources import collect_clips

    src = tmp_path / "clips"
    src.mkdir()
    for i in range(8):
        write(synthetic_motion(chain_skeleton(25), frames=800, fps=120, seed=i), src / f"c{i:02d}.bvh")
    refs = collect_clips([src])
    pipeline = Pipeline.build("svd")
    expected = {o.name: o.data for o in compress_clips(refs, pipeline, jobs=2)}
    killed = []
    with distributed.Client(cluster.scheduler_address) as client:
        pids = list(client.run(os.getpid).values())

    def kill_one(outcome):
        if not killed:
            os.kill(pids[0], signal.SIGKILL)  # a worker dies with its clips half done; Dask runs them again
            killed.append(pids[0])

    with dask_executor(cluster.scheduler_address) as executor:
        outcomes = compress_clips(refs, pipeline, executor=executor, on_done=kill_one)
    assert killed
    assert not any(o.failed for o in outcomes)
    assert {o.name: o.data for o in outcomes} == expected  # every clip, the same bytes


@pytest.mark.slow  # a client process killed mid-run
def test_resume_after_a_killed_client_finishes_only_the_rest(cluster, tmp_path):
    import subprocess
    import sys
    import time

    from motionrep.batch.store import journal_path

    src = tmp_path / "clips"
    src.mkdir()
    for i in range(10):
        write(synthetic_motion(chain_skeleton(25), frames=1000, fps=120, seed=i), src / f"c{i:02d}.bvh")
    out = tmp_path / "out.h5"
    journal = journal_path(out)
    p = subprocess.Popen([sys.executable, "-m", "motionrep", "compress", str(src), "-o", str(out), "--codec", "svd",
                          "--scheduler", cluster.scheduler_address], stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL)
    end = time.monotonic() + 240
    def committed() -> list[str]:  # not the hidden temporary file of a clip being written
        return sorted(q.stem for q in journal.glob("*.mrc") if not q.name.startswith(".")) if journal.is_dir() else []

    while len(committed()) < 2 and p.poll() is None:
        assert time.monotonic() < end
        time.sleep(0.05)
    p.kill()
    p.wait()
    done = committed()
    assert 2 <= len(done) < 10 and not out.exists()
    r = run("compress", src, "-o", out, "--codec", "svd", "--scheduler", cluster.scheduler_address, "--resume",
            "--json")
    assert r.exit_code == 0, r.output
    statuses = {n: c["status"] for n, c in json.loads(r.output)["clips"].items()}
    assert sorted(n for n, s in statuses.items() if s == "skipped") == done
    assert sorted(n for n, s in statuses.items() if s == "done") == sorted(set(statuses) - set(done))
    whole = tmp_path / "whole.h5"
    assert run("compress", src, "-o", whole, "--codec", "svd", "--jobs", "2").exit_code == 0
    assert _archive_bytes(out) == _archive_bytes(whole)
