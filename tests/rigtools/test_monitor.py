"""The live monitor's data logic, without a browser: envelopes keep every impact, the numbers it
shows for an ended point equal ``rig analyze``'s, it follows a file while it is written reading
only new samples, a stop request from it ends a run like Ctrl-C (ramp to zero recorded, reason
kept), and beyond loopback every request without the token is refused.

Simulated rig, unpaced, fixed seed (a dwell at 60 Hz, 15 N, gap 0.5 mm: one impact per period).
"""

from __future__ import annotations

import http.client
import signal
import subprocess
import sys
import threading
import urllib.error
import urllib.request

import numpy as np
import pytest

from rigtools.config import load_rig
from rigtools.monitor.control_files import STOP_REASON, LiveStatus, live_path, request_stop, stop_path
from rigtools.monitor.envelope import max_envelope, min_max_envelope
from rigtools.monitor.follow import Follower
from rigtools.procedures import RigStudy, SineDwell, Status
from rigtools.readable import number
from rigtools.recording import open_recording
from rigtools.recording_analysis.periodic import analyze_periodic

RATE = 51200.0


@pytest.fixture(scope="module")
def cfg():
    return load_rig()


@pytest.fixture(scope="module")
def dwell(cfg, tmp_path_factory):
    out = tmp_path_factory.mktemp("monitor") / "dwell.h5"
    params = {"fe": 60.0, "force": 15.0, "gap": 5e-4, "record_periods": 30}
    SineDwell(cfg, params, out, backend="sim", seed=1).run()
    return out


# -- envelopes --------------------------------------------------------------------------------------
def test_envelope_keeps_every_spike_that_striding_drops():
    """200 one-sample spikes of random height on a sine, 1 M samples drawn on 2000 points: each
    spike is in the envelope at its value and time; plain striding misses most of them. Two
    spikes inside one bucket (one pixel) show the larger, never less."""
    rng = np.random.default_rng(3)
    n, dt = 1_000_000, 1 / RATE
    y = np.sin(2 * np.pi * 60 * np.arange(n) * dt)
    # one spike in every 5th bucket of 1000 samples, anywhere inside it
    where = np.arange(200) * 5000 + rng.integers(0, 1000, 200)
    y[where] = rng.choice([-1, 1], 200) * rng.uniform(5, 50, 200)
    t, v = min_max_envelope(y, 0.0, dt, max_points=2000)
    assert len(v) <= 2002 and np.all(np.diff(t) >= 0)
    drawn = dict(zip(np.round(t / dt).astype(int), v, strict=True))
    assert all(drawn.get(int(i)) == y[i] for i in where)
    strided = set(range(0, n, n // 2000))
    assert len(strided & set(where.tolist())) < 5  # what the envelope is for
    y[where + 1] = y[where] * 0.5  # a smaller second impact in the same bucket
    _t2, v2 = min_max_envelope(y, 0.0, dt, max_points=2000)
    assert np.array_equal(v2, v)
    # a spectrum keeps its peaks
    f, a = max_envelope(np.arange(100_000.0), np.where(np.arange(100_000) == 4321, 9.0, 1.0), 500)
    assert a.max() == 9.0 and f[a.argmax()] == 4321.0


# -- numbers equal rig analyze -------------------------------------------------------------------------
def _fundamental(x: np.ndarray, rate: float, fe: float) -> float:
    """Peak amplitude of ``fe`` in ``x`` by a direct least-squares fit written here (numpy's lstsq
    on offset, cos, sin of fe and its harmonics to the 20th): the independent reference."""
    t = np.arange(x.size) / rate
    k = np.arange(1, 21)[None, :]
    basis = np.hstack(
        [
            np.ones((x.size, 1)),
            np.cos(2 * np.pi * fe * k * t[:, None]),
            np.sin(2 * np.pi * fe * k * t[:, None]),
        ]
    )
    coef = np.linalg.lstsq(basis, x, rcond=None)[0]
    return float(np.hypot(coef[1], coef[21]))


def test_ended_point_shows_what_rig_analyze_reports(dwell):
    """F1 of the ended point, shown by the monitor and reported by ``rig analyze``, equals the
    fundamental of the recorded force over the record window by a least-squares fit written in
    this test (offset and 20 harmonics): 1e-9 relative (over whole periods the harmonics are
    orthogonal, so fitting 1, 20 or 30 of them gives the same F1 up to rounding; the goal is 1 %).
    Impacts per period: one (the dwell's regime at 0.5 mm, 15 N, 60 Hz), in both."""
    snap = Follower(dwell).poll()
    with open_recording(dwell) as rec:
        point = rec.points[0]
        ref = analyze_periodic(point).dwell
        start, n = point.record_window
        force = np.asarray(point.channels["force"][start : start + n], dtype=float)
        f1 = _fundamental(force, float(point.sample_rate), float(point.params["fe"]))
    assert n * 60.0 / RATE == pytest.approx(round(n * 60.0 / RATE), abs=1e-9)  # whole periods
    assert snap.status == "finished" and snap.point == 0
    assert snap.control["f1"] == pytest.approx(f1, rel=1e-9)
    assert ref.force_amplitude == pytest.approx(f1, rel=1e-9)
    assert snap.impacts_per_period == pytest.approx(1.0) and ref.impacts.impacts_per_period == pytest.approx(
        1.0
    )
    assert snap.points[0]["f1"] == pytest.approx(f1, rel=1e-9)
    assert snap.control["target"] == 15.0 and snap.control["settled"] is True
    # the spectrum marks k·fe and names the strongest harmonics of the active shroud
    assert [f for _, f in snap.harmonics[:3]] == [60.0, 120.0, 180.0]
    assert len(snap.named) == 3 and all(k >= 2 for k, *_ in snap.named)
    # peaks against the rig's safety limits (from the recording's rig description)
    limits = {p["channel"]: p for p in snap.peaks}
    assert limits["force"]["warning"] == load_rig().safety.limits["force"].warning
    assert snap.end.startswith("the run finished") and "drive 0 V" in snap.end


_WRITER = """
import sys
import numpy as np
from rigtools.recording import ChannelSpec, RecordingWriter
rate, fe, block = 51200.0, 60.0, 5000
names = [("force", "N", "force"), ("active_shroud_accel", "m/s^2", "acceleration"),
         ("passive_shroud_accel", "m/s^2", "acceleration"), ("drive", "V", "voltage")]
specs = [ChannelSpec(n, u, q, rate) for n, u, q in names]
noise = np.random.default_rng(1)
with RecordingWriter(sys.argv[1], backend="simulated", rig="{}", experiment={}) as rec:
    point = rec.begin_point({"fe": fe, "force_amplitude": 2.0}, specs)
    for i in range(24):
        sys.stdin.readline()
        t = (i * block + np.arange(block)) / rate
        s = np.sin(2 * np.pi * fe * t)
        spike = np.where(np.abs((t * fe) % 1.0 - 0.3) < 0.5 / rate * fe, 400.0, 0.0)  # one per period
        data = np.vstack([2.0 * s, 80 * s - spike, 60 * s + spike, 0.1 * s])
        point.append(data + 0.01 * noise.standard_normal(data.shape))
        rec.flush()
        print("written", flush=True)
    sys.stdin.readline()
    point.end()
print("closed", flush=True)
"""


def test_follows_a_recording_while_it_is_written_reading_only_new_samples(tmp_path):
    """Another process appends blocks of 5000 samples (flushed, SWMR) of a response with one
    impact per period; the follower, looking after each, shows each new sample and reads every
    sample exactly once; once 1 s is there it shows F1 and exactly one impact per period at
    every look, whatever the phase of the window's edges (no impact lost or counted twice)."""
    path = tmp_path / "live.h5"
    writer = subprocess.Popen(
        [sys.executable, "-c", _WRITER, str(path)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    follower = Follower(path)
    seen, ipp, f1 = [], [], []
    try:
        for _ in range(24):
            writer.stdin.write("go\n")
            writer.stdin.flush()
            assert writer.stdout.readline().strip() == "written"
            s = follower.poll()
            for _retry in range(20):  # a look that meets the writer adding structure waits for the next
                if s.latest_t > (seen[-1] if seen else 0.0):
                    break
                s = follower.poll()
            seen.append(s.latest_t)
            if s.impacts_per_period is not None:
                ipp.append(s.impacts_per_period)
                f1.append(s.control["f1"])
        read = follower._buffer.read
        writer.stdin.write("end\n")
        writer.stdin.flush()
        assert writer.stdout.readline().strip() == "closed"
    finally:
        writer.kill()
        writer.wait()
    assert seen == pytest.approx([5000 * (i + 1) / RATE for i in range(24)])
    assert read == 24 * 5000  # every sample read once, none twice
    assert len(ipp) >= 12 and ipp == [1.0] * len(ipp)
    assert f1 == pytest.approx([2.0] * len(f1), rel=1e-3)
    s = follower.poll()
    assert s.status == "finished" and s.control["f1"] == pytest.approx(2.0, rel=1e-3)


# -- stop control and end states -----------------------------------------------------------------------
def test_stop_request_ends_the_run_like_ctrl_c_with_the_ramp_recorded(cfg, tmp_path):
    """A stop request beside the recording (what the page's stop button writes) while the dwell
    records: status aborted, reason "stopped from the monitor", the drive ramps to zero within
    [safety] abort_ramp_time in the record; the monitor shows the reason."""
    out = tmp_path / "stopped.h5"
    live = LiveStatus(out, lambda reason: proc.stop(reason))

    def progress(e):
        live.event(e)
        if e.kind == "recording":
            request_stop(out)

    params = {"fe": 60.0, "force": 15.0, "gap": 5e-4, "record_periods": 2000}
    proc = SineDwell(cfg, params, out, backend="sim", seed=1, progress=progress)
    with live:
        result = proc.run()
    assert result.status is Status.ABORTED and result.reason == STOP_REASON
    assert not stop_path(out).exists() and not live_path(out).exists()  # nothing left beside it
    with open_recording(out) as rec:
        assert rec.status == "aborted" and STOP_REASON in rec.abort_reason
        drive = np.asarray(rec.points[0].channels["drive"])
    ramp = int(cfg.safety.abort_ramp_time * RATE)
    assert np.max(np.abs(drive[-64:])) < 1e-9  # ends at zero
    before = np.max(np.abs(drive[-3 * ramp : -2 * ramp]))
    inside = np.max(np.abs(drive[-ramp // 2 :]))
    assert before > 0.5 and inside < 0.6 * before  # decreasing over the ramp, not cut
    snap = Follower(out).poll()
    assert snap.status == "aborted" and STOP_REASON in snap.status_text
    assert snap.points[0]["state"] == "stopped"


def test_finished_study_shows_every_point(cfg, tmp_path):
    """A three-point force study: every point in the table with F1 equal to rig analyze's."""
    out = tmp_path / "study.h5"
    params = {"kind": "force", "values": (5.0, 10.0, 15.0), "fe": 60.0, "gap": 5e-4, "record_periods": 12}
    RigStudy(cfg, params, out, backend="sim", seed=1, confirm_gap=lambda g, i: None).run()
    snap = Follower(out).poll()
    assert [r["point"] for r in snap.points] == [0, 1, 2]
    with open_recording(out) as rec:
        for row, point in zip(snap.points, rec.points, strict=True):
            ref = analyze_periodic(point).dwell
            assert row["f1"] == pytest.approx(ref.force_amplitude, rel=1e-9)
            assert row["impacts_per_period"] == ref.impacts.impacts_per_period
    assert [r["target"] for r in snap.points] == [5.0, 10.0, 15.0]


# -- access --------------------------------------------------------------------------------------------
def _status(url: str, headers: dict | None = None) -> int:
    try:
        with urllib.request.urlopen(urllib.request.Request(url, headers=headers or {}), timeout=20) as r:
            return r.status
    except urllib.error.HTTPError as exc:
        return exc.code


def test_beyond_loopback_every_request_without_the_token_is_refused(dwell):
    """Served on 0.0.0.0: the page and its data websocket (through which the stop control
    works) answer 403 without the token or with a wrong one; with it the page loads."""
    cmd = [sys.executable, "-m", "rigtools.cli", "monitor", str(dwell), "--host", "0.0.0.0", "--port", "0"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    timer = threading.Timer(60, proc.kill)
    timer.start()
    try:
        url = proc.stdout.readline().strip()
        base, token = url.split("?token=")
        port = int(base.rsplit(":", 1)[1].split("/")[0])
        local = f"http://127.0.0.1:{port}/monitor"
        assert len(token) >= 32
        assert _status(local) == 403
        wrong = token[:-1] + ("y" if token[-1] == "x" else "x")  # one character off, never the token
        assert _status(local + "?token=" + wrong) == 403
        assert _status(local + "?token=" + token) == 200
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=20)
        upgrade = {
            "Connection": "Upgrade",
            "Upgrade": "websocket",
            "Sec-WebSocket-Version": "13",
            "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ==",
        }
        conn.request("GET", "/monitor/ws", headers=upgrade)
        assert conn.getresponse().status == 403
        proc.send_signal(signal.SIGINT)  # Ctrl-C ends the monitor with the documented 130
        assert proc.wait(timeout=30) == 130
    finally:
        timer.cancel()
        proc.kill()
        proc.wait()


def test_a_bare_websocket_upgrade_is_one_line_and_the_monitor_serves_on(dwell):
    """A websocket upgrade without bokeh's subprotocol (a port scanner, curl) printed tornado's
    full traceback of bokeh's ProtocolError: now one line; the page still loads; Ctrl-C is 130."""
    cmd = [sys.executable, "-m", "rigtools.cli", "monitor", str(dwell), "--port", "0"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    timer = threading.Timer(60, proc.kill)
    timer.start()
    try:
        url = proc.stdout.readline().strip()
        port = int(url.rsplit(":", 1)[1].split("/")[0])
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=20)
        upgrade = {
            "Connection": "Upgrade",
            "Upgrade": "websocket",
            "Sec-WebSocket-Version": "13",
            "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ==",
        }
        conn.request("GET", "/monitor/ws", headers=upgrade)
        conn.getresponse()
        conn.close()
        assert _status(f"http://127.0.0.1:{port}/monitor") == 200
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=30) == 130
        err = proc.stderr.read()
        assert "Traceback" not in err, err
        assert "rig monitor: refused a request: ProtocolError: Subprotocol header is not 'bokeh'" in err
    finally:
        timer.cancel()
        proc.kill()
        proc.wait()


def test_sigterm_ends_the_monitor_with_143(dwell):
    """SIGTERM (kill, a job scheduler) ends it with 128 + 15, as every command (130 before)."""
    cmd = [sys.executable, "-m", "rigtools.cli", "monitor", str(dwell), "--port", "0"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    timer = threading.Timer(60, proc.kill)
    timer.start()
    try:
        assert proc.stdout.readline().startswith("http://127.0.0.1:")  # serving: the handlers are set
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=30) == 143
    finally:
        timer.cancel()
        proc.kill()
        proc.wait()


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (
            ["--port", "99999"],
            "--port = 99999: a TCP port is 0 (a free one) to 65535",
        ),  # bokeh's AssertionError
        (["--linger", "nan"], "--linger = 'nan'"),  # served forever
        (["--linger", "-1"], "--linger = '-1': must be >= 0"),
        (
            ["--file-is-a-folder"],
            "not a file (a recording, or where one will be written)",
        ),  # followed forever
    ],
)
def test_bad_monitor_options_are_one_line(tmp_path, args, words):
    from cli_helpers import run_cli

    target = tmp_path / "run.h5"
    if args == ["--file-is-a-folder"]:
        target.mkdir()
        args = []
    code, out, err = run_cli(["monitor", target, "--port", "0", *args])
    assert code == 2 and out == "" and "Traceback" not in err, err
    (line,) = err.strip().splitlines()
    assert words in line, line


# -- in the browser (one test: the suite's budget) -------------------------------------------------
def test_page_shows_the_numbers_in_chromium(dwell, chromium, tmp_path):
    """``rig monitor`` on the finished dwell, looked at in headless Chromium by two viewers: both
    pages show F1 and impacts per period as rig analyze reports them, the status, and drawn plots."""
    from headless_chromium import Chromium, figure_is_drawn
    from matplotlib import image as mpimg

    with open_recording(dwell) as rec:
        ref = analyze_periodic(rec.points[0]).dwell
    cmd = [sys.executable, "-m", "rigtools.cli", "monitor", str(dwell), "--port", "0"]
    server = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    timer = threading.Timer(90, server.kill)
    timer.start()
    try:
        url = server.stdout.readline().strip()
        with Chromium(chromium) as browser:
            pages = [browser.open(url), browser.open(url)]
            for page in pages:
                page.wait_text("mon-status", 60, "finished")
                shown = page.texts("mon-f1", "mon-ipp", "mon-status")
                assert shown["mon-f1"] == number(ref.force_amplitude, unit="N")
                assert float(shown["mon-ipp"]) == pytest.approx(ref.impacts.impacts_per_period)
            shot = mpimg.imread(str(pages[0].screenshot(tmp_path / "page.png")))[..., :3]
    finally:
        timer.cancel()
        server.kill()
        server.wait()
    assert figure_is_drawn(shot[60:560, 0:800])  # the traces
    assert figure_is_drawn(shot[560:900, 0:800])  # the spectrum
