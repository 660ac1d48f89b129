"""``rig acquire``: a sine dwell on the rig (NI-DAQmx or the simulated rig), recorded as HDF5."""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from rigtools.acquisition import AcquisitionAborted, BlockStream, StreamStats
from rigtools.options import check_out, quantity
from rigtools.config import RigConfig, load_rig
from rigtools.errors import UserError

HELP = "sine dwell on the rig (NI-DAQmx, or --simulated): drive, record, report harmonics"
EPILOG = """\
The drive is a sine of --fe at --drive volts peak at the DAQ's analog output (the shaker
amplifier's input), never above the rig file's [safety] max_drive. Its amplitude ramps up over
[safety] ramp_time (raised cosine, no step onto the shaker), the response settles for --settle,
then --duration is recorded; the drive then ramps down over ramp_time. On any fault, safety
abort or Ctrl-C the drive ramps to 0 V within [safety] abort_ramp_time (<= 0.1 s) after what
is already queued at the output, and the file keeps everything recorded before it.

Timeline (s from the start of the drive):
  0 .. ramp_time                      ramp up to --drive
  .. ramp_time + settle (+ DAQ delay) settling, not recorded
  .. + duration                       recorded (one point)
  then                                ramp down over ramp_time, stop

Inputs, sample rate and block size come from [daq] of the rig file; every block is checked
against [safety] limits (warnings are reported, abort limits stop the run). Without
--simulated the NI-DAQmx backend is used; the simulated rig runs the vibro-impact FE model of
the rig file's [test_article] through the [shaker] model, as fast as it can (--pace: in real
time).

Recorded (one point, backend "nidaqmx" or "simulated"): every [daq] input in SI units (N,
m/s^2, V) with its sensitivity, physical channel and location, plus "drive" (V, the drive
samples written, on the output's clock: the inputs lag them by the DAQ delay). Point
parameters: fe (Hz), drive_amplitude (V), gap (m, from the rig file), record_start (s); at the
end measured_force_amplitude (N, harmonic 1 of the force channel) and settled: for every input,
harmonic 1 over the first and the last 0.5 s of the record (whole periods) agree within 2 %
(plus noise), and what the harmonics k*fe do not explain (a decaying transient at the blade's
own frequencies) is no larger at the start than at the end (25 %, or 2 % of harmonic 1).
Give a longer --settle when it says NO.

Harmonics (summary and --json) are least-squares fits at k*fe, k = 1..30 (below Nyquist), over
the last whole periods within 1 s of the record; amplitudes and "peak" are peak values in the
channel's units. --json prints {"file", "backend", "fe", "drive_amplitude_v", "sample_rate",
"duration_s", "measured_force_amplitude_n", "settled", "warnings",
"channels": {name: {"units", "peak", "harmonics": [{"k", "frequency_hz", "amplitude"}, ...]}},
"status": "complete", "plot": PNG path or null}.

Plot: FILE.png beside FILE.h5 (same name; --no-plot skips it), written after the drive has
stopped: per channel its last 5 periods (time from the start of the drive) and its amplitude
spectrum (flattop window, peak values in the channel's units, k*fe marked) over the analysed
record (the last whole periods within 1 s). Not written when a fault stops the run.

Quantities take units: --fe "60 Hz", --drive "1 V" (peak; "500 mV", "2 Vpp" = 1 V peak),
--duration "2 s", --settle "500 ms"; a plain number is SI (Hz, V, s).

Faults (simulated rig only, repeatable): --fault KIND@TIME[:CHANNEL], KIND one of
input-overflow, amplifier-timeout, sensor-overload, nan-samples; TIME from the start of the
drive ("1.2", "1.2 s", "1200 ms"); CHANNEL an input (default: the first).

Exit status: 0 recorded, 2 bad input (options, rig file, existing --out without --overwrite),
3 NI-DAQmx (or its driver) not available: use --simulated, 4 a fault or a safety abort stopped
the run (the file is kept with status "aborted"), 130 Ctrl-C (drive ramped down, file kept).

examples:
  rig acquire --simulated --fe 60 --drive "1 V" --duration 2 --out run.h5
  rig acquire --simulated --fe 60 --drive "0.5 V" --duration 2 --settle 2 --out run.h5 --json
  rig acquire --simulated --fe 60 --drive "1 V" --duration 2 --fault "input-overflow@2.5:force" --out f.h5
  rig acquire --rig lab.toml --fe 60 --drive "0.8 V" --duration 10 --out dwell.h5
"""

K_MAX = 30
ANALYSIS_MAX_SECONDS = 1.0      # harmonics over the last whole periods within this much record
SETTLED_SEGMENT_SECONDS = 0.5   # "settled": the first vs the last segment of the record ...
SETTLED_TOLERANCE = 0.02        # ... agree within 2 % of harmonic 1 (see analyse)
FAULT_PATTERN = re.compile(r"^\s*([A-Za-z_-]+)\s*@\s*([^:]+?)\s*(?::\s*([\w.-]+))?\s*$")


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("acquire", help=HELP, description=HELP + ".", epilog=EPILOG,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--rig", metavar="FILE", help="rig file (TOML); default: the calibrated default rig")
    p.add_argument("--simulated", action="store_true",
                   help="run on the simulated rig (FE model + shaker) instead of NI-DAQmx hardware")
    p.add_argument("--pace", action="store_true",
                   help="simulated rig: deliver blocks in real time, like hardware (default: as fast as possible)")
    p.add_argument("--seed", type=int, default=None, metavar="N",
                   help="simulated rig: seed of the sensor noise (default: random)")
    p.add_argument("--fault", action="append", default=[], metavar="KIND@TIME[:CHANNEL]",
                   help="simulated rig: inject a fault (repeatable), e.g. 'nan-samples@1.5:force'")
    p.add_argument("--fe", required=True, help='excitation frequency, e.g. "60 Hz"')
    p.add_argument("--drive", required=True,
                   help='peak drive voltage at the output to the shaker amplifier, e.g. "1 V" '
                        '(at most [safety] max_drive)')
    p.add_argument("--duration", required=True, help='recorded time, e.g. "2 s" (at least one period)')
    p.add_argument("--settle", default="1 s",
                   help='time after the ramp up before recording starts (default "1 s")')
    p.add_argument("--out", required=True, metavar="FILE", help="HDF5 file to write (.h5)")
    p.add_argument("--overwrite", action="store_true", help="replace FILE if it exists")
    p.add_argument("--json", action="store_true", help="print the results as JSON on stdout")
    p.add_argument("--no-plot", action="store_true", help="do not write the PNG plot beside FILE")
    p.set_defaults(func=run)


# ------------------------------------------------------------------------------ inputs


def drive_amplitude(text: str) -> float:
    """Peak volts from ``--drive``; ``"2 Vpp"`` is 1 V peak."""
    value = quantity(text, "voltage", "--drive")
    return value / 2.0 if text.strip().lower().endswith("vpp") else value


def parse_faults(texts: list[str], simulated: bool) -> list:
    """``KIND@TIME[:CHANNEL]`` options as :class:`drivers.simulated.Fault` (time from the drive start)."""
    if not texts:
        return []
    if not simulated:
        raise UserError("--fault injects faults into the simulated rig only; add --simulated")
    from drivers.contracts import ConfigurationError
    from drivers.simulated import FAULT_KINDS, Fault

    faults = []
    for text in texts:
        match = FAULT_PATTERN.match(text)
        if not match:
            raise UserError(f"--fault = {text!r}: write KIND@TIME[:CHANNEL], e.g. 'input-overflow@1.5:force'")
        kind, at, channel = match.groups()
        t = quantity(at, "time", "--fault")
        if t < 0:
            raise UserError(f"--fault = {text!r}: the time must be >= 0 s")
        try:
            faults.append(Fault(kind, at_time=t, channel=channel))
        except ConfigurationError:
            raise UserError(f"--fault = {text!r}: unknown kind {kind!r} (known: "
                            f"{', '.join(k.replace('_', '-') for k in FAULT_KINDS)})") from None
    return faults


class Options:
    """The validated command line (SI)."""

    def __init__(self, args: argparse.Namespace, cfg: RigConfig) -> None:
        self.fe = quantity(args.fe, "frequency", "--fe")
        self.drive = drive_amplitude(args.drive)
        self.duration = quantity(args.duration, "time", "--duration")
        self.settle = quantity(args.settle, "time", "--settle")
        rate = cfg.daq.sample_rate
        if not (self.fe > 0 and math.isfinite(self.fe)):
            raise UserError(f"--fe = {args.fe!r}: the excitation frequency must be > 0 Hz")
        if self.fe >= rate / 2:
            raise UserError(f"--fe = {args.fe!r}: must be below half the sample rate "
                            f"({rate / 2:g} Hz, [daq] sample_rate)")
        if not self.drive > 0:
            raise UserError(f"--drive = {args.drive!r}: the drive amplitude must be > 0 V")
        if self.drive > cfg.safety.max_drive:
            raise UserError(f"--drive = {args.drive!r} is above the maximum drive "
                            f"{cfg.safety.max_drive:g} V ([safety] max_drive of the rig file)")
        if not (self.duration > 0 and math.isfinite(self.duration)):
            raise UserError(f"--duration = {args.duration!r}: must be > 0 s")
        if self.duration * self.fe < 1.0 - 1e-9:
            raise UserError(f"--duration = {args.duration!r} is shorter than one excitation period "
                            f"(1/fe = {1 / self.fe:.4g} s)")
        if not (self.settle >= 0 and math.isfinite(self.settle)):
            raise UserError(f"--settle = {args.settle!r}: must be >= 0 s")


# ------------------------------------------------------------------------------ device


def open_device(args: argparse.Namespace, cfg: RigConfig, faults: list):
    """The acquisition device, not configured yet."""
    if args.simulated:
        from drivers.simulated import SimulatedRig

        return SimulatedRig.from_config(cfg, pace=args.pace, faults=faults, seed=args.seed)
    if args.pace or args.seed is not None:
        raise UserError("--pace and --seed apply to the simulated rig only; add --simulated")
    from drivers.nidaq import NiDaqDevice

    return NiDaqDevice(abort_ramp_time=cfg.safety.abort_ramp_time)


def configure(device, cfg: RigConfig) -> float:
    """Channels and clock from [daq]; the actual (coerced) sample rate."""
    from drivers.contracts import ConfigurationError

    try:
        return device.configure(cfg.daq.input_specs(), cfg.daq.output_spec(), cfg.daq.sample_rate,
                                cfg.daq.block_size())
    except ConfigurationError as exc:
        raise UserError(str(exc)) from None


def safety_monitor(cfg: RigConfig, device):
    from drivers.safety import ChannelLimit, SafetyMonitor

    limits = [ChannelLimit(name, lim.warning, lim.abort) for name, lim in cfg.safety.limits.items()]
    return SafetyMonitor(limits, device.input_channels, max_drive=cfg.safety.max_drive)


def channel_specs(device, cfg: RigConfig, rate: float) -> list:
    """Recording channels: every input (from its spec), then the drive."""
    from rigtools.recording import ChannelSpec

    specs = [ChannelSpec(name=s.name, units=s.units, quantity=s.quantity, sample_rate=rate,
                         sensitivity=s.sensitivity, sensitivity_units=s.sensitivity_units,
                         physical_channel=s.physical_channel, location=s.location or None)
             for s in device.input_channels]
    out = cfg.daq.output_spec()
    specs.append(ChannelSpec(name=out.name, units="V", quantity="voltage", sample_rate=rate,
                             physical_channel=out.physical_channel,
                             location="drive output to the shaker amplifier (as written)"))
    return specs


# ------------------------------------------------------------------------------ recording


class WindowSink:
    """Passes the stream's samples ``[start, start + n)`` to ``point`` and keeps, for the
    analysis, the first ``head`` and the last ``tail`` of them and the per-channel peaks."""

    def __init__(self, point, start: int, n: int, head: int, tail: int) -> None:
        self.point, self.start, self.n = point, start, n
        self.head_n, self.tail_n = head, tail
        self.position = 0            # stream samples seen
        self.recorded = 0            # samples passed to the point
        self.peak: np.ndarray | None = None
        self._head: list[np.ndarray] = []
        self._tail: list[np.ndarray] = []
        self._tail_size = 0

    def append(self, block: np.ndarray) -> None:
        m = block.shape[1]
        lo = min(max(self.start - self.position, 0), m)
        hi = min(max(self.start + self.n - self.position, 0), m)
        self.position += m
        if hi <= lo:
            return
        part = block[:, lo:hi]
        self.point.append(part)
        peak = np.max(np.abs(part), axis=1)
        self.peak = peak if self.peak is None else np.maximum(self.peak, peak)
        have = sum(b.shape[1] for b in self._head)
        if have < self.head_n:
            self._head.append(part[:, : self.head_n - have].copy())
        self._tail.append(part.copy())
        self._tail_size += part.shape[1]
        while self._tail and self._tail_size - self._tail[0].shape[1] >= self.tail_n:
            self._tail_size -= self._tail.pop(0).shape[1]
        self.recorded += part.shape[1]

    def head(self) -> np.ndarray:
        return np.concatenate(self._head, axis=1)

    def tail(self) -> np.ndarray:
        return np.concatenate(self._tail, axis=1)[:, -self.tail_n:]


def whole_periods(n_max: int, rate: float, fe: float) -> int:
    """Samples in the most whole periods of ``fe`` that fit in ``n_max`` (at least ``n_max`` if
    not even one period fits)."""
    periods = math.floor(n_max * fe / rate + 1e-9)
    return int(round(periods * rate / fe)) if periods >= 1 else n_max


def analyse(sink: WindowSink, names: list[str], units: list[str], rate: float, fe: float,
            force_row: int | None) -> dict:
    """Harmonics of every channel over the tail, settledness from head vs tail."""
    from analysis.harmonics import harmonic_amplitudes

    k_max = min(K_MAX, math.ceil(rate / 2 / fe) - 1)
    tail = sink.tail()
    tail = tail[:, tail.shape[1] - whole_periods(tail.shape[1], rate, fe):]
    seg = whole_periods(min(sink.head_n, tail.shape[1]), rate, fe)
    head, last = sink.head()[:, :seg], tail[:, tail.shape[1] - seg:]
    channels, settled = {}, True
    n_inputs = len(names) - 1               # the last row is the drive
    for row, (name, unit) in enumerate(zip(names, units)):
        fit = harmonic_amplitudes(tail[row], rate, fe, min(k_max, (tail.shape[1] - 1) // 2))
        channels[name] = {
            "units": unit, "peak": float(sink.peak[row]),
            "harmonics": [{"k": r["k"], "frequency_hz": r["frequency_hz"], "amplitude": r["amplitude"]}
                          for r in fit.to_records()],
        }
        if row < n_inputs and seg >= 3:
            a = harmonic_amplitudes(head[row], rate, fe, 1)
            b = harmonic_amplitudes(last[row], rate, fe, 1)
            amp = max(a.at(1), b.at(1), 1e-300)
            change = abs(a.at(1) - b.at(1))
            # the fundamental agrees, and what the harmonics do not explain (a decaying transient
            # at the blade's own frequencies; noise) is no larger at the start than at the end
            settled &= change <= SETTLED_TOLERANCE * amp + 4 * b.residual_rms * math.sqrt(2.0 / seg)
            settled &= a.residual_rms <= 1.25 * b.residual_rms + SETTLED_TOLERANCE * amp
    force = None if force_row is None else channels[names[force_row]]["harmonics"][0]["amplitude"]
    return {"channels": channels, "settled": bool(settled), "measured_force_amplitude": force}


# ------------------------------------------------------------------------------ the command


def run(args: argparse.Namespace) -> int:
    out = check_out(args)
    cfg = load_rig(args.rig)
    opts = Options(args, cfg)
    faults = parse_faults(args.fault, args.simulated)
    device = open_device(args, cfg, faults)
    with device:
        rate = configure(device, cfg)
        if opts.fe >= rate / 2:
            raise UserError(f"--fe = {args.fe!r}: must be below half the sample rate ({rate / 2:g} Hz)")
        result, analysed = dwell(args, cfg, opts, device, rate, out)
    result["plot"] = None if args.no_plot else str(write_plot(out, analysed, opts.fe, result["backend"]))
    if args.json:
        print(json.dumps(result))
    else:
        print_summary(result, out)
    return 0


@dataclass(frozen=True)
class AnalysedRecord:
    """The samples the summary was computed from (for the plot)."""

    names: list[str]
    units: list[str]
    samples: np.ndarray      # (channels, n): the last whole periods within ANALYSIS_MAX_SECONDS
    sample_rate: float
    t0: float                # time of the first sample from the start of the drive, s


def write_plot(out: Path, rec: AnalysedRecord, fe: float, backend: str) -> Path:
    """:func:`analysis.plots.time_and_spectrum_figure` of the analysed record, beside ``out``."""
    from rigtools.figures import plot_path, save_figure
    from analysis.plots import time_and_spectrum_figure

    fig = time_and_spectrum_figure(dict(zip(rec.names, rec.samples)), dict(zip(rec.names, rec.units)),
                                   rec.sample_rate, fe, t0=rec.t0, k_max=K_MAX, title=f"{out.name} ({backend})")
    return save_figure(fig, plot_path(out))


def dwell(args: argparse.Namespace, cfg: RigConfig, opts: Options, device, rate: float,
          out: Path) -> tuple[dict, AnalysedRecord]:
    """Ramp up, settle, record, ramp down; the summary document and the analysed samples."""
    from drivers.safety import SineDrive
    from rigtools.recording import RecordingWriter

    drive = SineDrive(rate, opts.fe, max_drive=cfg.safety.max_drive, ramp_time=cfg.safety.ramp_time)
    drive.set_target(opts.drive)
    delay = device.input_to_output_delay()
    start = math.ceil((cfg.safety.ramp_time + opts.settle + delay) * rate - 1e-9)
    n_rec = int(round(opts.duration * rate))
    total = start + n_rec
    specs = channel_specs(device, cfg, rate)
    names, units = [s.name for s in specs], [s.units for s in specs]
    force_row = next((i for i, s in enumerate(device.input_channels) if s.kind == "force"), None)
    params = {"fe": opts.fe, "drive_amplitude": opts.drive, "gap": cfg.contact.gap,
              "record_start": start / rate, "settle_time": opts.settle,
              "ramp_time": cfg.safety.ramp_time, "abort_ramp_time": cfg.safety.abort_ramp_time}
    info = device.info()
    experiment = {"procedure": "sine dwell", "cli": "rig acquire", "device": asdict(info),
                  "faults": [f"{f.kind}@{f.at_time}s:{f.channel or ''}" for f in getattr(device, "faults", ())],
                  "pace": bool(args.pace)}
    segment = int(round(min(SETTLED_SEGMENT_SECONDS, opts.duration / 2) * rate))
    keep = int(round(min(ANALYSIS_MAX_SECONDS, opts.duration) * rate))
    with RecordingWriter(out, backend=device.backend, rig=cfg.to_json(), experiment=experiment,
                         overwrite=args.overwrite) as rec:
        point = rec.begin_point(params=params, channels=specs)
        sink = WindowSink(point, start, n_rec, max(segment, 1), keep)
        try:
            with ProgressBar(args, opts, rate, start, total) as update:
                with BlockStream(device, drive, sink=sink, safety=safety_monitor(cfg, device),
                                 record_drive=True, on_block=update) as stream:
                    while stream.stats.samples < total:
                        stream.read()
                    stats = stream.finish()
        except AcquisitionAborted as exc:    # one line for the user and the file's abort_reason
            raise AcquisitionAborted(
                f"{exc.fault}: {_cause_line(exc)}; drive ramped to zero; "
                f"{sink.recorded / rate:.3f} s recorded before it kept in {out} (status aborted)",
                fault=exc.fault, cause=exc.cause, samples_kept=sink.recorded, time=exc.time) from None
        summary = analyse(sink, names, units, rate, opts.fe, force_row)
        attrs = {"settled": summary["settled"], "samples_recorded": sink.recorded}
        if summary["measured_force_amplitude"] is not None:
            attrs["measured_force_amplitude"] = summary["measured_force_amplitude"]
        point.set_attrs(**attrs)
        point.end()
    tail = sink.tail()
    tail = tail[:, tail.shape[1] - whole_periods(tail.shape[1], rate, opts.fe):]
    analysed = AnalysedRecord(names, units, tail, rate, (start + sink.recorded - tail.shape[1]) / rate)
    return {
        "file": str(out), "backend": device.backend, "fe": opts.fe, "drive_amplitude_v": opts.drive,
        "sample_rate": rate, "duration_s": sink.recorded / rate,
        "measured_force_amplitude_n": summary["measured_force_amplitude"],
        "settled": summary["settled"],
        "warnings": sorted({str(w.channel) for w in stats.warnings}),
        "channels": summary["channels"], "status": "complete",
    }, analysed


def _cause_line(exc: AcquisitionAborted) -> str:
    """The cause's own one line, without a repeated fault name."""
    text = " ".join(str(exc.cause).split()) or type(exc.cause).__name__
    prefix = f"{exc.fault}: "
    return text[len(prefix):] if text.lower().startswith(prefix.lower()) else text


class ProgressBar:
    """A rich progress bar on stderr (off with --json or when stderr is not a terminal);
    yields the ``on_block`` callback."""

    def __init__(self, args, opts: Options, rate: float, start: int, total: int) -> None:
        self.enabled = not args.json and sys.stderr.isatty()
        self.rate, self.start, self.total = rate, start, total
        self.label = f"fe {opts.fe:g} Hz, {opts.drive:g} V"

    def __enter__(self):
        if not self.enabled:
            return lambda block, stats: None
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

        self._bar = Progress(TextColumn("{task.description}"), BarColumn(),
                             TextColumn("{task.fields[t]:.1f} / {task.fields[end]:.1f} s"),
                             TimeElapsedColumn(), console=Console(stderr=True), transient=True)
        self._bar.__enter__()
        self._task = self._bar.add_task(f"settling ({self.label})", total=self.total, t=0.0,
                                        end=self.total / self.rate)

        def update(block: np.ndarray, stats: StreamStats) -> None:
            done = min(stats.samples, self.total)
            phase = "recording" if done >= self.start else "settling"
            if done >= self.total:
                phase = "ramping down"
            self._bar.update(self._task, completed=done, t=done / self.rate,
                             description=f"{phase} ({self.label})")

        return update

    def __exit__(self, *exc) -> bool:
        if self.enabled:
            self._bar.__exit__(*exc)
        return False


def print_summary(doc: dict, out: Path) -> None:
    from rich.console import Console
    from rich.table import Table

    console = Console()
    table = Table(title=f"sine dwell fe = {doc['fe']:g} Hz, drive {doc['drive_amplitude_v']:g} V peak "
                        f"({doc['backend']}, {doc['duration_s']:g} s recorded)")
    for col, justify in (("channel", "left"), ("units", "left"), ("1×fe", "right"),
                         ("largest k×fe, k ≥ 2", "right"), ("peak", "right")):
        table.add_column(col, justify=justify)
    for name, ch in doc["channels"].items():
        h = ch["harmonics"]
        top = max(h[1:], key=lambda r: r["amplitude"]) if len(h) > 1 else None
        table.add_row(name, ch["units"], f"{h[0]['amplitude']:.4g}",
                      f"{top['amplitude']:.4g} (k = {top['k']})" if top else "-", f"{ch['peak']:.4g}")
    console.print(table)
    force = doc["measured_force_amplitude_n"]
    force_text = f"force amplitude {force:.4g} N, " if force is not None else ""
    warn = f"; safety warnings on {', '.join(doc['warnings'])}" if doc["warnings"] else ""
    plot = f" and {doc['plot']}" if doc.get("plot") else ""
    console.print(f"{force_text}settled: {'yes' if doc['settled'] else 'NO'}{warn}; wrote {out}{plot}")
