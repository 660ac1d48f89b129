"""The buffered inner loop of control-based continuation: a harmonic-domain feedback played block
by block on :class:`~rigtools.acquisition.BlockStream`.

Every block read, the harmonics of the active shroud's displacement over the latest
``window_periods`` whole periods (from its acceleration, ``X_k = -A_k / (k w)^2``) give the drive's
harmonics by the PD law (:func:`rigtools.procedures.cbc_iteration.control_drive`); the drive
(:class:`HarmonicDrive`) cross-fades to them over the next block it writes. The device plays that
block after the two already queued, so a correction reaches the shaker 50-65 ms after the middle
of the data it comes from (two 20 ms pieces, the window's half, the converters). A delayed loop
holds an orbit whose own growth rate is sigma only while sigma times that delay stays well under
1: at 64 Hz, multipliers up to about 1.15-1.2 (sigma = fe lnabs(mu) = 9-12 1/s). The PD law on
a 5-period window held abs(mu) 1.04; the delay-aware law (``Gains.envelope``,
:mod:`rigtools.procedures.cbc_delay`: real 2x2 gains on the fundamental's one-period estimate and
its block-to-block change, designed for the queue's delay over identified models) holds 1.17.
The whole unstable sheet (abs(mu) up to 3.8) needs a per-sample loop at a few kHz with 1-2 ms of
delay: a real-time target.

:class:`BufferedHarmonicLoop` is one inner loop; the outer iteration
(:mod:`rigtools.procedures.cbc`) talks to any object with its :meth:`~BufferedHarmonicLoop.hold`,
:meth:`~BufferedHarmonicLoop.set_gains` and :meth:`~BufferedHarmonicLoop.free_run` (a per-sample
loop of the simulated rig's real-time hook, or of a hardware target, can take its place).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from rigtools.acquisition import BlockStream
from rigtools.drivers.contracts import LimitExceeded
from rigtools.procedures.base import StopRequested
from rigtools.procedures.cbc_iteration import Gains, control_drive, displacement_from_acceleration
from rigtools.procedures.session import PointSink

STEADY_TOLERANCE = 0.002  # successive windows of the response's fundamental agree this well


class InnerLoop(Protocol):
    """What the outer iteration (:mod:`rigtools.procedures.cbc`) needs of an inner loop: the
    buffered harmonic-domain loop here, or a per-sample loop (the simulated rig's real-time hook,
    a hardware target). Constructed as ``factory(device, cfg, monitor, procedure, fe, rows,
    n_harmonics=..., window_periods=...)``; ``sink`` (a :class:`PointSink`) and ``stream`` (its
    :class:`~rigtools.acquisition.BlockStream`) let the procedure record points and end the stream."""

    name: str
    sink: PointSink
    stream: BlockStream

    def set_gains(self, gains: Gains) -> None: ...

    def set_point(self, target: np.ndarray, feedforward: np.ndarray, ramp_time: float) -> None: ...

    def sweep_from(self, f_start: float, seconds: float) -> None: ...

    def wait(self, seconds: float) -> None: ...

    def hold(
        self,
        target: np.ndarray,
        feedforward: np.ndarray,
        *,
        ramp_time: float = ...,
        settle_time: float = ...,
        measure_periods: int = ...,
        max_wait: float = ...,
    ) -> LoopMeasurement: ...

    def free_run(
        self, seconds: float, period_samples: int | None = None
    ) -> tuple[np.ndarray, np.ndarray]: ...

    def finish(self, ramp_time: float | None = None) -> None: ...


class HarmonicDrive:
    """A phase-continuous multi-harmonic drive ``u(t) = Re(sum_k U_k exp(i k w t))``, V, ``t`` the
    drive's own sample count over the rate; new harmonics are reached by a linear cross-fade over
    the next block; :meth:`stop_block` ramps to zero (raised cosine). The drive protocol of
    :class:`~rigtools.acquisition.BlockStream`.

    Parameters
    ----------
    sample_rate, fe
        S/s and the fundamental, Hz.
    n_harmonics
        Harmonics carried (k = 1..n).
    max_drive
        Peak never exceeded: harmonics whose peak bound ``sum_k |U_k|`` is above it are refused.
    ramp_time
        The ramp of :meth:`stop_block`, s.
    """

    def __init__(self, sample_rate: float, fe: float, n_harmonics: int, max_drive: float, ramp_time: float):
        self.sample_rate, self.fe, self.max_drive, self.ramp_time = sample_rate, fe, max_drive, ramp_time
        self.coefficients = np.zeros(n_harmonics, complex)
        self._from = self.coefficients.copy()
        self.samples_written = 0
        self.settled = True
        self.phase_offset = 0.0  # the fundamental's phase at sample s: 2 pi fe s / rate + offset
        self._sweep: tuple[int, int, float] | None = None  # (first sample, samples, start frequency)

    def phase_at(self, sample: int | np.ndarray) -> np.ndarray:
        """Phase of the fundamental (rad) at drive sample(s) ``sample`` (after any sweep)."""
        return 2 * math.pi * self.fe * np.asarray(sample, float) / self.sample_rate + self.phase_offset

    def sweep_from(self, f_start: float, seconds: float) -> None:
        """Sweep the fundamental linearly from ``f_start`` to ``fe`` over ``seconds`` from the
        next sample (phase-continuous; the harmonics held); afterwards the phase runs at ``fe``."""
        self._sweep = (self.samples_written, max(1, round(seconds * self.sample_rate)), float(f_start))

    def set_harmonics(self, harmonics: np.ndarray) -> None:
        """Move to ``harmonics`` (V, k = 1..n) over the next block.

        Raises
        ------
        LimitExceeded
            If their peak bound is above ``max_drive`` or not finite.
        """
        u = np.asarray(harmonics, dtype=complex)
        bound = float(np.sum(np.abs(u)))
        if not (math.isfinite(bound) and bound <= self.max_drive):
            raise LimitExceeded(
                f"the control asks for up to {bound:.3g} V, above max_drive {self.max_drive:g} V"
            )
        self.coefficients = u.copy()

    def _wave(self, start: int, n: int) -> np.ndarray:
        """``(n_harmonics, n)`` unit phasors ``exp(i k theta)`` of samples start..start+n."""
        s = start + np.arange(n)
        theta = self.phase_at(s)
        if self._sweep is not None:
            s0, m, f0 = self._sweep
            # during the sweep: phase = integral of the frequency, continuous at both ends
            j = np.clip(s - s0, 0, m)
            swept = self.phase_at(s0) + 2 * math.pi / self.sample_rate * (
                f0 * j + (self.fe - f0) * j**2 / (2 * m)
            )
            after = swept + 2 * math.pi * self.fe * (s - s0 - j) / self.sample_rate
            theta = np.where(s >= s0, after, theta)
            if start + n >= s0 + m:  # the sweep has ended: the phase runs at fe from here on
                end = self.phase_at(s0) + 2 * math.pi / self.sample_rate * (f0 * m + (self.fe - f0) * m / 2)
                self.phase_offset = float(end - 2 * math.pi * self.fe * (s0 + m) / self.sample_rate)
                self._sweep = None
        k = np.arange(1, self.coefficients.size + 1)
        return np.exp(1j * np.outer(k, theta))

    def next_block(self, n: int) -> np.ndarray:
        n = int(n)
        wave = self._wave(self.samples_written, n)
        fade = (np.arange(n) + 1) / n
        # einsum, not @: a complex vector-matrix product goes through BLAS at ~30 ms a block
        old, new = _combine(self._from, wave), _combine(self.coefficients, wave)
        self._from = self.coefficients.copy()
        self.samples_written += n
        return np.real(old + fade * (new - old))

    def stop_block(self, ramp_time: float | None = None) -> np.ndarray:
        """The present harmonics under a raised-cosine ramp to zero (default ``ramp_time``); the
        last sample is 0 V and the drive holds zero after it."""
        n = max(2, math.ceil((self.ramp_time if ramp_time is None else ramp_time) * self.sample_rate))
        wave = _combine(self.coefficients, self._wave(self.samples_written, n))
        envelope = 0.5 * (1 + np.cos(math.pi * np.arange(n) / (n - 1)))
        self.coefficients = np.zeros_like(self.coefficients)
        self._from = self.coefficients.copy()
        self.samples_written += n
        return np.real(wave) * envelope


def fit_matrix(n: int, rate: float, fe: float, k_max: int) -> np.ndarray:
    """``(n, 2 k_max)``: samples times it give the least-squares cos and sin coefficients of
    harmonics 1..k_max (with an offset fitted and dropped), the fit of
    :func:`rigtools.procedures.session.phasors` as one matrix."""
    w = 2 * np.pi * fe * np.arange(n) / rate
    phase = np.outer(np.arange(1, k_max + 1), w)
    basis = np.vstack([np.ones(n), np.cos(phase), np.sin(phase)])
    return np.linalg.solve(basis @ basis.T, basis)[1:].T.copy()


def _combine(coefficients: np.ndarray, wave: np.ndarray) -> np.ndarray:
    return np.einsum("k,kn->n", coefficients, wave)


class _ControlSink:
    """The stream's sink: keeps blocks (:class:`PointSink`) and runs the control after each one,
    before the stream writes its next drive block. The recording gets only the points' windows
    (the approach and the holds between points are not recorded)."""

    records_every_sample = False

    def __init__(self, sink: PointSink, control) -> None:
        self.sink, self.control = sink, control

    def append(self, block: np.ndarray) -> None:
        self.sink.append(block)
        self.control()


@dataclass
class LoopMeasurement:
    """The steady state the inner loop held (complex harmonics k = 1..H, stream-time phase).

    ``response`` the displacement (m), ``drive`` the drive as written (V), ``force`` the force
    sensor (N), ``accel`` the acceleration (m/s^2); ``steady`` whether two successive windows
    agreed; ``start``/``samples`` the window in stream samples; ``channels`` every input's
    harmonics in the device's order, then the drive's.
    """

    response: np.ndarray
    drive: np.ndarray
    force: np.ndarray
    accel: np.ndarray
    steady: bool
    start: int
    samples: int
    channels: np.ndarray | None = None  # (rows, H): every row's harmonics, the drive last
    change: float = math.inf  # the last two windows' fundamentals apart, over the latest's


class BufferedHarmonicLoop:
    """The harmonic-domain feedback on the buffered path (see the module docstring).

    Parameters
    ----------
    device, cfg, monitor
        The configured device (not started), the rig, its safety monitor.
    procedure
        The running procedure (stop requests).
    fe
        Excitation frequency, Hz (the sample rate over fe need not be whole).
    rows
        Rows of ``force`` and ``accel`` (the active shroud's acceleration) in the blocks.
    n_harmonics
        Harmonics of the target, the drive and the analysis (k = 1..H).
    window_periods
        Whole periods of the window the control estimates the response from.
    ring_seconds
        Latest samples kept for measurements, s.
    """

    name = "buffered"

    def __init__(
        self,
        device,
        cfg,
        monitor,
        procedure,
        fe: float,
        rows: dict[str, int],
        n_harmonics: int = 10,
        window_periods: int = 2,
        ring_seconds: float = 4.0,
    ) -> None:
        self.device, self.cfg, self.proc, self.fe = device, cfg, procedure, fe
        self.rate = device.sample_rate
        self.rows = rows
        self.n_harmonics = n_harmonics
        self.window = max(1, round(window_periods * self.rate / fe))
        self.period = max(1, round(self.rate / fe))
        self.drive = HarmonicDrive(self.rate, fe, n_harmonics, cfg.safety.max_drive, cfg.safety.ramp_time)
        n_rows = len(device.input_channels) + 1
        self.sink = PointSink(n_rows, int(ring_seconds * self.rate))
        self.stream = BlockStream(
            device,
            self.drive,
            sink=_ControlSink(self.sink, self._control),
            safety=monitor,
            record_drive=True,
            abort_ramp_time=cfg.safety.abort_ramp_time,
            hurry=lambda: bool(getattr(procedure, "hurry_requested", False)),
        )
        self.gains = Gains(0.0)
        self.target = np.zeros(n_harmonics, complex)
        self.feedforward = np.zeros(n_harmonics, complex)
        self._ramp: tuple[int, int, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
        self.effort = 0.0  # RMS of the last control term, V
        self._fits: dict[int, np.ndarray] = {}
        self.active = True
        self._last_x1: complex | None = None  # the previous block's one-period fundamental
        # (stream sample, one-period X1 m, played U1 V) per block when a list: identification
        self.block_log: list[tuple[int, complex, complex]] | None = None

    # -- the feedback, once per block ----------------------------------------------------------
    def _control(self) -> None:
        if not self.active or self.sink.total < max(self.window, self.period, self.stream.n):
            self._last_x1 = None
            return
        target, ff = self._ramped()
        x = self.response_now()
        u = control_drive(ff, target, x, self.gains, self.fe)
        x1 = self.fundamental_now()
        envelope = self.gains.envelope
        if envelope is not None:  # the delay-aware law on the fundamental, from one period
            last = x1 if self._last_x1 is None else self._last_x1
            u[0] = ff[0] + envelope.correction(x1 - target[0], x1 - last, target[0], ff[0])
        self._last_x1 = x1
        self.effort = float(np.sqrt(np.sum(np.abs(u - ff) ** 2) / 2))
        self.drive.set_harmonics(u)
        if self.block_log is not None:
            n = self.stream.n  # the drive's fundamental as played over the block just read
            played = self.harmonics(self.sink.last(n)[-1:], self.sink.total - n)[0, 0]
            self.block_log.append((self.sink.total, x1, complex(played)))

    def _ramped(self) -> tuple[np.ndarray, np.ndarray]:
        if self._ramp is None:
            return self.target, self.feedforward
        start, n, t0, f0, t1, f1 = self._ramp
        s = min(1.0, (self.sink.total - start) / n)
        s = 0.5 - 0.5 * math.cos(math.pi * s)
        if s >= 1.0:
            self._ramp = None
        return t0 + s * (t1 - t0), f0 + s * (f1 - f0)

    def harmonics(self, data: np.ndarray, start: int) -> np.ndarray:
        """Complex harmonics ``(rows, H)`` of ``data`` whose first sample is stream sample ``start``,
        phase referred to stream time zero."""
        data = np.atleast_2d(data)
        n = data.shape[1]
        if n not in self._fits:  # the least-squares fit of phasors() as one real matrix per length
            self._fits[n] = fit_matrix(n, self.rate, self.fe, self.n_harmonics)
        coef = data @ self._fits[n]  # (rows, 2H): cos, then sin coefficients
        h = self.n_harmonics
        p = coef[:, :h] - 1j * coef[:, h:]
        k = np.arange(1, self.n_harmonics + 1)
        return p * np.exp(-1j * k * float(self.drive.phase_at(start)))

    def fundamental_now(self) -> complex:
        """Displacement fundamental of the active shroud over the latest whole period (the
        estimate the delay-aware law and its identified model use: the shortest leak-free one)."""
        data = self.sink.last(self.period)[self.rows["accel"]]
        h = self.harmonics(data[None, :], self.sink.total - data.size)[0]
        return complex(displacement_from_acceleration(h, self.fe)[0])

    def response_now(self) -> np.ndarray:
        """Displacement harmonics of the active shroud over the latest control window."""
        data = self.sink.last(self.window)[self.rows["accel"]]
        start = self.sink.total - data.size
        return displacement_from_acceleration(self.harmonics(data[None, :], start)[0], self.fe)

    # -- for the outer iteration ---------------------------------------------------------------
    def read(self) -> np.ndarray:
        """One block; a stop request ramps the drive to zero (recorded) and raises StopRequested."""
        block = self.stream.read()
        if self.proc.stop_requested:
            self.finish(self.cfg.safety.abort_ramp_time)
            raise StopRequested(self.proc.stop_reason)
        return block

    def wait(self, seconds: float) -> None:
        end = self.sink.total + seconds * self.rate
        while self.sink.total < end:
            self.read()

    def set_gains(self, gains: Gains) -> None:
        self.gains = gains
        self._last_x1 = None

    def sweep_from(self, f_start: float, seconds: float) -> None:
        """Sweep the drive's frequency from ``f_start`` up to fe over ``seconds`` (the approach)."""
        self.drive.sweep_from(f_start, seconds)

    def set_point(self, target: np.ndarray, feedforward: np.ndarray, ramp_time: float) -> None:
        """Move the target and the feedforward to new harmonics along a raised cosine of ``ramp_time`` s."""
        t0, f0 = self._ramped()
        self.target, self.feedforward = np.array(target, complex), np.array(feedforward, complex)
        n = round(ramp_time * self.rate)
        self._ramp = (self.sink.total, n, t0, f0, self.target, self.feedforward) if n > 0 else None

    def hold(
        self,
        target: np.ndarray,
        feedforward: np.ndarray,
        *,
        ramp_time: float = 0.1,
        settle_time: float = 0.4,
        measure_periods: int = 10,
        max_wait: float = 3.0,
    ) -> LoopMeasurement:
        """Hold ``target`` with ``feedforward`` (complex harmonics k = 1..H) and measure the steady
        state: after the ramp and ``settle_time`` s, windows of ``measure_periods`` whole periods
        until two successive ones agree in the response's fundamental (or ``max_wait`` s)."""
        self.set_point(target, feedforward, ramp_time)
        self.wait(ramp_time + settle_time)
        n = round(measure_periods * self.rate / self.fe)
        waited, prev = 0, None
        while True:
            start0 = self.sink.total
            while self.sink.total - start0 < n:
                self.read()
            m = self.measure(n)
            waited += self.sink.total - start0
            if prev is not None:
                change = abs(m.response[0] - prev.response[0])
                if change <= STEADY_TOLERANCE * abs(m.response[0]) or waited >= max_wait * self.rate:
                    m.steady = change <= STEADY_TOLERANCE * abs(m.response[0])
                    m.change = float(change / abs(m.response[0])) if abs(m.response[0]) > 0 else math.inf
                    return m
            prev = m

    def measure(self, n: int) -> LoopMeasurement:
        """The harmonics of the latest ``n`` samples of every row."""
        data = self.sink.last(n)
        start = self.sink.total - data.shape[1]
        h = self.harmonics(data, start)
        accel = h[self.rows["accel"]]
        return LoopMeasurement(
            response=displacement_from_acceleration(accel, self.fe),
            drive=h[-1],
            force=h[self.rows["force"]],
            accel=accel,
            steady=False,
            start=start,
            samples=data.shape[1],
            channels=h,
        )

    def free_run(self, seconds: float, period_samples: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Gains at zero, the drive held at its present harmonics: the response's fundamental per
        period over ``seconds`` s, ``(times s, complex X1)``, while the orbit is left alone.
        Afterwards the loop runs on with the gains at zero (an approach follows)."""
        self.active = False
        n = period_samples or round(self.rate / self.fe)
        start = self.sink.total
        try:
            self.wait(seconds)
        finally:  # the loop runs again, with the gains at zero (the drive: the feedforward)
            self.set_gains(Gains(0.0))
            self.active = True
        data = self.sink.last(self.sink.total - start)[self.rows["accel"]]
        count = data.size // n
        times, x1 = np.zeros(count), np.zeros(count, complex)
        for i in range(count):
            piece = data[i * n : (i + 1) * n]
            h = self.harmonics(piece[None, :], start + i * n)[0]
            x1[i] = displacement_from_acceleration(h, self.fe)[0]
            times[i] = (i + 0.5) * n / self.rate
        return times, x1

    def finish(self, ramp_time: float | None = None) -> None:
        """The drive's ramp to zero, recorded; the stream stops."""
        self.active = False
        self.stream.finish(ramp_time)
