"""A study on a real Dask cluster: a ``dask scheduler`` and two ``dask worker`` processes started
here on localhost (as a lab starts them, or dask-jobqueue does on SLURM/PBS), reached through
``rig study --scheduler``. The recording must equal the in-process one value for value, and every
worker must carry the process settings of the worker plugin (a ``dask worker`` nanny sets
``MALLOC_TRIM_THRESHOLD_``: the plugin resets glibc's thresholds with mallopt)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import cloudpickle
import numpy as np
import pytest

from rigtools import study_runner
from rigtools.cli import main
from rigtools.recording import open_recording

STARTUP_TIMEOUT_S = 180.0  # a loaded 2-core machine can take a minute to start four processes
cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers cannot import tests/


def _start(args: list[str], log: Path) -> subprocess.Popen:
    with open(log, "wb") as f:
        return subprocess.Popen(
            [sys.executable, "-m", "dask", *args],
            stdout=f,
            stderr=subprocess.STDOUT,
            start_new_session=True,  # its own process group: the nanny's worker goes with it
        )


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is not None:
        return
    os.killpg(proc.pid, signal.SIGTERM)
    try:
        proc.wait(timeout=30)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """Address of a scheduler with two single-threaded workers (processes stopped afterwards)."""
    from distributed import Client

    tmp = tmp_path_factory.mktemp("cluster")
    scheduler_file = tmp / "scheduler.json"
    procs: list[subprocess.Popen] = []
    try:
        procs.append(
            _start(
                [
                    "scheduler",
                    "--host",
                    "127.0.0.1",
                    "--port",
                    "0",
                    "--no-dashboard",
                    "--scheduler-file",
                    str(scheduler_file),
                ],
                tmp / "scheduler.log",
            )
        )
        deadline = time.monotonic() + STARTUP_TIMEOUT_S
        while not scheduler_file.exists():
            assert procs[0].poll() is None, (tmp / "scheduler.log").read_text()[-2000:]
            assert time.monotonic() < deadline, "the scheduler did not start"
            time.sleep(0.2)
        for i in range(2):
            procs.append(
                _start(
                    [
                        "worker",
                        "--scheduler-file",
                        str(scheduler_file),
                        "--nthreads",
                        "1",
                        "--no-dashboard",
                        "--name",
                        f"w{i}",
                        "--local-directory",
                        str(tmp / f"w{i}"),
                    ],
                    tmp / f"worker{i}.log",
                )
            )
        address = json.loads(scheduler_file.read_text())["address"]
        with Client(address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=max(1.0, deadline - time.monotonic()))
        yield address
    finally:
        for proc in reversed(procs):
            _stop(proc)


def _worker_info() -> dict:
    from rigtools.worker_plugin import worker_settings

    return {"trim": os.environ.get("MALLOC_TRIM_THRESHOLD_"), **worker_settings()}


ARGV = [
    "study",
    "gap",
    "--values",
    "0.3 mm,0.5 mm,0.7 mm,0.9 mm",
    "--fe",
    "60 Hz",
    "--force",
    "15 N",
    "--duration",
    "0.1 s",
    "--max-settle",
    "3 s",
    "--from-rest",
    "--json",
]


def test_rig_study_on_scheduler_equals_in_process(cluster, tmp_path, capsys):
    from distributed import Client

    assert main([*ARGV, "--out", str(tmp_path / "here.h5")]) == 0
    assert main([*ARGV, "--scheduler", cluster, "--out", str(tmp_path / "cluster.h5")]) == 0
    capsys.readouterr()
    with open_recording(tmp_path / "here.h5") as a, open_recording(tmp_path / "cluster.h5") as b:
        assert len(a.points) == len(b.points) == 4
        for pa, pb in zip(a.points, b.points, strict=True):
            assert pa.params["gap"] == pb.params["gap"]
            for name in pa.channels:
                assert np.array_equal(pa[name].read(), pb[name].read()), name
    with Client(cluster, timeout="60s") as client:
        info = client.run(_worker_info)
    assert len(info) == 2
    for worker in info.values():
        # the nanny of `dask worker` set the variable; the plugin reset glibc's thresholds
        assert worker["trim"] is not None
        assert worker["allocator"] in ("mallopt", "not glibc")
        assert worker["blas_threads"] == 1


def test_unreachable_scheduler_is_one_line(tmp_path, capsys, monkeypatch):
    """Refused in one line once the connection timeout is over (shortened here from 10 s to 1 s:
    waiting is not what is checked)."""
    monkeypatch.setattr(study_runner, "SCHEDULER_CONNECT_TIMEOUT", "1s")
    code = main([*ARGV, "--scheduler", "tcp://127.0.0.1:9", "--out", str(tmp_path / "x.h5")])
    err = capsys.readouterr().err
    assert code != 0
    assert "cannot reach the Dask scheduler tcp://127.0.0.1:9" in err
    assert "Traceback" not in err
