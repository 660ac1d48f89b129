"""The running phase-locked loop of :mod:`rigtools.procedures.pll`: one :class:`PllRun` per run
holds the drive's phase history, the PI and the outer force loop, and takes each point from
approach to lock to record (see that module's docstring for what a point is and how it ends)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rigtools.controlled_point import ControlledPoint
from rigtools.errors import UserError
from rigtools.procedures.pll_loop import Detection, PhaseController, PhaseLog, detect, wrap_deg
from rigtools.sim.channel_names import ACTIVE_SHROUD_ACCEL

DETECT_PERIODS = 2  # whole periods in each phase-detector window
FORCE_GAIN = 0.6  # share (log) of the force error the outer loop corrects per update
MAX_FORCE_STEP = 1.5  # largest drive ratio of one outer-loop update
LOSS_DEG = 30.0  # a locked point whose phase error passes this has lost its lock
MIN_FORCE = 0.02  # below this share of the force target the phase is not measured yet


def harmonics_table(det: Detection, names: list[str], force_row: int) -> dict:
    """``{channel: {"amplitude": [...], "phase": [...]}}``, phases relative to the force
    fundamental (``phase_k - k phase_F1``), as a sine point records them."""
    k = np.arange(1, det.harmonics.shape[1] + 1)
    ref = np.angle(det.harmonics[force_row][0])
    return {
        name: {"amplitude": np.abs(h).tolist(), "phase": np.angle(h * np.exp(-1j * k * ref)).tolist()}
        for name, h in zip(names, det.harmonics, strict=True)
    }


def rms_deg(errors: list[float]) -> float:
    """Root mean square of phase errors, deg (``inf`` for none)."""
    return math.sqrt(float(np.mean(np.square(errors)))) if errors else math.inf


class PllRun:
    """The loop's state over a run: the session streams, this object steers it.

    Parameters
    ----------
    proc
        The running :class:`rigtools.procedures.pll.PhaseLockedLoop` (progress, stop requests).
    session
        Its :class:`rigtools.procedures.session.SineSession` (not yet driving).
    params
        Its :class:`rigtools.procedures.pll.PllParameters`.
    """

    name = "buffered"  # the inner loop: the host's, on the buffered stream

    def __init__(self, proc: Any, session: Any, params: Any) -> None:
        self.proc, self.s, self.p = proc, session, params
        self.rate = float(session.rate)
        names = session.names
        if ACTIVE_SHROUD_ACCEL not in names[: session.n_inputs]:
            raise UserError(
                f"the rig file's [daq] has no {ACTIVE_SHROUD_ACCEL!r} channel; the PLL's phase is that "
                "shroud's response to the force"
            )
        self.accel_row = names.index(ACTIVE_SHROUD_ACCEL)
        self.drive_row = session.n_inputs
        # the device's input-to-output delay, in samples: the drive phase each input sample saw
        self.delay = float(session.device.input_to_output_delay()) * self.rate
        self.log = PhaseLog(self.rate, session.fe)
        lo, hi = params.frequency_range()
        self.ctl = PhaseController(params.kp, params.ki, lo, hi, params.max_step)
        self.k_max = max(1, min(params.k_max, int(self.rate / 2 / hi) - 1))
        self.target: float | None = None  # the moving phase target, deg
        self.updates = 0
        cfg = session.cfg
        self.cap_drive, self.cap_name = float(cfg.safety.max_drive), "max_drive"
        lim = session.monitor.limits.get("drive")
        if lim is not None and lim.warning * 0.98 < self.cap_drive:
            self.cap_drive, self.cap_name = lim.warning * 0.98, "drive warning"
        self.limited_by = ""
        self._force_ready = 0  # stream sample from which the last drive change shows in a window

    @property
    def fe(self) -> float:
        return float(self.s.fe)

    def _detect(self, n: int) -> Detection:
        rows = self.s.sink.last(n)
        first = self.s.sink.total - rows.shape[1]
        return detect(
            rows,
            first,
            self.log,
            self.delay,
            force_row=self.s.force_row,
            accel_row=self.accel_row,
            drive_row=self.drive_row,
            k_max=self.k_max,
        )

    def _set_frequency(self, fe: float) -> None:
        if fe != self.fe:
            self.s.set_frequency(fe)
            self.log.change(self.s.drive.samples_written, fe)

    def _steer(self, error: float, dt: float) -> None:
        """One step of the phase loop: the PI's next frequency (buffered: the host runs it)."""
        self._set_frequency(self.ctl.update(self.fe, error, dt))

    def _hold_force(self, det: Detection, force: float, dt: float) -> None:
        """The outer loop: the drive amplitude towards the force target, within the limits."""
        drive = self.s.drive
        if not drive.settled or self.s.sink.total < self._force_ready:
            return
        a, mag = drive.target, abs(det.force)
        if mag <= 0 or a <= 0:
            return
        a_new = a * (force / mag) ** FORCE_GAIN
        a_new = min(max(a_new, a / MAX_FORCE_STEP), a * MAX_FORCE_STEP)
        limit = ""
        n = round(DETECT_PERIODS * self.rate / self.fe)
        peaks = np.max(np.abs(self.s.sink.last(n)), axis=1)
        for row, name in enumerate(self.s.names[: self.s.n_inputs]):
            lim = self.s.monitor.limits.get(name)
            if lim is not None and peaks[row] > 0:
                allowed = a * self.p.margin * lim.warning / peaks[row]
                if a_new > allowed:
                    a_new, limit = allowed, f"{name} warning"
        if a_new > self.cap_drive:
            a_new, limit = self.cap_drive, self.cap_name
        self.limited_by = limit if a_new < a * (force / mag) ** FORCE_GAIN * (1 - 1e-9) else ""
        if abs(a_new / a - 1) > 1e-5:
            self.s.set_drive(a_new, ramp_time=dt)
            # the slower loop: the next update waits until this one shows in a whole window (the
            # drive queued ahead, its ramp, the device's delay, the detector's window)
            shows = 3 * self.s.stream.n + math.ceil(self.delay) + n
            self._force_ready = self.s.sink.total + max(
                shows, round(self.p.force_periods * self.rate / self.fe)
            )

    def _update(self, force: float, phase: float, dt: float) -> tuple[Detection, float] | None:
        """Read one piece and take one step of both loops; ``(detection, phase error)`` or
        ``None`` while the force is still too small to measure a phase."""
        self.s.read()
        n = round(DETECT_PERIODS * self.rate / self.fe)
        if self.s.sink.total < n + self.delay:
            return None
        det = self._detect(n)
        if not abs(det.force) > MIN_FORCE * force:
            # too small a force to measure a phase: the drive still rises towards the target
            # (a first point of 40 N from the initial drive's 0.44 N waited here for ever)
            self._hold_force(det, force, dt)
            return None
        measured = det.phase_deg
        if self.target is None:  # the first point: no branch to follow yet, aim at once
            self.target = phase
        step = self.p.phase_rate * dt
        gap = wrap_deg(phase - self.target)
        self.target = phase if abs(gap) <= step else self.target + math.copysign(step, gap)
        error = wrap_deg(measured - self.target)
        self._steer(error, dt)
        self.updates += 1
        self._hold_force(det, force, dt)
        return det, error

    def point(self, force: float, phase: float, index: int, n_points: int) -> dict:
        """Approach, lock and record one point at ``force`` N and ``phase`` deg."""
        p, s = self.p, self.s
        warnings0 = len(s.stream.stats.warnings)
        start = s.sink.total
        if s.drive.target <= 0:
            s.set_drive(min(p.initial_drive, self.cap_drive))
        self.ctl.reset()
        dt = s.stream.n / self.rate
        history: list[tuple[int, float]] = []  # (stream sample, phase error) once the target is reached
        message, locked = "", False
        lo, hi = p.frequency_range()
        while True:
            out = self._update(force, phase, dt)
            periods = (s.sink.total - start) / self.rate * self.fe
            if out is not None:
                det, error = out
                if self.target == phase:
                    history.append((s.sink.total, error))
                window = [e for t, e in history if t >= s.sink.total - p.lock_periods * self.rate / self.fe]
                spans = bool(history) and history[0][0] <= s.sink.total - p.lock_periods * self.rate / self.fe
                force_ok = abs(abs(det.force) / force - 1) <= p.force_tolerance
                self.proc.emit(
                    "control",
                    point=index,
                    n_points=n_points,
                    update=self.updates,
                    control_error=abs(det.force) / force - 1,
                    text=f"{self.fe:.4f} Hz, phase {det.phase_deg:.2f} deg, {abs(det.force):.4g} N",
                )
                if spans and rms_deg(window) <= p.lock_tolerance and force_ok:
                    locked = True
                    break
                message = self._loss(det, error, lo, hi)
                if message:
                    break
            if periods > p.max_periods:
                rms = rms_deg(
                    [e for t, e in history if t >= s.sink.total - p.lock_periods * self.rate / self.fe]
                )
                if math.isfinite(rms):
                    message = f"no lock within {p.max_periods} periods (phase error RMS {rms:.3g} deg"
                    message += f" over the last {p.lock_periods} periods{self._limit_text()})"
                else:  # no phase measured over the lock periods: the force stayed too small
                    message = (
                        f"no lock within {p.max_periods} periods (the force stayed below {MIN_FORCE:.0%}"
                        f" of {force:g} N, too small to measure the phase{self._limit_text()})"
                    )
                break
        iterations = round((s.sink.total - start) / self.rate * self.fe)
        return self._record(force, phase, index, n_points, locked, message, iterations, start, warnings0, dt)

    def _limit_text(self) -> str:
        return f"; force held short by the {self.limited_by} limit" if self.limited_by else ""

    def _loss(self, det: Detection, error: float, lo: float, hi: float) -> str:
        """Why the loop cannot go on at this point ('' when it can)."""
        amp = abs(det.displacement)
        if self.p.max_amplitude is not None and amp > self.p.max_amplitude:
            return f"amplitude {amp * 1e3:.4g} mm above the limit {self.p.max_amplitude * 1e3:.4g} mm"
        if (self.fe <= lo and error < 0) or (self.fe >= hi and error > 0):
            edge = "f_min" if self.fe <= lo else "f_max"
            return f"the frequency reached {edge} = {self.fe:.4g} Hz with the phase {det.phase_deg:.1f} deg"
        return ""

    def _record(
        self,
        force: float,
        phase: float,
        index: int,
        n_points: int,
        locked: bool,
        message: str,
        iterations: int,
        start: int,
        warnings0: int,
        dt: float,
    ) -> dict:
        """Record ``record_periods`` periods with the loops running (a locked point) or the last
        detector window (a point given up) and make the point."""
        p, s = self.p, self.s
        errors: list[float] = []
        record_from = s.sink.total
        if locked:
            self.proc.emit("recording", point=index, n_points=n_points, text=f"{p.record_periods} periods")
            end = record_from + round(p.record_periods * self.rate / self.fe)
            while s.sink.total < end:
                out = self._update(force, phase, dt)
                if out is not None:
                    errors.append(out[1])
                    if abs(out[1]) > LOSS_DEG:
                        message = f"lock lost while recording (phase error {out[1]:.3g} deg)"
                        break
            n = s.sink.total - record_from
        else:
            n = round(DETECT_PERIODS * self.rate / self.fe)
            record_from = s.sink.total - n
        det = self._detect(n)
        rms = rms_deg(errors)
        f1 = abs(det.force)
        converged = bool(
            locked and not message and rms <= p.lock_tolerance and abs(f1 / force - 1) <= p.force_tolerance
        )
        if not converged and not message:
            message = (
                f"lock not kept while recording: phase error RMS {rms:.3g} deg (at most "
                f"{p.lock_tolerance:g}), force {f1:.4g} N (target {force:g} N)"
            )
        if message:
            tail = "the run stops" if p.on_lock_loss == "stop" else "going on"
            message = f"point {index}: {message}; marked not converged, {tail}"
        cp = ControlledPoint(
            fe_hz=det.fe,
            amplitude_m=abs(det.displacement),
            force_fundamental_n=f1,
            phase_deg=det.phase_deg,
            converged=converged,
            iterations=int(iterations),
            drive_harmonics_ratio=det.drive_harmonics_ratio,
        )
        return {
            "fe": det.fe,
            "force_amplitude": force,
            "phase_target": phase,
            "force_amplitude_measured": f1,
            "drive_amplitude": float(s.drive.target),
            "settled": converged,
            "converged": converged,
            "record_start": (record_from - start) / self.rate,
            "record_samples": int(n),
            "phase_error_rms": rms if math.isfinite(rms) else -1.0,
            "lock_message": message,
            "control_limited_by": self.limited_by,
            "safety_warnings": len(s.stream.stats.warnings) - warnings0,
            "harmonics": harmonics_table(det, s.names, s.force_row),
            "peaks": dict(zip(s.names, np.max(np.abs(s.sink.last(n)), axis=1).tolist(), strict=True)),
            **cp.to_dict(),
        }
