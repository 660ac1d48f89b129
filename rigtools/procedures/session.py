"""A running sine on the rig: one :class:`~rigtools.acquisition.BlockStream`, its drive, and the
steps every sine procedure takes at a point -- hold the force, wait for steady state, record.

Force control (:meth:`SineSession.hold_force`): the force sensor's fundamental ``F`` (least
squares over whole periods, :func:`rigtools.analysis.harmonics.harmonic_amplitudes`) is held at ``F0`` by
adjusting the drive amplitude ``a``. Each update waits until ``F`` is steady (two successive
windows agree), then takes a secant step on ``|F|(a)`` through the last two measurements (the
first step scales ``a`` by ``F0/|F|``); a step up of more than 10 % aims 10 % below F0.
Steps are limited: at most ``max_step`` times up or
down, and never further than a linear prediction of every limited channel's peak allows
(``margin`` of its warning level) or the drive's own warning / maximum -- the force is
approached from below, so no warning is crossed while converging. At a resonance the force
drops out (the drive needed grows); with impacts the force is rich in harmonics -- the fit of
the fundamental ignores them. If the limits stop the approach -- the force, linear in the drive,
stays short of ``(1 - tolerance) F0`` even at the capped drive, and the capped step is smaller
than the tolerance or the updates are spent -- the limit is named (``limited_by``) and the point
is marked not settled.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rigtools.acquisition import BlockStream
from rigtools.analysis.harmonics import harmonic_amplitudes
from rigtools.drivers.drive_signals import SineDrive
from rigtools.procedures.base import StopRequested

MEASURE_SECONDS = 0.1  # shortest measurement window (whole periods, at least 3)
STEADY_TOLERANCE = 0.002  # a measurement is steady when successive windows agree this well
SETTLED_TOLERANCE = 0.01  # steady state: every input's fundamental within 1 % over 2 windows
MAX_WAIT_SECONDS = 3.0  # longest wait for one steady measurement
APPROACH = 0.9  # large steps up aim at this share of F0 (approach from below)


class PointSink:
    """Forwards blocks to the current recording point (if any) and keeps the latest samples
    in a circular buffer."""

    def __init__(self, n_rows: int, ring_samples: int) -> None:
        self.point = None
        self.total = 0  # samples seen since the stream started
        self.point_start = 0  # stream sample where the current point began
        self._ring = np.zeros((n_rows, max(1, int(ring_samples))))
        self._filled = 0

    @property
    def capacity(self) -> int:
        return self._ring.shape[1]

    def begin(self, point) -> None:
        self.point, self.point_start = point, self.total

    def append(self, block: np.ndarray) -> None:
        if self.point is not None:
            self.point.append(block)
        m, r = block.shape[1], self._ring.shape[1]
        if m >= r:
            self._ring[:, :] = block[:, m - r :]
            pos = (self.total + m) % r
            self._ring = np.roll(self._ring, pos, axis=1)  # keep sample k at index k % r
        else:
            i = self.total % r
            first = min(m, r - i)
            self._ring[:, i : i + first] = block[:, :first]
            self._ring[:, : m - first] = block[:, first:]
        self._filled = min(r, self._filled + m)
        self.total += m

    def last(self, n: int) -> np.ndarray:
        """The latest ``n`` samples (fewer if not that many were kept), a copy."""
        n = min(int(n), self._filled)
        r = self._ring.shape[1]
        idx = (self.total - n + np.arange(n)) % r
        return self._ring[:, idx]

    @property
    def point_samples(self) -> int:
        return self.total - self.point_start


def whole_periods(seconds: float, rate: float, fe: float, min_periods: int = 3) -> int:
    """Samples in the fewest whole periods of ``fe`` lasting at least ``seconds`` (and
    ``min_periods`` periods)."""
    periods = max(min_periods, math.ceil(seconds * fe - 1e-9))
    return round(periods * rate / fe)


def phasor(x: np.ndarray, rate: float, fe: float, k_max: int = 1):
    """Complex amplitudes of harmonics 1..k_max of ``x`` (peak, phase of cos), and the fit."""
    fit = harmonic_amplitudes(x, rate, fe, k_max)
    return fit.amplitude * np.exp(1j * fit.phase), fit


def phasors(rows: np.ndarray, rate: float, fe: float, k_max: int) -> np.ndarray:
    """Complex amplitudes ``(n_rows, k_max)`` of harmonics 1..k_max of every row at once.

    The least-squares fit of :func:`rigtools.analysis.harmonics.harmonic_amplitudes` (offset plus
    cos/sin at k fe, t from the first sample; amplitude ``|c|``, phase ``angle(c)`` of
    ``cos(2 pi k fe t + phase)``), solved for all rows with one set of normal equations:
    ~50x faster than one SVD per channel on a record of many periods, where the basis is
    nearly orthogonal (the normal equations lose nothing measurable there).
    """
    rows = np.atleast_2d(np.asarray(rows, dtype=float))
    n = rows.shape[1]
    w = 2 * np.pi * fe * np.arange(n) / rate
    k = np.arange(1, k_max + 1)
    phase = np.outer(k, w)
    basis = np.vstack([np.ones(n), np.cos(phase), np.sin(phase)])  # (2K+1, n)
    gram = basis @ basis.T
    coef = np.linalg.solve(gram, basis @ rows.T)  # (2K+1, n_rows)
    a, b = coef[1 : k_max + 1], coef[k_max + 1 :]
    return (a - 1j * b).T  # a cos + b sin = Re((a - i b) e^{i w t})


@dataclass
class ControlResult:
    """How force control ended at a point."""

    target: float
    measured: float = math.nan
    drive: float = 0.0
    updates: int = 0
    converged: bool = False
    limited_by: str = ""
    history: list = field(default_factory=list)  # (drive V, |F| N) per measurement
    warnings: int = 0


class SineSession:
    """A sine drive streaming on a configured device; see the module docstring.

    Parameters
    ----------
    device
        Configured device (not started).
    cfg
        The rig (its ``[safety]`` ramps and limits).
    monitor
        :class:`rigtools.drivers.safety.SafetyMonitor` of ``device``.
    fe
        First frequency, Hz.
    procedure
        The running :class:`~rigtools.procedures.base.Procedure` (stop requests, progress).
    force_row
        Row of the force sensor in the blocks.
    ring_seconds
        Latest samples kept for measurements, s (at least the longest record).
    """

    def __init__(
        self, device, cfg, monitor, fe: float, procedure, force_row: int, ring_seconds: float = 2.0
    ) -> None:
        self.device, self.cfg, self.proc = device, cfg, procedure
        self.rate = device.sample_rate
        self.force_row = force_row
        self.monitor = monitor
        self.n_inputs = len(device.input_channels)
        self.names = [s.name for s in device.input_channels] + [cfg.daq.output_spec().name]
        self.drive = SineDrive(self.rate, fe, max_drive=cfg.safety.max_drive, ramp_time=cfg.safety.ramp_time)
        self.sink = PointSink(self.n_inputs + 1, int(ring_seconds * self.rate))
        self.stream = BlockStream(
            device,
            self.drive,
            sink=self.sink,
            safety=monitor,
            record_drive=True,
            abort_ramp_time=cfg.safety.abort_ramp_time,
            hurry=lambda: bool(getattr(procedure, "hurry_requested", False)),
        )
        self.delay = math.ceil(device.input_to_output_delay() * self.rate)
        self._change_end = 0  # stream sample after which the last drive change shows

    @property
    def fe(self) -> float:
        return self.drive.frequency

    # -- streaming -------------------------------------------------------------------------------
    def read(self) -> np.ndarray:
        """One block; a stop request ramps the drive to zero (recorded) and raises StopRequested."""
        block = self.stream.read()
        if self.proc.stop_requested:
            self.stream.finish(ramp_time=self.cfg.safety.abort_ramp_time)
            raise StopRequested(self.proc.stop_reason)
        return block

    def finish(self) -> None:
        """Normal end: the drive's ramp to zero, recorded."""
        self.stream.finish()

    def set_drive(self, amplitude: float, ramp_time: float | None = None) -> None:
        n = math.ceil((self.cfg.safety.ramp_time if ramp_time is None else ramp_time) * self.rate)
        self.drive.set_target(amplitude, ramp_time)
        # the change shows after the queued drive, its ramp and the DAQ delay
        queued = self.stream.stats.samples + 2 * self.stream.n
        self._change_end = queued + n + self.delay

    def set_frequency(self, fe: float) -> None:
        self.drive.set_frequency(fe)
        self._change_end = self.stream.stats.samples + 2 * self.stream.n + self.delay

    def wait_samples(self, n: int) -> None:
        end = self.sink.total + n
        while self.sink.total < end:
            self.read()

    def _wait_change(self) -> None:
        while self.sink.total < self._change_end:
            self.read()

    # -- measuring -------------------------------------------------------------------------------
    def measure(
        self, fe: float, seconds: float = MEASURE_SECONDS, max_wait: float = MAX_WAIT_SECONDS
    ) -> tuple[complex, np.ndarray, bool]:
        """The force fundamental once it is steady: ``(F, peaks per row, steady)``.

        Reads blocks until two successive windows of whole periods (after the last drive change
        has shown) agree within :data:`STEADY_TOLERANCE` (plus the noise), or ``max_wait`` s.
        """
        self._wait_change()
        n = whole_periods(seconds, self.rate, fe)
        while self.sink.total - self._change_end < n:
            self.read()
        start = self.sink.total
        prev = None
        while True:
            data = self.sink.last(n)
            f, fit = phasor(data[self.force_row], self.rate, fe)
            value = complex(f[0])
            if prev is not None:
                noise = 3 * fit.residual_rms * math.sqrt(2.0 / n)
                # magnitudes: successive windows start at different phases of the sine
                if abs(abs(value) - abs(prev)) <= STEADY_TOLERANCE * abs(value) + noise:
                    return value, np.max(np.abs(data), axis=1), True
                if self.sink.total - start >= max_wait * self.rate:
                    return value, np.max(np.abs(data), axis=1), False
            prev = value
            # the next window follows this one (no overlap)
            self.wait_samples(n)

    # -- force control ---------------------------------------------------------------------------
    def hold_force(
        self,
        fe: float,
        target: float,
        *,
        tolerance: float = 0.005,
        max_updates: int = 10,
        initial_drive: float = 0.2,
        max_step: float = 4.0,
        margin: float = 0.8,
        control_ramp: float = 0.05,
        point: int = 0,
        n_points: int = 1,
    ) -> ControlResult:
        """Adjust the drive until the force fundamental is ``target`` N within ``tolerance``.

        The first drive (when none is running) is ``initial_drive`` V, reached along the
        ``[safety] ramp_time`` ramp; every update ramps over ``control_ramp`` s. At most
        ``max_updates`` updates after that ramp.
        """
        res = ControlResult(target)
        warnings0 = len(self.stream.stats.warnings)
        if self.drive.target <= 0:
            self.set_drive(min(initial_drive, self.cfg.safety.max_drive))
        cap_drive, cap_name = self.cfg.safety.max_drive, "max_drive"
        lim = self.monitor.limits.get("drive")
        if lim is not None and lim.warning * 0.98 < cap_drive:
            cap_drive, cap_name = lim.warning * 0.98, "drive warning"
        while True:
            a = self.drive.target
            f, peaks, _steady = self.measure(fe)
            mag = abs(f)
            res.history.append((a, mag))
            err = mag / target - 1.0
            self.proc.emit(
                "control",
                point=point,
                n_points=n_points,
                update=res.updates,
                control_error=err,
                text=f"{mag:.4g} N at {a:.4g} V",
            )
            if abs(err) <= tolerance:
                res.converged = True
                break
            a_new = self._next_drive(res.history, target)
            if mag < APPROACH * target and a_new > 1.1 * a:
                # a large step up: aim 10 % low, so that a response stiffening with the drive
                # (impacts) does not carry the force past F0; the next, small step finishes
                a_new = self._next_drive(res.history, APPROACH * target)
            a_new = min(max(a_new, a / max_step), a * max_step)
            # linear prediction of every limited channel's peak: stay below margin * warning
            limit_name = ""
            for row, name in enumerate(self.names[: self.n_inputs]):
                lim_c = self.monitor.limits.get(name)
                if lim_c is not None and peaks[row] > 0:
                    allowed = a * margin * lim_c.warning / peaks[row]
                    if a_new > allowed:
                        a_new, limit_name = allowed, f"{name} warning"
            if a_new > cap_drive:
                a_new, limit_name = cap_drive, cap_name
            # a limit holds the force short of F0 when even at the capped drive (the force linear in
            # the drive) it stays below (1 - tolerance) F0. There, a capped step up by less than the
            # tolerance is no progress: the cap moves with the noise of the measured peaks (~1e-4 of
            # the drive), and following it spent the updates and ended without naming the limit.
            # When the updates are spent, the same rule gives the verdict.
            short = bool(limit_name) and mag < target and mag * a_new / a < (1 - tolerance) * target
            if short and (a_new <= a * (1 + tolerance) or res.updates >= max_updates):
                res.limited_by = limit_name
                break
            if res.updates >= max_updates:
                break
            self.set_drive(a_new, control_ramp)
            res.updates += 1
        res.measured, res.drive = abs(res.history[-1][1]), self.drive.target
        res.warnings = len(self.stream.stats.warnings) - warnings0
        return res

    @staticmethod
    def _next_drive(history: list, target: float) -> float:
        a1, f1 = history[-1]
        if f1 <= 0:
            return a1 * 4
        if len(history) >= 2:
            a0, f0 = history[-2]
            if abs(a1 - a0) > 1e-3 * a1 and (f1 - f0) / (a1 - a0) > 0:
                slope = (f1 - f0) / (a1 - a0)
                guess = a1 + (target - f1) / slope
                if guess > 0:
                    return guess
        return a1 * target / f1

    # -- steady state and recording --------------------------------------------------------------
    def settle(self, fe: float, seconds: float = 0.2, max_wait: float = MAX_WAIT_SECONDS) -> bool:
        """Wait until the fundamental of every input agrees over two successive windows of
        ``seconds`` (whole periods) within :data:`SETTLED_TOLERANCE` (plus noise)."""
        n = whole_periods(seconds, self.rate, fe)
        # a channel far below its limits (a passive shroud without impacts) is steady enough when
        # it moves by less than 0.1 % of its warning level
        floor = np.array(
            [
                1e-3 * self.monitor.limits[name].warning if name in self.monitor.limits else 0.0
                for name in self.names[: self.n_inputs]
            ]
        )
        self._wait_change()
        start = self.sink.total
        prev = None
        while True:
            while self.sink.total - max(start, self._change_end) < n:
                self.read()
            data = self.sink.last(n)[: self.n_inputs]
            fundamentals, noise = [], []
            for row in data:
                p, fit = phasor(row, self.rate, fe)
                fundamentals.append(abs(p[0]))
                noise.append(3 * fit.residual_rms * math.sqrt(2.0 / n))
            amps = np.array(fundamentals)
            if prev is not None:
                ok = np.abs(amps - prev) <= SETTLED_TOLERANCE * amps + np.array(noise) + floor
                if np.all(ok):
                    return True
                if self.sink.total - start >= max_wait * self.rate:
                    return False
            prev = amps
            start_next = self.sink.total
            while self.sink.total - start_next < n:
                self.read()

    def record(self, fe: float, periods: int, k_max: int = 10) -> dict:
        """Read ``periods`` whole periods and analyse them: harmonics 1..K of every channel
        (amplitude, and phase relative to the force fundamental: ``phase_k - k phase_F1``)."""
        n = round(periods * self.rate / fe)
        start = self.sink.point_samples
        self.wait_samples(n)
        data = self.sink.last(self.sink.total - (self.sink.point_start + start))[:, :n]
        k_max = max(1, min(k_max, int(self.rate / 2 / fe) - 1))
        fits = phasors(data, self.rate, fe, k_max)
        ref = np.angle(fits[self.force_row][0])
        k = np.arange(1, k_max + 1)
        harmonics = {}
        for name, p in zip(self.names, fits, strict=True):
            rel = np.angle(p * np.exp(-1j * k * ref))
            harmonics[name] = {"amplitude": np.abs(p).tolist(), "phase": rel.tolist()}
        return {
            "record_start": start / self.rate,
            "record_samples": n,
            "force_amplitude_measured": float(abs(fits[self.force_row][0])),
            "harmonics": harmonics,
            "peaks": np.max(np.abs(data), axis=1).tolist(),
        }

    def run_point(
        self,
        fe: float,
        force: float,
        *,
        record_periods: int,
        k_max: int = 10,
        point: int = 0,
        n_points: int = 1,
        **control,
    ) -> dict:
        """Hold ``force`` at ``fe``, settle, record; the point's parameters and analysis."""
        warnings0 = len(self.stream.stats.warnings)
        if abs(self.fe - fe) > 1e-12 * fe:
            self.set_frequency(fe)
        ctl = self.hold_force(fe, force, point=point, n_points=n_points, **control)
        self.proc.emit("settling", point=point, n_points=n_points, text=f"{fe:g} Hz")
        steady = self.settle(fe)
        self.proc.emit("recording", point=point, n_points=n_points, text=f"{record_periods} periods")
        rec = self.record(fe, record_periods, k_max)
        settled = bool(steady and ctl.converged and abs(rec["force_amplitude_measured"] / force - 1) <= 0.01)
        return {
            "fe": fe,
            "force_amplitude": force,
            "force_amplitude_measured": rec["force_amplitude_measured"],
            "drive_amplitude": float(self.drive.target),
            "control_updates": ctl.updates,
            "settled": settled,
            "control_converged": ctl.converged,
            "control_limited_by": ctl.limited_by,
            "control_warnings": ctl.warnings,
            "safety_warnings": len(self.stream.stats.warnings) - warnings0,
            "record_start": rec["record_start"],
            "record_samples": rec["record_samples"],
            "harmonics": rec["harmonics"],
            "peaks": dict(zip(self.names, rec["peaks"], strict=True)),
            "control_history": ctl.history,
        }


def point_attrs(result: dict) -> dict:
    """The recording point parameters of a :meth:`SineSession.run_point` result."""
    attrs = {
        k: result[k]
        for k in (
            "force_amplitude_measured",
            "drive_amplitude",
            "control_updates",
            "settled",
            "record_start",
            "record_samples",
        )
    }
    attrs["control_limited_by"] = result["control_limited_by"]
    attrs["safety_warnings"] = result["safety_warnings"]
    for name, h in result["harmonics"].items():
        attrs[f"{name}_harmonic_amplitude"] = h["amplitude"]
        attrs[f"{name}_harmonic_phase"] = h["phase"]
    return attrs
