"""``rig continuation`` through rigtools.cli.main: a branch without contact against ``rig harmonic``
(0.1 %), the stored file (kind "branches"), --json, one-line refusals (exit 2) and --measured
reading a simulated stepped sine (its fundamentals as the sweep procedure recorded them)."""

from __future__ import annotations

import csv
import json
import re

import h5py
import numpy as np
import pytest
from cli_helpers import run_cli

SHORT = ["--param", "fe", "--from", "55", "--to", "58", "--force", "15 N", "--gap", "5 mm", "--no-switch"]


@pytest.fixture(scope="module")
def no_contact(tmp_path_factory):
    """A 55-58 Hz branch at a 5 mm gap (no orbit closes it) with --json, and ``rig harmonic``."""
    d = tmp_path_factory.mktemp("cont")
    code, out, err = run_cli(["continuation", *SHORT, "--measure", "accel1", "--out", d / "b.h5", "--json"])
    assert code == 0, err
    hcode, _, herr = run_cli(
        [
            "harmonic",
            "--force",
            "15 N",
            "--fmin",
            "55",
            "--fmax",
            "58",
            "--points",
            "601",
            "--out",
            d / "h.csv",
        ]
    )
    assert hcode == 0, herr
    with open(d / "h.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    lin = {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}
    return json.loads(out), d / "b.h5", lin


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    """A short stepped sine of the simulated rig, up and down, no contact (5 mm gap)."""
    path = tmp_path_factory.mktemp("sweep") / "sw.h5"
    code, _, err = run_cli(
        ["acquire", "sweep", "--backend", "sim", "--frequencies", "56 Hz,57 Hz,58 Hz", "--force", "15 N"]
        + ["--gap", "5 mm", "--direction", "both", "--periods", "5", "--out", path]
    )
    assert code == 0, err
    return path


def test_branch_without_contact_is_rig_harmonic(no_contact):
    doc, path, lin = no_contact
    with h5py.File(path) as f:
        g = f["branches/00"]
        fe = g["value"][()]
        acc = g["measures/accel_harmonics_active"][()][:, 0]
        tip = g["measures/tip_amplitude_active"][()]
        mult = np.hypot(g["multipliers_real"][()], g["multipliers_imag"][()])
    assert fe[0] == pytest.approx(55.0) and fe[-1] == pytest.approx(58.0) and fe.size >= 3
    # rig harmonic's 5 mHz grid, linearly interpolated: 1e-6 relative here, far from resonance
    f = lin["frequency_hz"]
    np.testing.assert_allclose(acc, np.interp(fe, f, lin["fem_active_shroud_acceleration_m_s2"]), rtol=1e-3)
    np.testing.assert_allclose(tip, np.interp(fe, f, lin["fem_active_shroud_displacement_m"]), rtol=1e-3)
    assert np.all(mult < 1.0)
    assert doc["branches"][0]["status"] == "complete"


def test_file_kind_and_content(no_contact):
    _, path, _ = no_contact
    with h5py.File(path) as f:
        assert f.attrs["kind"] == "branches" and f.attrs["schema"] == "rigtools-branches"
        exp = json.loads(f.attrs["experiment"])
        assert exp["param"] == "fe" and exp["from"] == 55.0 and exp["to"] == 58.0
        assert exp["gap"] == pytest.approx(5e-3) and exp["force"] == 15.0 and exp["model"] == "fem"
        assert list(f["branches"]) == ["00"]
        g = f["branches/00"]
        assert g.attrs["periods"] == 1 and g.attrs["status"] == "complete"
        assert np.all(g["stable"][()])
        labels = json.loads(g.attrs["labels"])
        assert labels[0] == ["start"] and labels[-1] == ["end"] and not any(labels[1:-1])
        assert np.all(g["measures/peak_contact_force"][()] == 0.0)
        assert np.all(g["measures/min_gap"][()] > 0.4e-3)  # never closes


def test_json_document(no_contact, tmp_path):
    doc, path, _ = no_contact
    assert set(doc) == {"branches", "out", "plot"}
    assert doc["out"] == str(path) and doc["plot"] == str(path.with_suffix(".png"))
    (b,) = doc["branches"]
    assert b["periods"] == 1 and b["points"] > 2
    assert [x["label"] for x in b["bifurcations"]] == ["start", "end"]
    assert path.with_suffix(".png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--param", "fe", "--from", "60", "--to", "60 Hz"], "give a range"),
        (["--param", "fe", "--from", "fast", "--to", "60"], "--from"),
        (["--param", "gap", "--from", "-1 mm", "--to", "1 mm"], "--from"),
        (["--param", "fe", "--from", "55", "--to", "60", "--drive", "1 V"], "--model rig"),
        (["--param", "fe", "--from", "55", "--to", "60", "--model", "rig", "--drive", "-1 V"], "--drive"),
        (["--param", "force", "--from", "1 N", "--to", "2 N", "--model", "rig", "--drive", "1 V"], "--from"),
        (["--param", "fe", "--from", "55", "--to", "60", "--measured", "missing.h5"], "missing.h5"),
        # the force was silently not held
        (
            [
                "--param",
                "fe",
                "--from",
                "55",
                "--to",
                "60",
                "--model",
                "rig",
                "--drive",
                "1 V",
                "--force",
                "3 N",
            ],
            "--force = '3 N' with --drive = '1 V': the model holds either",
        ),
        # "1 MN" for "1 mN": the rig's model continues a 40 m orbit unless refused (as rig simulate)
        (
            [
                "--param",
                "fe",
                "--from",
                "60",
                "--to",
                "60.2",
                "--model",
                "rig",
                "--force",
                "1 MN",
                "--no-switch",
            ],
            "moves 39.6 m, more than any blade",
        ),
    ],
)
def test_bad_input_is_one_line_exit_2(tmp_path, args, words):
    code, _, err = run_cli(["continuation", *args, "--out", tmp_path / "x.h5"])
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and words in lines[0] and "Traceback" not in err
    assert not (tmp_path / "x.h5").exists()


def test_measured_overlay_reads_the_sweep(sweep, tmp_path):
    from rigtools.measured_sweeps import measured_sweeps
    from rigtools.recording import open_recording

    got = measured_sweeps([sweep], "fe", "accel1")
    assert [m.direction for m in got] == ["up", "down"]
    # the down sweep starts below the top step (rig acquire sweep does not repeat it)
    assert list(got[0].value) == [56.0, 57.0, 58.0] and list(got[1].value) == [57.0, 56.0]
    assert all(m.jumps == [] for m in got)
    with open_recording(sweep) as rec:
        recorded = [float(p.params["active_shroud_accel_harmonic_amplitude"][0]) for p in rec.complete_points]
    # the sweep procedure's own fit of the record window, 1e-6
    np.testing.assert_allclose(np.concatenate([m.measure for m in got]), recorded, rtol=1e-6)
    out = tmp_path / "m.h5"
    code, _, err = run_cli(["continuation", *SHORT, "--measure", "accel1", "--measured", sweep, "--out", out])
    assert code == 0, err
    with h5py.File(out) as f:
        assert json.loads(f.attrs["experiment"])["measured"] == [str(sweep)]
    # a rig recording has no contact force: refused in one line before any work
    code, _, err = run_cli(["continuation", *SHORT, "--measured", sweep, "--out", tmp_path / "c.h5"])
    assert code == 2 and "--measure accel1" in err and len(err.strip().splitlines()) == 1


def test_out_is_never_a_measured_recording(sweep, tmp_path):
    """--overwrite or not, --out naming a --measured recording (also by another spelling) is
    refused before any work, the recording unchanged (it was replaced by the branches before)."""
    rec = tmp_path / "sw.h5"
    rec.write_bytes(sweep.read_bytes())
    before = rec.read_bytes()
    for out in (rec, tmp_path / "." / "sw.h5"):
        code, _, err = run_cli(
            ["continuation", *SHORT, "--measure", "accel1", "--measured", rec, "--out", out, "--overwrite"]
        )
        assert code == 2 and "is an input of this command" in err and len(err.strip().splitlines()) == 1
    assert rec.read_bytes() == before


def test_report_draws_branches_over_matching_recordings_only(no_contact, sweep, tmp_path):
    """``rig report --branches``: a branch file continued at the sweep's fixed quantities is drawn
    in the sweep's section with its jump-free overlay; one at another force is not drawn over it
    (a note says why, with both forces) and gets a section of its own; an imported recording
    or another rig's is never drawn over the rig's branches."""
    from types import SimpleNamespace

    import rigtools
    from rigtools.branches_file import write_branches
    from rigtools.config import load_rig
    from rigtools.report.branches import load_branch_files, why_not

    _, b15, _ = no_contact
    cfg = load_rig(None)
    other = rigtools.continuation("fe", "56 Hz", "57 Hz", force="10 N", gap="5 mm", switch=False)
    experiment = {"procedure": "continuation", "param": "fe", "from": 56.0, "to": 57.0}
    experiment |= {"fe": 60.0, "force": 10.0, "gap": 5e-3, "model": "fem", "measured": []}
    b10 = write_branches(tmp_path / "b10.h5", other, cfg.to_json(), experiment)
    code, _, err = run_cli(["report", sweep, "--branches", b15, b10, "--out", tmp_path / "rep"])
    assert code == 0, err
    page = (tmp_path / "rep" / "report.html").read_text()
    sections = page.split("<section>")
    (mine,) = [s for s in sections if s.startswith("<h2>sw.h5")]
    assert 'alt="b.h5 (FEM, F0 15 N, gap 5 mm): the model&#x27;s periodic orbits continued in fe' in mine
    assert "sw (up), sw (down) (up ^, down v)" in mine and "The sweeps drawn show no jump." in mine
    assert "b10.h5: continued at F0 10 N, this recording runs at F0 15 N: not drawn over it" in mine
    (own,) = [s for s in sections if s.startswith("<h2>b10.h5: model branches</h2>")]
    assert "drawn over no recording of this report" in own and 'alt="b10.h5 (FEM, F0 10 N, gap 5 mm)' in own
    assert len(re.findall(r'<img class="figure"[^>]* alt="b(?:10)?\.h5 \(FEM', page)) == 2
    # the rule: an imported recording does not describe this rig; another rig's neither
    (bf,) = load_branch_files([b15])
    imported = SimpleNamespace(procedure="import", periodic=[])
    assert "imported recording, it does not describe this rig" in why_not(bf, imported, cfg.to_json())
    longer = cfg.model_copy(update={"blade": cfg.blade.model_copy(update={"length": cfg.blade.length * 1.1})})
    own_rig = SimpleNamespace(procedure="stepped sine", periodic=[])
    assert why_not(bf, own_rig, cfg.to_json()) == ""
    assert "another rig description" in why_not(bf, own_rig, longer.to_json())


def test_rig_model_held_drive(tmp_path):
    """--model rig --drive: the simulated rig's model at a held drive, continued in the drive
    amplitude (5 mm gap, no contact): the force fundamental is proportional to the drive, and
    equals the shaker's closed-form force per drive volt with the test article's receptance
    (all FE modes), 0.1 %."""
    from rigtools.config import load_rig
    from rigtools.sim.harmonic import fem_harmonic_response
    from rigtools.sim.rig_model import build_rig_model

    out = tmp_path / "rig.h5"
    args = ["--param", "force", "--from", "0.4 V", "--to", "600 mV", "--fe", "57 Hz", "--gap", "5 mm"]
    code, _, err = run_cli(
        ["continuation", *args, "--model", "rig", "--drive", "0.5 V", "--no-switch", "--out", out]
    )
    assert code == 0, err
    with h5py.File(out) as f:
        exp = json.loads(f.attrs["experiment"])
        g = f["branches/00"]
        drive, f1 = g["value"][()], g["measures/force_fundamental"][()]
        np.testing.assert_allclose(g["measures/drive_amplitude"][()], drive)
    assert exp["model"] == "rig" and exp["drive"] is True and exp["from"] == 0.4 and exp["to"] == 0.6
    assert drive[0] == pytest.approx(0.4) and drive[-1] == pytest.approx(0.6)
    cfg = load_rig(None)
    article = build_rig_model(cfg.test_article.to_params().apply(cfg.to_params()))
    receptance = fem_harmonic_response(article, np.array([57.0]), 1.0).displacement["active_force_point"]
    per_volt = abs(cfg.shaker.to_params().sensor_force_per_drive(np.array([57.0]), receptance)[0])
    np.testing.assert_allclose(f1, drive * per_volt, rtol=1e-3)


def test_period_two_branch_leaving_a_range_edge_it_is_not_followed_past(tmp_path):
    """60.3-61 Hz: the period-2 branch born in the range runs down through 60.3 Hz in one step (fe
    is followed upwards only); it ends there, named, instead of an IndexError's traceback. (There
    were two: the second was born at a false period doubling where a second impact grazes in at
    60.49 Hz, now labelled grazing; issue 29.)"""
    out = tmp_path / "b.h5"
    code, text, err = run_cli(["continuation", "--param", "fe", "--from", "60.3", "--to", "61", "--out", out])
    assert code == 0, err
    ends = [line for line in text.splitlines() if "left the range at 60.3 Hz" in line]
    assert len(ends) == 1, text
    assert "grazing 60.48" in text and text.count("period-doubling 60.51") == 1
    assert all(
        "left range the branch left the range at 60.3 Hz, where it is followed no further" in e for e in ends
    )


@pytest.fixture
def ctrl_c_after_30_steps(monkeypatch):
    """A KeyboardInterrupt raised in the corrector after 30 corrector steps, as the signal
    handler raises it."""
    from rigtools.sim.orbit_tracer import BranchTracer

    correct, calls = BranchTracer.correct, []

    def interrupted(self, prev, h):
        calls.append(h)
        if len(calls) > 30:
            raise KeyboardInterrupt
        return correct(self, prev, h)

    monkeypatch.setattr(BranchTracer, "correct", interrupted)


def test_ctrl_c_keeps_the_points_computed(tmp_path, ctrl_c_after_30_steps):
    """Ctrl-C after 30 corrector steps (KeyboardInterrupt raised in the corrector, as the signal
    handler raises it): exit 130, and the file holds the branch's points so far, "interrupted",
    its last point where the message says; no .partial left."""
    from rigtools.branches_file import read_branches

    out = tmp_path / "b.h5"
    code, _, err = run_cli(["continuation", *SHORT, "--out", out])
    assert code == 130, err
    assert re.search(r"kept (\d+) points of 1 branch\(es\) computed so far in", err), err
    _, (b,) = read_branches(out)
    assert b.status == "interrupted" and 10 <= len(b.value) <= 31
    assert f"interrupted after fe = {b.value[-1]:.6g} Hz" in b.message
    assert b.value[0] == 55.0 and np.all(np.diff(b.value) > 0) and b.value[-1] < 58.0
    assert f"kept {len(b.value)} points" in err
    assert not list(tmp_path.glob("*.partial"))


@pytest.mark.parametrize(
    ("damage", "words"),
    [
        ("stable", "a damaged branches file: /branches/00/stable: missing"),
        ("branches", "a damaged branches file: /branches: missing"),
        ("missing", "x.h5: no such file"),
        ("folder", "x.h5: not a file"),
        ("half", "truncated HDF5 file"),
    ],
)
def test_report_refuses_a_damaged_branch_file_in_one_line(no_contact, sweep, tmp_path, damage, words):
    """A branches file with a dataset or group gone, missing, a folder or cut in half: one line,
    exit 2 (a KeyError's traceback, h5py's whole error text before)."""
    _, good, _ = no_contact
    bad = tmp_path / "x.h5"
    if damage == "folder":
        bad.mkdir()
    elif damage == "half":
        data = good.read_bytes()
        bad.write_bytes(data[: len(data) // 2])
    elif damage != "missing":
        bad.write_bytes(good.read_bytes())
        with h5py.File(bad, "a") as f:
            del f["branches/00/stable" if damage == "stable" else "branches"]
    code, _, err = run_cli(["report", sweep, "--branches", bad, "--out", tmp_path / "rep"])
    assert code == 2 and "Traceback" not in err, err
    (line,) = err.strip().splitlines()
    assert words in line, line


@pytest.mark.parametrize("command", [["analyze"], ["export", "uff"], ["report"]])
def test_a_branches_file_where_a_recording_is_expected_is_named(no_contact, tmp_path, command):
    """One line saying what the file is and what reads it, exit 2 (the schema names only before)."""
    _, path, _ = no_contact
    tail = {"export": [tmp_path / "x.uff"], "report": ["--out", tmp_path / "rep"]}.get(command[0], [])
    code, _, err = run_cli([*command, path, *tail])
    assert code == 2 and "Traceback" not in err, err
    (line,) = err.strip().splitlines()
    assert "a branches file of rig continuation (rig report --branches draws it)" in line, line


def test_info_describes_a_branches_file(no_contact, tmp_path):
    """``rig info`` of a branches file (exit 2 "not a rigtools recording" before): the range, the
    quantities held, a row per branch with its bifurcations (here one fold written into a copy)."""
    doc, path, _ = no_contact
    marked = tmp_path / "fold.h5"
    marked.write_bytes(path.read_bytes())
    with h5py.File(marked, "a") as f:
        g = f["branches/00"]
        labels = json.loads(g.attrs["labels"])
        labels[10] = ["fold"]
        g.attrs["labels"] = json.dumps(labels)
        fold_hz = float(g["value"][10])
        n, stable = g["value"].size, int(np.count_nonzero(g["stable"][()]))
    code, out, err = run_cli(["info", marked, "--json"])
    info = json.loads(out)
    assert code == 0, err
    assert (info["kind"], info["param"], info["rig"]) == ("branches", "fe", "default steel rig")
    (b,) = info["branches"]
    assert (b["periods"], b["points"], b["stable_points"], b["from"], b["to"]) == (1, n, stable, 55.0, 58.0)
    assert b["bifurcations"] == [{"label": "fold", "value": fold_hz}]
    assert b["points"] == doc["branches"][0]["points"]
    code, out, err = run_cli(["info", marked])
    words = " ".join(out.split())  # however the console wraps it
    assert code == 0 and "branches of rig continuation (FEM model, rig default steel rig)" in words
    assert "fe from 55 to 58 Hz; force 15 N, gap 5 mm;" in words
    assert f"fold {fold_hz:.6g}" in words


def test_check_passes_a_branches_file(no_contact):
    """``rig check`` knows a branches file (it said "INVALID recording", exit 1, before)."""
    doc, path, _ = no_contact
    n = doc["branches"][0]["points"]
    code, out, _ = run_cli(["check", path])
    assert code == 0 and out.strip() == (
        f"{path}: valid rigtools branches file of rig continuation (1 branch(es), {n} points; "
        "rig report --branches draws them)"
    )
    code, out, _ = run_cli(["check", path, "--json"])
    got = json.loads(out)
    assert code == 0 and (got["kind"], got["valid"], got["branches"], got["points"], got["problems"]) == (
        "branches",
        True,
        1,
        n,
        [],
    )


def _drop_stable(f):
    del f["branches/00/stable"]


def _short_labels(f):
    f["branches/00"].attrs["labels"] = json.dumps([["start"]])


def _inf_value(f):
    f["branches/00/value"][3] = np.inf


def _no_contact_measure(f):
    del f["branches/00/measures/peak_contact_force"]


def _no_branch(f):
    del f["branches/00"]  # an empty /branches group: was "valid ... (0 branch(es), 0 points ...)"


@pytest.mark.parametrize(
    ("damage", "where", "message"),
    [
        (_no_branch, "/branches", "holds no branch (rig report --branches would draw nothing)"),
        (_drop_stable, "/branches/00/stable", "missing"),
        (_short_labels, "/branches/00", "labels holds 1 entries for {n} points"),
        (_inf_value, "/branches/00/value", "1 non-finite value(s), first at point 3"),
        (
            _no_contact_measure,
            "/branches/00/measures",
            "peak_contact_force missing (rig report --branches draws them)",
        ),
    ],
)
def test_check_finds_each_damage_of_a_branches_file(no_contact, tmp_path, damage, where, message):
    doc, good, _ = no_contact
    bad = tmp_path / "bad.h5"
    bad.write_bytes(good.read_bytes())
    with h5py.File(bad, "a") as f:
        damage(f)
    code, out, err = run_cli(["check", bad])
    lines = out.splitlines()
    assert code == 1 and "Traceback" not in err, out + err
    assert lines[0] == f"{bad}: INVALID branches file (1 problem)"
    assert lines[1] == f"  error: {where}: {message.format(n=doc['branches'][0]['points'])}"
    if damage is _inf_value:  # --quick reads no values
        assert run_cli(["check", bad, "--quick"])[0] == 0


def test_check_of_a_newer_branches_file_is_unreadable(no_contact, tmp_path):
    _, good, _ = no_contact
    newer = tmp_path / "newer.h5"
    newer.write_bytes(good.read_bytes())
    with h5py.File(newer, "a") as f:
        f.attrs["schema_version"] = 2
    code, _, err = run_cli(["check", newer])
    (line,) = err.strip().splitlines()
    assert code == 2 and "branches schema_version 2 is newer than this rigtools reads (1)" in line, line


def test_ctrl_c_in_a_script_keeps_the_points_in_found(ctrl_c_after_30_steps):
    """``rigtools.continuation(..., found=found)`` from Python: a KeyboardInterrupt after 30
    corrector steps leaves the branch so far in ``found``, marked "interrupted" (they were lost)."""
    import rigtools

    found: list = []
    with pytest.raises(KeyboardInterrupt):
        rigtools.continuation("fe", "55 Hz", "58 Hz", force="15 N", gap="5 mm", switch=False, found=found)
    (b,) = found
    values = [p.value for p in b.points]
    assert b.status == "interrupted" and 10 <= len(values) <= 31
    assert values[0] == 55.0 and np.all(np.diff(values) > 0) and values[-1] < 58.0
