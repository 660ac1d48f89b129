"""Lab procedures from option text, as ``rig acquire`` and scripts give them: quantity strings
(``"60 Hz"``, ``"0.5 mm"``), value lists (``"340 Hz:380 Hz:2 Hz"``), fault texts; and a finished
procedure's result as the ``rig acquire --json`` document.

* :func:`parse_faults`: ``KIND@TIME[:CHANNEL]`` texts -> :class:`rigtools.drivers.simulated.Fault`
  (the one fault grammar, :meth:`~rigtools.drivers.simulated.Fault.parse`);
* :func:`build_procedure`: a :class:`rigtools.procedures.base.Procedure` of a name and options;
* :func:`result_document`: what a run gave (harmonics, jumps, the FRF quick check, tap modes);
  :func:`document_if_ended`: the same of a run stopped or failed after it began recording.
"""

from __future__ import annotations

import contextlib
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar

from rigtools.analysis.frf import MIN_FRAME_SAMPLES
from rigtools.drivers.contracts import ConfigurationError
from rigtools.drivers.realtime_pll import NO_REALTIME_PLL
from rigtools.drivers.simulated import Fault
from rigtools.errors import UserError
from rigtools.options import band_option, quantity, swept_not_fixed, value_list
from rigtools.options import gap as _gap_text
from rigtools.procedures.cbc_door import OPTIONS as CBC_OPTIONS
from rigtools.procedures.cbc_door import from_options as cbc_from_options
from rigtools.procedures.cbc_door import json_document
from rigtools.procedures.dwell import SineDwell
from rigtools.procedures.frf import FrfTest, quick_check
from rigtools.procedures.pll import PhaseLockedLoop
from rigtools.procedures.pll_options import OPTIONS as PLL_OPTIONS
from rigtools.procedures.pll_options import pll_document, pll_parameters
from rigtools.procedures.result import RunResult
from rigtools.procedures.rig import sim_only
from rigtools.procedures.rig_study import RigStudy
from rigtools.procedures.sweep import SteppedSine
from rigtools.procedures.tap import TapTest, analyze_tap_recording

PROCEDURES = ("dwell", "sweep", "study", "frf", "tap", "pll", "cbc")
TAP_F_MIN_HZ = 5.0
_Built = TypeVar("_Built")


def with_option_names(
    build: Callable[[], _Built], names: Mapping[str, str], options: Mapping[str, Any] = {}
) -> _Built:
    """``build()``; a :class:`UserError` naming a parameter names the command's option instead:
    each of ``names`` anywhere in the line (``max_periods`` -> ``--max-periods``), and a line
    that starts ``name = `` with ``name`` one of the command's ``options`` (``force = -5.0``
    -> ``--force = -5.0``; ``record_periods`` is ``--periods``): the command line's words, not
    the Python door's."""
    try:
        return build()
    except UserError as exc:
        text = str(exc)
        for name, option in names.items():
            text = re.sub(rf"(?<![\w-]){name}(?![\w-])", option, text)
        first = re.match(r"([a-z][a-z0-9_]*) = ", text)
        if first is not None:
            key = {"record_periods": "periods", "phases": "phase"}.get(first.group(1), first.group(1))
            if key in options:
                text = "--" + key.replace("_", "-") + text[first.end(1) :]
        if text == str(exc):
            raise
        raise type(exc)(text) from None


def parse_faults(texts: Sequence[str], backend: str) -> list[Any]:
    """Faults for the simulated rig from ``"KIND@TIME[:CHANNEL]"`` texts (TIME in seconds or with a
    unit: ``"input-overflow@1.5"``, ``"nan-samples@250 ms:force"``); refused on another backend."""
    if not texts:
        return []
    if backend != "sim":
        raise UserError("--fault injects faults into the simulated rig only; add --backend sim")
    faults = []
    for text in texts:
        try:
            faults.append(Fault.parse(text))
        except ConfigurationError as exc:
            raise UserError(f"--fault = {text!r}: {exc}") from None
    return faults


def _gap(options: Mapping[str, Any]) -> float | None:
    value = options.get("gap")
    return None if value is None else _gap_text(value)


def _control(options: Mapping[str, Any]) -> dict:
    n = options.get("max_updates", 10)
    if not 1 <= n <= 100:
        raise UserError(f"--max-updates = {n}: use 1..100")
    return {"max_updates": n}


def _grid(text: str, kind: str, option: str, minimum: int = 1) -> list[float]:
    return value_list(text, kind, option, minimum=minimum)


#: Highest excitation or analysis frequency as a fraction of the sample rate (anti-alias margin).
NYQUIST_FRACTION = 0.45


def below_nyquist(values: list[float] | float, rate: float, option: str, text: Any) -> None:
    """Refuse (exit 2, before the first sample) a frequency at or above ``NYQUIST_FRACTION`` of the
    sample rate ``rate``, naming the option."""
    top = NYQUIST_FRACTION * rate
    for f in values if isinstance(values, list) else [values]:
        if f > top:
            raise UserError(
                f"{option} = {text!r}: {f:g} Hz is above what {rate:g} samples/s can record "
                f"(at most {top:g} Hz, {NYQUIST_FRACTION:g} x the sample rate)"
            )


def _frame(text: Any, rate: float, default: str) -> float:
    frame = quantity(text if text is not None else default, "time", "--frame")
    if not frame * rate >= MIN_FRAME_SAMPLES:
        raise UserError(
            f"--frame = {text!r}: {frame:g} s is {frame * rate:.3g} samples at {rate:g} samples/s; "
            f"a frame needs at least {MIN_FRAME_SAMPLES} samples ({MIN_FRAME_SAMPLES / rate:.3g} s)"
        )
    return frame


def _periods(params: dict, options: Mapping[str, Any]) -> dict:
    if options.get("periods") is not None:
        params["record_periods"] = options["periods"]
    return params


def build_procedure(
    name: str,
    cfg: Any,
    out: str | Path,
    options: Mapping[str, Any],
    *,
    confirm_gap: Callable[[float, int], None] | None = None,
    **run_options: Any,
) -> Any:
    """A procedure ready to ``run()``.

    Parameters
    ----------
    name
        One of :data:`PROCEDURES`.
    cfg
        The :class:`rigtools.config.RigConfig`.
    out
        The recording to write.
    options
        The procedure's options by their ``rig acquire`` names (``fe``, ``force``, ``gap``,
        ``periods``, ``max_updates``, ``frequencies``, ``direction``, ``jump_threshold``, ``kind``,
        ``values``, ``resume``, ``signal``, ``band``, ``level``, ``frame``, ``averages``, ``seed``,
        ``blade``, ``position``, ``hits``, ``pretrigger``, ``trigger``, ``hammer_channel``,
        ``response``, ``timeout``, ``hit_force``, ``pulse``, ``f_max``); quantities as text with
        units or SI numbers.
    confirm_gap
        Study on the rig: ``confirm_gap(gap_m, index)`` waits until the operator has set the gap.
    **run_options
        ``backend``, ``overwrite``, ``pace``, ``faults``, ``seed`` of the procedure.
    """
    # the simulated rig's options with another backend: refused before a backend's note is said
    sim_only(
        run_options.get("backend", "nidaq"),
        pace=bool(run_options.get("pace")),
        faults=run_options.get("faults") or (),
        seed=run_options.get("seed"),
    )
    names = {"pll": PLL_OPTIONS, "cbc": CBC_OPTIONS}.get(name, {})
    return with_option_names(
        lambda: _build(name, cfg, out, options, confirm_gap, run_options), names, options
    )


def _build(
    name: str,
    cfg: Any,
    out: str | Path,
    options: Mapping[str, Any],
    confirm_gap: Callable[[float, int], None] | None,
    run_options: dict[str, Any],
) -> Any:
    rate = float(cfg.daq.sample_rate)

    o = options
    params: dict[str, Any]
    if name == "dwell":
        params = {
            "fe": quantity(o["fe"], "frequency", "--fe"),
            "force": quantity(o["force"], "force", "--force"),
            "gap": _gap(o),
            "control": _control(o),
        }
        below_nyquist(params["fe"], rate, "--fe", o["fe"])
        return SineDwell(cfg, _periods(params, o), out, **run_options)
    if name == "sweep":
        params = {
            "frequencies": _grid(o["frequencies"], "frequency", "--frequencies", minimum=2),
            "force": quantity(o["force"], "force", "--force"),
            "gap": _gap(o),
            "direction": o.get("direction", "up"),
            "jump_threshold": o.get("jump_threshold", 0.3),
            "control": _control(o),
        }
        below_nyquist(params["frequencies"], rate, "--frequencies", o["frequencies"])
        return SteppedSine(cfg, _periods(params, o), out, **run_options)
    if name == "study":
        swept_not_fixed(o["kind"], {"--fe": o.get("fe"), "--force": o.get("force"), "--gap": o.get("gap")})
        params = {
            "kind": o["kind"],
            "values": _grid(o["values"], o["kind"], "--values"),
            "direction": o.get("direction", "up"),
            "fe": None if o.get("fe") is None else quantity(o["fe"], "frequency", "--fe"),
            "force": None if o.get("force") is None else quantity(o["force"], "force", "--force"),
            "gap": _gap(o),
            "control": _control(o),
        }
        if params["kind"] == "frequency":
            below_nyquist(params["values"], rate, "--values", o["values"])
        if params["fe"] is not None:
            below_nyquist(params["fe"], rate, "--fe", o["fe"])
        resume = bool(o.get("resume", False))
        if resume:
            run_options = {**run_options, "overwrite": False}
        return RigStudy(cfg, _periods(params, o), out, resume=resume, confirm_gap=confirm_gap, **run_options)
    if name == "pll":
        params = pll_parameters(cfg, o)
        below_nyquist(params["fe_start"], rate, "--fe-start", o.get("fe_start"))
        pll = PhaseLockedLoop(cfg, params, out, **run_options)
        if run_options.get("backend") == "nidaq" and params.get("inner_loop") != "buffered":
            pll.note = NO_REALTIME_PLL  # said before the device opens
        return pll
    if name == "tap":
        hits = o.get("hits", 5)
        if not 2 <= hits <= 1000:
            raise UserError(f"--hits = {hits}: use 2..1000 (averaging and coherence need two hits or more)")
        params = {
            "blade": o.get("blade", "passive"),
            "position": quantity(o["position"], "length", "--position"),
            "hits": hits,
            "frame": _frame(o.get("frame"), rate, "2 s"),
            "pretrigger": quantity(o.get("pretrigger", "10 ms"), "time", "--pretrigger"),
            "trigger": quantity(o.get("trigger", "5 N"), "force", "--trigger"),
            "gap": _gap(o),
            "hammer_channel": o.get("hammer_channel", "hammer"),
            "response": o.get("response"),
            "timeout": quantity(o.get("timeout", "60 s"), "time", "--timeout"),
            "hit_force": quantity(o.get("hit_force", "20 N"), "force", "--hit-force"),
            "pulse": quantity(o.get("pulse", "0.5 ms"), "time", "--pulse"),
        }
        f_max = quantity(o.get("f_max", "2 kHz"), "frequency", "--f-max")
        if not f_max > TAP_F_MIN_HZ:
            raise UserError(
                f"--f-max = {o.get('f_max')!r}: modes are identified from {TAP_F_MIN_HZ:g} Hz up; "
                f"give more than {TAP_F_MIN_HZ:g} Hz"
            )
        below_nyquist(f_max, rate, "--f-max", o.get("f_max"))
        return TapTest(cfg, params, out, **run_options)
    if name == "cbc":
        below_nyquist(quantity(o["fe"], "frequency", "--fe"), rate, "--fe", o["fe"])
        return cbc_from_options(cfg, out, o, **run_options)
    if name != "frf":
        raise UserError(f"unknown procedure {name!r} (known: {', '.join(PROCEDURES)})")
    band = band_option(str(o["band"]), "--band", allow_zero=False)
    below_nyquist(list(band), rate, "--band", o["band"])
    params = {
        "signal": o.get("signal", "chirp"),
        "band": band,
        "level": quantity(o["level"], "voltage", "--level"),
        "frame": _frame(o.get("frame"), rate, "1 s"),
        "averages": o.get("averages", 10),
        "gap": _gap(o),
        "seed": o.get("seed"),
    }
    return FrfTest(cfg, params, out, **run_options)


_POINT_KEYS = (
    "fe",
    "force_amplitude",
    "force_amplitude_measured",
    "gap",
    "drive_amplitude",
    "control_updates",
    "settled",
    "direction",
    "study_value",
)


def point_document(p: Mapping[str, Any], units: Mapping[str, str]) -> dict:
    """One point of a result: its parameters and, per channel, units, peak and harmonics."""
    doc = {k: p[k] for k in _POINT_KEYS if k in p}
    doc["channels"] = {
        name: {
            "units": units.get(name, ""),
            "peak": p["peaks"][name],
            "harmonics": [
                {"k": i + 1, "amplitude": a, "phase": ph}
                for i, (a, ph) in enumerate(zip(h["amplitude"], h["phase"], strict=True))
            ],
        }
        for name, h in p["harmonics"].items()
    }
    return doc


def result_document(name: str, backend: str, proc: Any, result: Any, f_max: str | float = "2 kHz") -> dict:
    """The ``rig acquire --json`` document of a finished (or ended) procedure: ``result`` is
    the :class:`rigtools.procedures.RunResult` its ``run()`` returned; the points are read from
    its working record (``proc.result``), which keeps each harmonic's phase and each channel's peak.

    A dwell gives its point's harmonics; a sweep or study its points (without channels) and the
    summary (jumps); a finished FRF test the quick check (:func:`rigtools.procedures.frf.quick_check`);
    a tap test its hits and the modes identified over the accepted hits up to ``f_max``
    (:func:`rigtools.procedures.tap.analyze_tap_recording`).
    """
    doc: dict[str, Any] = {
        "file": str(proc.out),
        "status": result.status.value,
        "reason": result.reason,
        "backend": backend,
        "procedure": name,
    }
    units = {s.name: s.units for s in getattr(proc, "specs", [])}
    finished = result.status == "finished"
    points = proc.result.points  # the working record's points: every harmonic's phase and each peak
    if name == "dwell" and points:
        doc.update(point_document(points[0], units))
        doc["warnings"] = points[0]["safety_warnings"]
    elif name in ("sweep", "study"):
        doc["points"] = [
            {k: v for k, v in point_document(p, units).items() if k != "channels"} for p in points
        ]
        doc.update(result.summary)
    elif name == "pll":
        doc["procedure"] = "pll"
        doc["points"] = pll_document(proc)
        doc.update({k: v for k, v in result.summary.items() if k != "points"})
    elif name == "cbc":
        doc.update(json_document(proc))
    elif name == "frf" and finished:
        doc["check"] = quick_check(proc.out, proc.params.response)
    elif name == "tap":
        doc.update(result.summary)
        doc["hits_detail"] = points
        if finished:
            top = min(quantity(f_max, "frequency", "--f-max"), 0.45 * proc.rate)
            res = analyze_tap_recording(proc.out, proc.response, f_min=TAP_F_MIN_HZ, f_max=top)
            doc["modes"] = [
                {"frequency_hz": m.frequency_hz, "damping_ratio": m.damping_ratio}
                for m in res.modes[proc.response].modes
            ]
    return doc


@contextlib.contextmanager
def document_if_ended(
    options: Mapping[str, Any], proc: Any, emit: Callable[[dict[str, Any]], None]
) -> Iterator[None]:
    """Around ``proc.run()`` of ``rig acquire`` (``options``: its arguments ``procedure``,
    ``backend``, ``json``, ``f_max``): with ``json``, a run that began its recording and then
    stopped (a signal, Ctrl-C) or failed gives ``emit`` (the command's printer) its
    :func:`result_document` (status ``aborted`` or ``failed``, the reason, the file, the points
    recorded so far) before the exception goes on to its one line. A run refused before recording (no NI-DAQmx) prints none: its line says it all.
    Around the analysis of a finished run (``result_document``): a stop there prints the document
    without the analysis (status ``finished``: the recording is whole), not the analysis again."""
    try:
        yield
    except (KeyboardInterrupt, Exception):
        if options.get("json") and getattr(proc, "writer", None) is not None and proc.result is not None:
            name, backend = str(options["procedure"]), str(options["backend"])
            ended = RunResult.from_procedure(name, proc.result, proc.out)
            doc = {"file": str(proc.out), "status": ended.status.value, "reason": ended.reason}
            doc.update({"backend": backend, "procedure": name})
            if ended.status != "finished":  # finished: stopped in its analysis, never run it again
                # a partial run's detail that fails leaves the short document: the run's error goes on
                with contextlib.suppress(Exception):
                    doc = result_document(name, backend, proc, ended, options.get("f_max") or "2 kHz")
            emit(doc)
        raise
