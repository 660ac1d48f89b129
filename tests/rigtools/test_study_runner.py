"""The study runner: one code path in-process and on a real Dask LocalCluster, results in point
order and bit-identical whatever the number of workers; a worker that dies loses no point."""

from __future__ import annotations

import functools
import os
import sys
from pathlib import Path

import cloudpickle
import numpy as np
import pytest

from rigtools.config import load_rig
from rigtools.sim.reduction import reduced_system
from rigtools.study_runner import RunOptions, StudyRunner, map_chains, run_point

OPTIONS = RunOptions(record_duration=0.1, max_settle_time=3.0)
CHAINS = map_chains([0.3e-3, 0.5e-3, 0.7e-3], [10.0, 15.0, 20.0], [58.0, 60.0, 62.0])
cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers cannot import tests/


@pytest.fixture(scope="module")
def system():
    return reduced_system(load_rig(None).to_params(), "fem")


@pytest.fixture(scope="module")
def in_process(system):
    return [(p, r) for p, r in StudyRunner().run(system, CHAINS, OPTIONS)]


def _same(a, b):
    assert [p.index for p, _ in a] == [p.index for p, _ in b] == list(range(27))
    for (pa, ra), (pb, rb) in zip(a, b, strict=True):
        assert pa == pb
        for key, value in ra.outputs.items():
            assert np.array_equal(value, rb.outputs[key]), (pa.index, key)


def test_map_chains_cover_the_grid_in_row_major_order():
    points = [p for chain in CHAINS for p in chain]
    assert len(CHAINS) == 9 and all(len(c) == 3 for c in CHAINS)
    assert [p.index for p in points] == list(range(27))
    assert (points[0].gap, points[0].force, points[0].fe) == (0.3e-3, 10.0, 58.0)
    assert (points[5].gap, points[5].force, points[5].fe) == (0.3e-3, 15.0, 62.0)
    assert (points[26].gap, points[26].force, points[26].fe) == (0.7e-3, 20.0, 62.0)


def test_in_process_carries_state_like_a_plain_loop(system, in_process):
    # chain 0 by hand: each point starts from the previous one's final state
    previous = None
    for point in CHAINS[0]:
        previous = run_point(system, point, OPTIONS, previous)
        got = in_process[point.index][1]
        assert np.array_equal(got.outputs["contact_force"], previous.outputs["contact_force"])


def _worker_env() -> dict:
    from rigtools.runtime import MALLOC_TUNING_VARS
    from rigtools.worker_plugin import worker_settings

    return {"environ": {k: os.environ[k] for k in MALLOC_TUNING_VARS if k in os.environ}, **worker_settings()}


def test_two_worker_cluster_is_bit_identical(system, in_process):
    before = os.environ.get("MALLOC_TRIM_THRESHOLD_")
    with StudyRunner(workers=2) as runner:
        assert runner.n_workers == 2
        got = list(runner.run(system, CHAINS, OPTIONS))
        seen = runner.client.run(_worker_env)
    _same(in_process, got)
    assert runner.report.retried == []
    # no allocator variable in the workers (glibc's adaptive mmap threshold stays on) nor leaked
    # into this process by the nanny; the plugin ran in every worker
    assert len(seen) == 2
    for info in seen.values():
        assert info["environ"] == {}
        assert info["allocator"] in ("adaptive", "not glibc")
        assert info["blas_threads"] == 1
    assert os.environ.get("MALLOC_TRIM_THRESHOLD_") == before


def _dies_once(marker: str, index: int, system, point, options, previous):
    """run_point, except that the worker running point ``index`` dies the first time."""
    if point.index == index and not os.path.exists(marker):
        Path(marker).write_text(str(os.getpid()))
        os._exit(1)
    return run_point(system, point, options, previous)


def test_killed_worker_loses_no_point(system, in_process, tmp_path):
    marker = str(tmp_path / "killed")
    with StudyRunner(workers=2) as runner:
        got = list(runner.run(system, CHAINS, OPTIONS, point_fn=functools.partial(_dies_once, marker, 13)))
        runner.client.wait_for_workers(2, timeout=120)  # the nanny restarts the dead one
        seen = runner.client.run(_worker_env)
    assert Path(marker).exists()  # the worker really died
    # the restarted worker got the process settings too (a worker plugin, not a one-off run)
    assert len(seen) == 2 and all(info.get("blas_threads") == 1 for info in seen.values())
    retried = [i for i, _ in runner.report.retried]
    # point 13 killed its worker; points queued on the same worker were lost with it: each rerun once
    assert 13 in retried and len(set(retried)) == len(retried)
    _same(in_process, got)


def test_workers_and_scheduler_exclude_each_other():
    from rigtools.errors import UserError

    with pytest.raises(UserError, match="exclude"):
        StudyRunner(workers=2, scheduler="tcp://127.0.0.1:1")


def test_rig_study_map_same_file_on_two_workers(tmp_path):
    """`rig study map` in-process and with --workers 2 write the same points, bit for bit."""
    from rigtools.cli import main
    from rigtools.recording import open_recording

    argv = [
        "study",
        "map",
        "--gap",
        "0.3 mm,0.5 mm",
        "--force",
        "15 N",
        "--fe",
        "58 Hz,60 Hz",
        "--duration",
        "0.1 s",
        "--max-settle",
        "3 s",
        "--json",
    ]
    assert main([*argv, "--out", str(tmp_path / "one.h5")]) == 0
    assert main([*argv, "--workers", "2", "--out", str(tmp_path / "two.h5")]) == 0
    with open_recording(tmp_path / "one.h5") as a, open_recording(tmp_path / "two.h5") as b:
        assert len(a.points) == len(b.points) == 4
        for pa, pb in zip(a.points, b.points, strict=True):
            assert (pa.params["gap"], pa.params["fe"]) == (pb.params["gap"], pb.params["fe"])
            for name in pa.channels:
                assert np.array_equal(pa[name].read(), pb[name].read()), name
    assert [(p.params["gap"], p.params["fe"]) for p in open_recording(tmp_path / "one.h5").points] == [
        (0.3e-3, 58.0),
        (0.3e-3, 60.0),
        (0.5e-3, 58.0),
        (0.5e-3, 60.0),
    ]
