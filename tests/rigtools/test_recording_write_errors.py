"""Write errors end in one RecordingWriteError (exit 4) and keep everything flushed.

The writer runs in a child process whose file-size limit (RLIMIT_FSIZE) is a few MB, with
SIGXFSZ ignored, so writes past the limit fail with EFBIG just as a full disk fails with ENOSPC.
The child streams known blocks (flushing every append) until the writer raises; the parent then
reads the file with the reader and ``rig info``/``rig check``.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from rigtools.cli import main
from rigtools.recording import RecordingWriteError, open_recording
from rigtools.recording.lock import lock_path

resource = pytest.importorskip("resource")

CHILD = textwrap.dedent("""
    import resource, signal, sys
    import numpy as np
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    limit = int(sys.argv[2])
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    from rigtools.recording import ChannelSpec, RecordingWriteError, RecordingWriter
    channels = [ChannelSpec(n, "N", "force", 1000.0) for n in ("a", "b")]
    with RecordingWriter(sys.argv[1], backend="simulated", rig="{}", compression=sys.argv[3],
                         flush_interval=0, chunk_samples=1024) as rec:
        try:
            for p in range(1000):
                point = rec.begin_point({"fe": 1.0 + p}, channels)
                for b in range(10):
                    point.append(np.random.default_rng([p, b]).standard_normal((2, 2000)))
                    print("F", p, point.flushed_samples, flush=True)
                point.set_attrs(settled=True)
                point.end()
        except RecordingWriteError as exc:
            print("ERROR", exc.exit_code, str(exc), flush=True)
            raise SystemExit(exc.exit_code)
""")


@pytest.mark.parametrize("compression", ["gzip", "none"])
def test_file_size_limit_ends_in_one_error_and_keeps_the_data(tmp_path, capsys, compression):
    path = tmp_path / "full.h5"
    limit = 6_000_000
    run = subprocess.run(
        [sys.executable, "-c", CHILD, str(path), str(limit), compression],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert run.returncode == 4, run.stderr
    assert "Traceback" not in run.stderr and "Segmentation" not in run.stderr
    lines = run.stdout.splitlines()
    error = [line for line in lines if line.startswith("ERROR")]
    assert len(error) == 1 and error[0].startswith("ERROR 4 ")
    assert str(path) in error[0] and "File too large" in error[0]
    flushed: dict[int, int] = {}
    for line in lines:
        if line.startswith("F"):
            _, p, n = line.split()
            flushed[int(p)] = int(n)
    assert sum(flushed.values()) >= 20_000  # a real amount was written first
    assert path.stat().st_size <= limit
    assert not lock_path(path).exists()
    with open_recording(path) as rec:
        assert rec.status == "aborted" and rec.writer is None
        assert rec.abort_reason.startswith("RecordingWriteError: cannot write")
        assert "File too large" in rec.abort_reason
        for p, n in flushed.items():
            point = rec.points[p]
            expected = np.hstack(
                [np.random.default_rng([p, b]).standard_normal((2, 2000)) for b in range(-(-n // 2000))]
            )[:, :n]
            for row, name in enumerate(("a", "b")):
                np.testing.assert_array_equal(point[name][:n], expected[row])
        assert rec.points[-1].complete is False and rec.points[0].complete is True
    assert main(["check", str(path)]) == 0  # valid, aborted: everything flushed reads
    out = capsys.readouterr().out
    assert "status aborted" in out and "File too large" in out
    assert main(["info", "--json", str(path)]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["points"][-1]["state"] == "incomplete"


def test_write_error_is_a_user_error_with_exit_4():
    assert RecordingWriteError("x").exit_code == 4
    from rigtools.errors import UserError
    from rigtools.recording import RecordingError

    assert issubclass(RecordingWriteError, RecordingError)
    assert issubclass(RecordingWriteError, UserError)
