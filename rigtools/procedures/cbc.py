"""Control-based continuation (CBC) in the harmonic domain on the buffered path: ``rig acquire cbc``.

At a fixed excitation frequency ``fe`` a feedback on the active shroud's displacement (a PD law
with a multi-harmonic target, :mod:`rigtools.procedures.cbc_iteration`) holds the rig on an orbit
whose fundamental is the target's; an outer iteration on the target's higher harmonics and the
feedforward makes the control non-invasive (the drive voltage a pure sine: its harmonics 2..10
below ``tolerance`` of its fundamental). The converged point is then an orbit of the rig without
control, stable or not, and the force fundamental F1 it needs is measured. The target's
fundamental amplitude A is the continuation parameter: point after point along ``amplitudes``,
each started from a secant predictor through the last two converged points, so the S-shaped
curve F1(A) through the folds comes out point by point.

The rig is first brought onto the branch to be followed by a slow sweep of the drive frequency up
to ``fe`` at ``approach_drive`` (a stepped sine's path: the impacting branch of the hardening
resonance), then the feedback is switched on with the orbit it found as its first target.

The buffered path plays a correction 50-65 ms after the data it comes from (the device's output
queue); the loop then holds an unstable orbit only while its growth rate times that delay stays
well under 1 (abs(mu) up to about 1.15-1.2 at 64 Hz, see :mod:`rigtools.procedures.cbc_loop`; the
default law on the fundamental, ``law="delay"``, is designed for that delay,
:mod:`rigtools.procedures.cbc_delay`; gains given by the caller select the PD law). On the NI
backend the procedure says so in one line: the whole unstable sheet needs a real-time inner loop.
Where the backend has one (``has_realtime_loop``: the simulated rig) the inner loop is, by
default, that per-sample loop (:mod:`rigtools.procedures.cbc_realtime`, gains 2000 V/m and
2 V s/m, Kd scheduled to 3.5 V s/m up the sheet, unless given), and each converged point's Floquet multipliers are measured by a probe
and a release of its target (``multipliers``); ``inner_loop="buffered"`` keeps the buffered one.

A failed or lost A-step where the leg's last two points (the approach's orbit before the first)
have no turn in A ahead (A rising with the drive, or rising as it falls) is a step too long: it
is cut in half (twice a round at most), each half measured first and then the failed target
again, recorded with ``step_cut``; every attempt after a failed one starts from the leg's last
converged orbit restored, and a leg whose cuts came nearer goes on, within ``CUT_ATTEMPTS``
(:mod:`rigtools.procedures.cbc_cut`). Where A falls as the drive rises (towards the turn in A)
a failed A-step goes on by pseudo-arclength.

A target the real-time loop loses (the held A 10 % from it, or a force peak past 75 % of the
force's abort limit with the loop on) and that no cut gets nearer to ends its leg with one line
saying which and why (``lost``), the drive brought to rest, instead of the run ending on the
safety abort. Below the impacting branch's turn in A (a target under the leg's points that the
loop holds above it, at the turn) the orbit at that A is the one without contact: the rig is
brought to rest and the target, a pure sine, is ramped up from the plant's measured linear
response (``branch`` "no contact").

With ``release_seconds`` the gains are set to zero after the last point (the drive held at its
converged harmonics) and the departure of the response from the orbit is recorded: its growth
rate, s^-1, is ``fe lnabs(mu)`` of the orbit's largest Floquet multiplier.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from rigtools.controlled_point import ControlledPoint
from rigtools.drivers.realtime import NO_REALTIME_LOOP
from rigtools.errors import TargetNotReached, UserError
from rigtools.procedures import rig
from rigtools.procedures.base import ProcedureResult, Status, validate
from rigtools.procedures.cbc_arclength import STEP_CUTS, ArcStep, extrapolate, no_turn_ahead
from rigtools.procedures.cbc_cut import CUT_ATTEMPTS, restore_orbit
from rigtools.procedures.cbc_iteration import (
    DELAY_GAINS,
    ERROR_GROWTH,
    FeedforwardSecant,
    Gains,
    backtrack,
    drive_harmonics_ratio,
    growth_rate,
    half_peak_to_peak,
    picard_update,
    secant_predict,
)
from rigtools.procedures.cbc_loop import BufferedHarmonicLoop, InnerLoop, LoopMeasurement
from rigtools.procedures.cbc_realtime import REALTIME_GAINS, RealTimeHarmonicLoop
from rigtools.procedures.sine import SineProcedure
from rigtools.quantity_fields import Frequency, Length, Time, VoltageAmplitude
from rigtools.units import MAX_GAP

#: The line a backend without a real-time inner loop prints (the NI backend): the buffered loop
#: cannot hold the whole unstable sheet.
REAL_TIME_NOTE = NO_REALTIME_LOOP
INNER_LOOPS = ("realtime", "buffered")
RESPONSE_CHANNEL = "active_shroud_accel"  # the controlled response: the active shroud
WITHOUT_CONTACT_RAMP = 1.0  # s: up to the orbit without contact (the blade's free decay ~0.25 s)
LINEAR_DEPARTURE = 0.05  # a released orbit's departure is fitted up to this share of A


class CBCParameters(BaseModel):
    """A control-based continuation at a fixed frequency (SI: Hz, m, V)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    fe: Frequency = Field(gt=0, le=25000, description="excitation frequency, Hz")
    amplitudes: tuple[Length, ...] = Field(min_length=1, description="target fundamental amplitudes A, m")
    gap: Length | None = Field(None, ge=0, le=MAX_GAP, description="shroud gap, m (None: as set)")
    kp: float = Field(300.0, ge=0, le=1e6, description="proportional gain, V/m")
    kd: float = Field(0.0, ge=0, le=1e4, description="derivative gain, V s/m")
    feedback_harmonics: int = Field(1, ge=0, le=10, description="harmonics 1..n of the error fed back")
    law: Literal["delay", "pd"] = Field(
        "delay",
        description="the buffered loop's law on the fundamental: the delay-aware one (DELAY_GAINS) or PD",
    )
    harmonics: int = Field(10, ge=2, le=20, description="harmonics of target, drive and analysis")
    tolerance: float = Field(0.01, gt=0, le=0.5, description="drive harmonics 2-10 over its fundamental")
    amplitude_tolerance: float = Field(0.005, gt=0, le=0.5, description="|X1 - X1*| / A at convergence")
    max_iterations: int = Field(8, ge=1, le=50, description="outer iterations per point")
    window_periods: int = Field(5, ge=1, le=50, description="periods the control estimates from")
    settle_time: Time = Field(0.4, gt=0, le=20, description="wait after each change, s")
    ramp_time: Time = Field(0.3, gt=0, le=20, description="ramp of each change of target and feedforward, s")
    measure_periods: int = Field(10, ge=2, le=1000, description="periods of each measurement")
    approach_from: Frequency | None = Field(None, gt=0, description="sweep start, Hz (None: fe - 8 Hz)")
    approach_drive: VoltageAmplitude = Field(0.42, gt=0, le=10, description="drive of the sweep, V peak")
    approach_time: Time = Field(6.0, gt=0, le=600, description="sweep duration, s")
    walk_step: Length = Field(
        0.005e-3, gt=0, description="largest step from the approach's orbit to a leg's first point, m"
    )
    release_seconds: Time = Field(0.0, ge=0, le=60, description="gains at zero after the last point, s")
    arclength_points: int = Field(
        4, ge=0, le=50, description="points by pseudo-arclength in (A, drive) after a failed A-step"
    )
    multipliers: bool = Field(True, description="measure each point's multipliers (a real-time loop only)")

    @field_validator("amplitudes")
    @classmethod
    def _positive(cls, amplitudes: tuple[float, ...]) -> tuple[float, ...]:
        # a displacement amplitude is > 0 (the command's --amplitude refuses the rest already)
        bad = [a for a in amplitudes if not a > 0]
        if bad:
            raise ValueError(f"target amplitudes must be > 0 m (got {bad[0]:g})")
        # a plain number is in m: "0.32" (meant mm) would be walked to in 5 um steps for minutes
        big = [a for a in amplitudes if a > MAX_GAP]
        if big:
            raise ValueError(
                f"a target must be at most {MAX_GAP * 1e3:g} mm (got {big[0]:g} m; a plain "
                "number is in m: write units, e.g. '0.32 mm')"
            )
        return amplitudes

    def gains(self) -> Gains:
        envelope = DELAY_GAINS if self.law == "delay" else None
        return Gains(self.kp, self.kd, self.feedback_harmonics, envelope)


#: ``multipliers_not_measured`` of a point that did not converge (its multipliers never tried).
NOT_CONVERGED = "the point did not converge"


@dataclass
class CBCPoint:
    """One point of the continuation: the shared record and what CBC adds."""

    point: ControlledPoint
    control_effort: float  # RMS of the control term u - u_ff over the measurement, V
    target: np.ndarray  # the target's harmonics, m (complex, k = 1..H)
    feedforward: np.ndarray  # V (complex)
    measurement: LoopMeasurement
    tip_amplitude: float  # half the peak-to-peak of the displacement (harmonics 1..H), m
    history: list[dict[str, float]] = field(default_factory=list)
    channel_names: tuple[str, ...] = ()  # the rows of ``measurement.channels``
    multipliers: np.ndarray | None = None  # measured Floquet multipliers (complex), largest first
    stability: dict[str, float | str] = field(default_factory=dict)  # how they were measured (or why not)
    # the measurement's window in the recording point: s from the point's start, and samples
    record_start: float | None = None
    record_samples: int = 0
    arclength: bool = False  # placed by pseudo-arclength (past a turn in A), not at a target A
    lost: str = ""  # why the inner loop let go of the target (the orbit lost), if it did
    branch: str = ""  # "no contact": the orbit without contact, past the turn in A
    step_cut: int = 0  # halvings of a failed A-step this point's target comes from (0: none)
    shape: Any = None  # the inner loop's orbit_shape() at the end (a real-time loop), to restore
    slope: np.ndarray | None = None  # the feedforward secant's Jacobian at the end, to restore

    def multiplier_fields(self) -> dict[str, Any]:
        """``multipliers`` (moduli, largest first), their angles (deg) and the fit's details;
        where none were measured, ``multipliers_not_measured`` (why) if they were tried."""
        if self.multipliers is None:
            return {f"multipliers_{k}": v for k, v in self.stability.items()}
        mu = self.multipliers
        return {
            "multipliers": np.abs(mu).tolist(),
            "multipliers_phase_deg": np.degrees(np.angle(mu)).tolist(),
            "max_multiplier": float(np.max(np.abs(mu))) if mu.size else math.nan,
            **{f"multipliers_{k}": v for k, v in self.stability.items()},
        }

    def attrs(self) -> dict[str, Any]:
        """The recording point's attributes (SI; complex harmonics as amplitude and phase lists)."""
        m = self.measurement
        ref = np.angle(m.force[0])
        k = np.arange(1, m.force.size + 1)

        def rel(z: np.ndarray) -> list[float]:
            return np.angle(z * np.exp(-1j * k * ref)).tolist()

        channels = {}
        if m.channels is not None:
            for name, h in zip(self.channel_names, m.channels, strict=False):
                channels[f"{name}_harmonic_amplitude"] = np.abs(h).tolist()
                channels[f"{name}_harmonic_phase"] = rel(h)
        return {
            **self.point.to_dict(),
            **channels,
            "force_amplitude_measured": self.point.force_fundamental_n,
            "drive_amplitude": float(abs(m.drive[0])),
            "control_effort": self.control_effort,
            "tip_amplitude_active": self.tip_amplitude,
            "steady": bool(m.steady),
            "target_harmonic_amplitude": np.abs(self.target).tolist(),
            "target_harmonic_phase": rel(self.target),
            "feedforward_amplitude": float(abs(self.feedforward[0])),
            "response_harmonic_amplitude": np.abs(m.response).tolist(),
            "response_harmonic_phase": rel(m.response),
            "iteration_drive_ratio": [h["drive_harmonics_ratio"] for h in self.history],
            "iteration_amplitude_error": [h["amplitude_error"] for h in self.history],
            **self.multiplier_fields(),
            **self.window_fields(),
            **({"lost": self.lost} if self.lost else {}),
        }

    def window_fields(self) -> dict[str, Any]:
        """``record_start`` (s from the point's start) and ``record_samples``: the window the
        point's harmonics come from, as every point of a recording states it; empty if unknown."""
        if self.record_start is None:
            return {}
        return {"record_start": self.record_start, "record_samples": self.record_samples}


def cbc_point(
    loop,
    params: CBCParameters,
    target: np.ndarray,
    feedforward: np.ndarray,
    secant: FeedforwardSecant,
    arc: ArcStep | None = None,
) -> CBCPoint:
    """Iterate at one target fundamental until the control is non-invasive: the target's harmonics
    2..H by Picard steps, the feedforward's fundamental by ``secant`` (see the module docstring).
    With ``arc`` the target's amplitude moves too, onto the pseudo-arclength corrector's line
    (:class:`~rigtools.procedures.cbc_arclength.ArcStep`; the measured A and drive), which a
    converged point then meets.

    Where the inner loop learns its target above H from each measurement (the real-time loop's
    ``orbit_shape``), an iterate is not learnt from at once when its window was unsteady (the
    same target held again, from the shape before), nor when its amplitude error grew past
    :data:`~rigtools.procedures.cbc_iteration.ERROR_GROWTH` times the best iterate's (the next
    half way back to the best's target and feedforward, with its shape:
    :func:`~rigtools.procedures.cbc_iteration.backtrack`): at the top of the sheet an orbit that
    slid fed its harmonics into the next target and the loop lost it (A 0.4292 mm, errors
    0.63 -> 8.8 -> 1.3 -> 13.1 %)."""
    fe, a_target = params.fe, abs(target[0])
    history: list[dict[str, float]] = []
    m: LoopMeasurement | None = None
    converged = False
    shape_of = getattr(loop, "orbit_shape", None)  # the real-time loop's target above H
    best: tuple[float, np.ndarray, np.ndarray, Any] | None = None  # the iterate nearest A
    unsteady = 0  # unsteady iterates in a row
    for it in range(1, params.max_iterations + 1):
        before = shape_of() if callable(shape_of) else None
        m = loop.hold(
            target,
            feedforward,
            ramp_time=params.ramp_time,
            settle_time=params.settle_time,
            measure_periods=params.measure_periods,
        )
        ratio = drive_harmonics_ratio(m.drive)
        error = float(abs(m.response[0] - target[0]) / a_target)
        history.append({"drive_harmonics_ratio": ratio, "amplitude_error": error})
        on_arc = arc is None or arc.satisfied(float(abs(m.response[0])), float(abs(m.drive[0])))
        # settled: the last two windows within the amplitude tolerance of each other (steady, the
        # stricter STEADY_TOLERANCE, is what the iteration learns from)
        settled = m.steady or m.change <= params.amplitude_tolerance
        converged = bool(settled and ratio <= params.tolerance and error <= params.amplitude_tolerance)
        converged = converged and on_arc
        lost = getattr(loop, "lost", None)  # the inner loop let go of a lost target
        if lost:
            converged = False
        if converged or lost or it == params.max_iterations:
            break
        if arc is None and callable(shape_of):  # the safeguard (a real-time loop: see above)
            shape = shape_of() if m.steady else before
            if best is None or error < best[0]:
                best = (error, target.copy(), feedforward.copy(), shape)
            elif error > max(ERROR_GROWTH * best[0], params.amplitude_tolerance):  # diverged
                target, feedforward = backtrack((best[1], best[2]), (target, feedforward))
                _restore_shape(loop, best[3])
                unsteady = 0
                continue
            unsteady = 0 if m.steady else unsteady + 1
            if unsteady == 1:  # the same target held again, from the orbit's shape before
                _restore_shape(loop, before)
                continue
        if arc is not None and arc.by_drive:  # the drive on the corrector's line, the target follows
            a_target = float(abs(m.response[0]))
            u1 = arc.drive_for(a_target) * np.exp(1j * np.angle(feedforward[0]))
            target, feedforward = np.array(m.response, complex), np.zeros_like(feedforward)
            feedforward[0] = u1
            continue
        new_ff = secant.step(complex(feedforward[0]), complex(m.response[0]), complex(target[0]))
        target, feedforward = picard_update(target, feedforward, m.response, m.drive)
        feedforward[0] = new_ff
        if arc is not None:  # the target's amplitude onto the corrector's line
            a_target = arc.next_amplitude(float(abs(m.response[0])), float(abs(m.drive[0])))
            target[0] *= a_target / abs(target[0])
    assert m is not None
    x1, f1 = m.response[0], m.force[0]
    point = ControlledPoint(
        fe_hz=fe,
        amplitude_m=float(abs(x1)),
        force_fundamental_n=float(abs(f1)),
        phase_deg=float(np.degrees(np.angle(x1 / f1))) if f1 != 0 else math.nan,
        converged=converged,
        iterations=len(history),
        drive_harmonics_ratio=history[-1]["drive_harmonics_ratio"],
    )
    effort = float(np.sqrt(np.sum(np.abs(m.drive - feedforward) ** 2) / 2))
    pt = CBCPoint(point, effort, target, feedforward, m, half_peak_to_peak(m.response), history)
    pt.lost = lost or ""
    pt.shape = shape_of() if callable(shape_of) else None
    pt.slope = np.array(secant.jacobian)
    return pt


def _restore_shape(loop, shape: Any) -> None:
    """The real-time loop's target above H and mean back to ``shape`` (none: nothing to do)."""
    restore = getattr(loop, "restore_shape", None)
    if shape is not None and callable(restore):
        restore(shape)


def start_state(params: CBCParameters, m: LoopMeasurement) -> tuple[np.ndarray, np.ndarray]:
    """``(target, feedforward)`` of the orbit the approach found: the target its response, the
    feedforward its drive's fundamental."""
    target = np.array(m.response, complex)
    ff = np.zeros_like(target)
    ff[0] = m.drive[0]
    return target, ff


def legs(amplitudes: tuple[float, ...], start: float) -> tuple[list[float], list[float]]:
    """The amplitudes in the order they are measured, as two legs from the approach's orbit
    (amplitude ``start``) outwards: upwards first, then downwards. A target given twice is
    measured once (two converged points at one A give the step cut no secant)."""
    once = set(amplitudes)
    up = sorted(a for a in once if a >= start)
    down = sorted((a for a in once if a < start), reverse=True)
    return up, down


def predicted(
    done: list[CBCPoint], first: tuple[np.ndarray, np.ndarray], amplitude: float
) -> tuple[np.ndarray, np.ndarray]:
    """The secant predictor: ``(target, feedforward)`` at ``amplitude`` through the last two
    converged points (the approach's orbit before there is one), the target's fundamental set to
    ``amplitude`` at the predicted phase."""
    # the two converged points nearest in amplitude, nearest last
    good = sorted((p for p in done if p.point.converged), key=lambda q: -abs(abs(q.target[0]) - amplitude))
    if good:
        amps = [abs(p.target[0]) for p in good[-2:]]
        states = [np.concatenate([p.target, p.feedforward]) for p in good[-2:]]
        s = secant_predict(amps, states, amplitude)
        n = s.size // 2
        target, ff = s[:n].copy(), s[n:].copy()
    else:
        target, ff = (a.copy() for a in first)
    target[0] = amplitude * np.exp(1j * np.angle(target[0]))
    return target, ff


class ControlBasedContinuation(SineProcedure):
    """``rig acquire cbc``: see the module docstring. Each point is written as it converges
    (or gives up); :attr:`points` holds the :class:`CBCPoint` objects."""

    name = "control-based continuation"

    def __init__(self, cfg, params: CBCParameters | dict, out: str | Path, **kwargs: Any) -> None:
        # the inner loop: "realtime" (where the backend has one), "buffered", None (the first
        # that the backend has) or a factory of the InnerLoop protocol
        choice = kwargs.pop("inner_loop", None)
        if isinstance(choice, str) and choice not in INNER_LOOPS:
            raise UserError(f"inner_loop = {choice!r}: choose one of {', '.join(INNER_LOOPS)}")
        self.inner_loop_choice: str | Callable[..., InnerLoop] | None = choice
        self.loop: InnerLoop | None = None
        super().__init__(cfg, out, **kwargs)
        self.params = params if isinstance(params, CBCParameters) else validate(CBCParameters, **params)
        # the gains given by the caller, kept; else the chosen loop's own defaults
        self._gains_given = isinstance(params, CBCParameters) or "kp" in params or "kd" in params
        if not isinstance(params, CBCParameters) and self._gains_given and "law" not in params:
            self.params = self.params.model_copy(update={"law": "pd"})  # gains given: the PD law
        self.points: list[CBCPoint] = []
        self.release: dict[str, Any] = {}
        self.note = ""  # the line rig acquire prints first (the NI backend: REAL_TIME_NOTE)
        self._leg: list[CBCPoint] = []  # the points of the leg being measured
        self._cuts_left = CUT_ATTEMPTS  # the leg's attempts beyond its targets still allowed
        self.lost: list[str] = []  # one line per target the inner loop lost (each ended its leg)
        self.rate = 0.0  # samples per second, once the device is configured

    def first_frequency(self) -> float:
        return self.params.fe

    def parameters_doc(self) -> dict:
        return {**self.params.model_dump(), "kind": "cbc"}

    def startup(self) -> None:
        if self.device is None:
            self.device = rig.open_device(self.cfg, self.backend, **self._device_opts)
        rate = self.rate = rig.configure(self.device, self.cfg)
        if self.params.harmonics * self.params.fe >= 0.45 * rate:
            raise UserError(
                f"fe = {self.params.fe:g} Hz: harmonic {self.params.harmonics} is above 0.45 x the sample rate"
            )
        make = self._inner_loop()
        monitor = rig.safety_monitor(self.cfg, self.device)
        self.specs = rig.channel_specs(self.device, self.cfg, rate)
        names = [s.name for s in self.device.input_channels]
        rows = {"force": rig.force_row(self.device), "accel": names.index(RESPONSE_CHANNEL)}
        self.loop = make(
            self.device,
            self.cfg,
            monitor,
            self,
            self.params.fe,
            rows,
            n_harmonics=self.params.harmonics,
            window_periods=self.params.window_periods,
        )
        # the inner loop is this procedure's session: the base class ramps it to zero on every exit
        self.session = self.loop  # type: ignore[assignment]  # InnerLoop has SineSession's shutdown API
        loop_name = getattr(make, "name", type(self.loop).__name__)
        self.open_writer(
            rig.experiment_metadata(self.name, self.device, self.parameters_doc(), inner_loop=loop_name)
        )

    def _inner_loop(self) -> Callable[..., InnerLoop]:
        """The factory of the inner loop chosen (see ``__init__``); the note where the backend
        has no real-time loop; the real-time loop's gains where none were given."""
        choice = self.inner_loop_choice
        if callable(choice):
            return choice
        has = bool(getattr(self.device, "has_realtime_loop", False))
        if not has and not self.note:
            self.note = NO_REALTIME_LOOP
            self.emit("message", text=NO_REALTIME_LOOP)
        if choice == "buffered" or not has:
            return BufferedHarmonicLoop
        if not self._gains_given:
            self.params = self.params.model_copy(update=dict(zip(("kp", "kd"), REALTIME_GAINS, strict=True)))
        return RealTimeHarmonicLoop

    def execute(self) -> None:
        p = self.params
        loop = self.loop
        if loop is None:
            raise RuntimeError(f"{self.name}: no inner loop; startup() has not run")
        gap = self.set_gap(p.gap)
        self.result.summary["inner_loop"] = loop.name
        first = self._approach(loop, p)
        up, down = legs(p.amplitudes, abs(first[0][0]))
        n, done, skipped = len(up) + len(down), 0, []
        for leg_index, leg in enumerate((up, down)):
            if not leg:
                continue
            if leg_index:  # the second leg starts from the approach's orbit again
                first = self._approach(loop, p)
            secant = self._probe(loop, p, *first)
            secant = self._walk(loop, p, first, leg[0], secant)
            if getattr(loop, "lost", None):  # lost on the walk: the whole leg skipped
                skipped.extend(leg)
                done += len(leg)
                self._leg = []
                continue
            self._cuts_left = CUT_ATTEMPTS
            for j, amplitude in enumerate(leg):
                done += 1
                self.emit("point", point=done, n_points=n, text=f"A = {amplitude * 1e3:.4g} mm")
                after_failure = bool(self._leg) and not self._leg[-1].point.converged
                if after_failure and not self._restore(loop):
                    skipped.extend(leg[j:])  # the last converged orbit not held again: lost
                    done += len(leg) - j - 1
                    break
                target, ff = predicted(self._leg, first, amplitude)
                # the slope learnt so far (after a failed attempt, the last converged point's), a fresh history
                secant = FeedforwardSecant(self._slope(secant) if after_failure else secant.jacobian)
                release = j == len(leg) - 1 and leg_index == 0 and p.release_seconds > 0
                pt = self._measure(loop, gap, amplitude, target, ff, secant, release=release)
                self.emit("point_done", point=done, n_points=n, text=_line(pt))
                if not pt.point.converged and self._beyond_turn(pt, amplitude):  # lost or not
                    below = self._without_contact(loop, gap, amplitude, pt, secant)
                    if below.point.converged:  # the leg goes on along the orbits without contact
                        self._leg = [below]
                        continue
                if not pt.point.converged:  # the A-step failed: past a turn in A, or the orbit is lost
                    if self._no_turn(first):  # a step too long: cut it, the leg goes on if the cuts advance
                        if self._cut_step(loop, gap, first, pt, amplitude, secant, release=release):
                            secant = FeedforwardSecant(self._slope(secant))
                            continue
                    elif pt.lost:
                        self._end_leg_lost(loop, pt, amplitude)
                    elif p.arclength_points:  # past the turn: points on the branch, not at these A
                        self._arclength(loop, gap, secant)
                    skipped.extend(leg[j + 1 :])
                    done += len(leg) - j - 1
                    break
            self._leg = []
        self.result.summary["points"] = [pt.point.to_dict() for pt in self.points]
        self.result.summary["skipped_amplitudes"] = skipped
        self.result.summary["lost"] = self.lost
        loop.finish()
        if not any(pt.point.converged for pt in self.points):  # nothing of the branch measured
            why = self.lost[0] if self.lost else f"none within {p.max_iterations} iterations"
            kept = (
                f"the {len(self.points)} point(s) measured are kept" if self.points else "no point measured"
            )
            raise TargetNotReached(f"no target converged ({why}); {kept}")

    def _measure(
        self,
        loop,
        gap: float,
        amplitude: float,
        target: np.ndarray,
        ff: np.ndarray,
        secant: FeedforwardSecant,
        *,
        release: bool = False,
        arc: ArcStep | None = None,
        branch: str = "",
        cut: int = 0,
    ) -> CBCPoint:
        """One recorded point at ``amplitude`` (or on ``arc``'s corrector line); with ``release``
        and converged, the gains at zero afterwards (:meth:`_release`); ``cut``: the halvings of a
        failed A-step it belongs to (recorded as ``step_cut``)."""
        p = self.params
        kind: dict[str, Any] = {"parameterisation": "arclength"} if arc is not None else {}
        if branch:
            kind["branch"] = branch
        if cut:
            kind["step_cut"] = cut
        self.begin_point({"fe": p.fe, "amplitude_target": amplitude, "gap": gap, **kind})
        pt = cbc_point(loop, p, target, ff, secant, arc=arc)
        pt.arclength = arc is not None
        pt.branch = branch
        pt.step_cut = cut
        pt.channel_names = tuple(spec.name for spec in self.specs)
        pt.record_start = (pt.measurement.start - loop.sink.point_start) / self.rate
        pt.record_samples = pt.measurement.samples
        self._stability(loop, pt)
        self.points.append(pt)
        self._leg.append(pt)
        released = self._release(loop, p) if release and pt.point.converged else {}
        if released:
            self.release = released
        attrs = {**pt.attrs(), **kind, **{f"release_{k}": v for k, v in released.items()}}
        self.end_point({k: v for k, v in attrs.items() if not isinstance(v, list) or v})
        self.result.points.append({"fe": p.fe, "gap": gap, "amplitude_target": amplitude, **attrs})
        return pt

    def _arclength(self, loop, gap: float, secant: FeedforwardSecant) -> list[CBCPoint]:
        """After a failed A-step near a turn in A (A falling as the drive rises, :meth:`_no_turn`
        false; the last secant nearer the drive's axis than A's: the drive changing faster than
        A, relative to each): up to ``arclength_points``
        points by pseudo-arclength in (A, U) from the leg's last two converged points
        (:mod:`rigtools.procedures.cbc_arclength`), recorded with ``parameterisation``
        "arclength"; stops at the first not converged. Elsewhere (an orbit lost on a branch that
        is a graph over A) nothing is tried."""
        done: list[CBCPoint] = []
        for i in range(self.params.arclength_points):
            good = [q for q in self._leg if q.point.converged][-2:]
            if len(good) < 2:
                break
            points = [(abs(q.target[0]), abs(q.feedforward[0])) for q in good]
            step = ArcStep.through(points[0], points[1])
            if i == 0 and not step.by_drive:  # the branch was no turn in A: the orbit is lost
                break
            state = extrapolate([np.concatenate([q.target, q.feedforward]) for q in good], points, step)
            m = state.size // 2
            target, ff = state[:m].copy(), state[m:].copy()
            a_pred, u_pred = step.predictor()
            target[0] = a_pred * np.exp(1j * np.angle(target[0]))
            if step.by_drive:
                ff[0] = u_pred * np.exp(1j * np.angle(ff[0]))
            self.emit("message", text=f"arclength point {i + 1}: A = {a_pred * 1e3:.4g} mm predicted")
            pt = self._measure(loop, gap, a_pred, target, ff, FeedforwardSecant(secant.jacobian), arc=step)
            self.emit("point_done", text=_line(pt))
            done.append(pt)
            if pt.lost:
                self._end_leg_lost(loop, pt, a_pred, "arclength point")
            if not pt.point.converged:
                break
        return done

    def _no_turn(self, first: tuple[np.ndarray, np.ndarray]) -> bool:
        """Whether the leg's last two converged points (the approach's orbit ``first`` before
        its first) have no turn in A ahead (:func:`~rigtools.procedures.cbc_arclength.no_turn_ahead`:
        A rising with the drive, or rising as it falls)."""
        good = [q for q in self._leg if q.point.converged and not q.branch]
        if not good:
            return False
        a_u = [(abs(first[0][0]), abs(first[1][0]))] + [
            (abs(q.target[0]), abs(q.feedforward[0])) for q in good
        ]
        return no_turn_ahead(a_u[-2], a_u[-1])

    def _cut_step(
        self,
        loop,
        gap: float,
        first: tuple[np.ndarray, np.ndarray],
        failed: CBCPoint,
        amplitude: float,
        secant: FeedforwardSecant,
        *,
        release: bool = False,
    ) -> bool:
        """A failed or lost A-step where the branch has no turn in A (:meth:`_no_turn`), cut in
        half (:mod:`rigtools.procedures.cbc_cut`): rounds of up to ``STEP_CUTS`` halvings, each
        half measured (from the secant of the converged points nearest it), then the target
        again; a round that came nearer is followed by another; each attempt after a failed one
        from the last converged orbit restored (:meth:`_restore`); ``CUT_ATTEMPTS`` per leg.
        Returns whether the leg goes on (the target reached, or a cut converged); a lost target
        whose leg does not go on ends it (:meth:`_end_leg_lost`)."""
        advanced, last_failed = False, failed
        while self._cuts_left > 0:  # rounds of cuts, each from the last converged point
            pending, moved = [amplitude], False  # the targets still to reach, the next last
            for cut in range(1, STEP_CUTS + 1):
                if self._cuts_left <= 0:
                    break
                last = abs([q for q in self._leg if q.point.converged][-1].target[0])
                pending.append(0.5 * (last + pending[-1]))
                self.emit("message", text=f"A-step cut ({cut}): A = {pending[-1] * 1e3:.4g} mm first")
                while pending and self._cuts_left > 0:
                    if not self._leg[-1].point.converged and not self._restore(loop):
                        return False  # lost on the way back (the line said, the drive at rest)
                    a = pending[-1]
                    target, ff = predicted(self._leg, first, a)
                    fresh = FeedforwardSecant(self._slope(secant))
                    self._cuts_left -= 1
                    pt = self._measure(
                        loop, gap, a, target, ff, fresh, cut=cut, release=release and a == amplitude
                    )
                    self.emit("point_done", text=_line(pt))
                    if not pt.point.converged:
                        last_failed = pt
                        break
                    pending.pop()
                    moved = True
                if not pending:
                    return True
            advanced = advanced or moved
            if not moved:  # this round's cuts came no nearer
                break
        if not advanced and (failed.lost or last_failed.lost):  # the leg ends: the target lost
            lost = failed if failed.lost else last_failed  # (named), else the cut step lost
            kind = "cut step" if lost.step_cut else "target"
            self._end_leg_lost(loop, lost, amplitude if lost is failed else abs(lost.target[0]), kind)
        return advanced

    def _slope(self, secant: FeedforwardSecant) -> np.ndarray:
        """The feedforward secant's Jacobian at the leg's last converged point (``secant``'s
        where none has one): a failed attempt's Broyden updates, from windows of an orbit that
        slid, are not learnt from."""
        good = [q.slope for q in self._leg if q.point.converged and q.slope is not None]
        return good[-1] if good else secant.jacobian

    def _restore(self, loop) -> bool:
        """The leg's last converged orbit held again after a failed attempt
        (:func:`~rigtools.procedures.cbc_cut.restore_orbit`); ``False`` if the loop lost it on
        the way (the leg ends: the line said, the drive at rest)."""
        q = [q for q in self._leg if q.point.converged][-1]
        a = abs(q.target[0])
        self.emit("message", text=f"back to A = {a * 1e3:.4g} mm, the last converged orbit")
        steady = restore_orbit(loop, q, self.params).steady
        lost = getattr(loop, "lost", None)
        if lost:
            self._end_leg_lost(loop, replace(q, lost=str(lost)), a, "restored orbit")
        elif not steady:
            self.emit("message", text="the last converged orbit held again, not steady: the cut goes on")
        return not lost

    def _beyond_turn(self, pt: CBCPoint, amplitude: float) -> bool:
        """A target below the leg's converged points that the loop held above it (the measured A
        short of the target by more than the tolerance): past the impacting branch's turn in A,
        where the orbit at that A is the one without contact (the loop can set it: the
        inner loop's ``forget_shape``)."""
        below = all(amplitude < abs(q.target[0]) for q in self._leg if q.point.converged)
        held = pt.point.amplitude_m - amplitude > self.params.amplitude_tolerance * amplitude
        return (
            below
            and held
            and any(q.point.converged for q in self._leg)
            and hasattr(self.loop, "forget_shape")
        )

    def _without_contact(
        self, loop, gap: float, amplitude: float, pt: CBCPoint, secant: FeedforwardSecant
    ) -> CBCPoint:
        """The target at ``amplitude`` as a pure sine (the orbit without contact: no harmonics,
        no mean), recorded with ``branch`` "no contact". The impacting orbit the loop held there
        sustains itself (the passive blade rings between impacts) and needs a drive a third
        larger, so the rig is brought to rest, open loop; half the drive that held ``pt`` (no
        impacting orbit there) gives the orbit's linear response ``G = X1 / U1``; the drive
        ``A / G`` and the target ramp up from it slowly with the loop on (the passive blade never
        struck), the secant started from the closed loop's ``G / (1 + G K)`` (``K`` the loop's
        gain at fe)."""
        p = self.params
        self.emit(
            "message", text=f"A = {amplitude * 1e3:.4g} mm past the turn in A: the orbit without contact"
        )
        zero = np.zeros(p.harmonics, complex)
        loop.forget_shape()
        self._to_rest(loop, 1.5)
        probe = zero.copy()
        probe[0] = 0.5 * pt.measurement.drive[0]
        m = loop.hold(zero, probe, ramp_time=1.0, settle_time=1.0, measure_periods=p.measure_periods)
        g = complex(m.response[0] / m.drive[0])
        target, ff = zero.copy(), zero.copy()
        target[0] = amplitude * np.exp(1j * np.angle(m.response[0]))
        ff[0] = target[0] / g
        loop.set_gains(p.gains())
        loop.set_point(target, ff, ramp_time=WITHOUT_CONTACT_RAMP)
        loop.wait(WITHOUT_CONTACT_RAMP + 0.5)
        gain = getattr(loop, "gain_at_fe", None)
        k = complex(gain()) if callable(gain) else 0j
        start = FeedforwardSecant.from_gain((1 + g * k) / g)
        return self._measure(loop, gap, amplitude, target, ff, start, branch="no contact")

    def _end_leg_lost(self, loop, pt: CBCPoint, amplitude: float, kind: str = "target") -> None:
        """The inner loop let go of a lost target: one line saying which and why, the drive down
        to rest; the leg ends there (the next leg starts with its own approach)."""
        line = f"{kind} A = {amplitude * 1e3:.4g} mm lost ({pt.lost}): the leg ends there"
        self.lost.append(line)
        self.emit("message", text=line)
        self._to_rest(loop, 1.0)

    def _to_rest(self, loop, seconds: float) -> None:
        """The gains zero, the target and drive ramped to zero over 0.5 s; ``seconds`` waited."""
        zero = np.zeros(self.params.harmonics, complex)
        loop.set_gains(Gains(0.0))
        loop.set_point(zero, zero, ramp_time=0.5)
        loop.wait(seconds)

    def _walk(
        self, loop, p: CBCParameters, first: tuple[np.ndarray, np.ndarray], amplitude: float, secant
    ) -> FeedforwardSecant:
        """From the approach's orbit to the leg's first amplitude in steps of at most
        ``walk_step`` (continuation points not recorded), so that each step starts near its orbit."""
        a0 = abs(first[0][0])
        steps = math.ceil(abs(amplitude - a0) / p.walk_step - 1e-9)
        for a in np.linspace(a0, amplitude, steps + 1)[1:-1]:
            self.emit("message", text=f"walking to {amplitude * 1e3:.4g} mm: {a * 1e3:.4g} mm")
            target, ff = predicted(self._leg, first, float(a))
            secant = FeedforwardSecant(secant.jacobian)
            pt = cbc_point(loop, p, target, ff, secant)
            if pt.point.converged:
                self._leg.append(pt)
            if pt.lost:  # the leg ends before its first point (execute reads loop.lost)
                self._end_leg_lost(loop, pt, float(a), "walk point")
                break
        return secant

    def _approach(self, loop, p: CBCParameters) -> tuple[np.ndarray, np.ndarray]:
        """Open loop, sweep the drive up to fe at ``approach_drive``; engage the feedback on the
        orbit found (its response the target, its drive the feedforward: no kick)."""
        self.emit("message", text=f"approach: sweep to {p.fe:g} Hz at {p.approach_drive:g} V")
        loop.set_gains(Gains(0.0))
        zero = np.zeros(p.harmonics, complex)
        if self.points:  # from the last orbit: down to rest first (a sweep's jump from it can impact hard)
            self._to_rest(loop, 1.5)
        loop.sweep_from(p.approach_from or max(1.0, p.fe - 8.0), p.approach_time)
        ff = np.zeros(p.harmonics, complex)
        ff[0] = p.approach_drive
        first = start_state(p, loop.hold(zero, ff, ramp_time=0.3, settle_time=p.approach_time + 0.5))
        loop.set_point(*first, ramp_time=0.0)
        loop.set_gains(p.gains())
        self._leg = []
        return first

    def _stability(self, loop, pt: CBCPoint) -> None:
        """The point's multipliers where the inner loop measures them (a real-time loop); a point
        that did not converge is not measured, and says so (``multipliers_not_measured``)."""
        measure = getattr(loop, "multipliers", None)
        if not (self.params.multipliers and callable(measure)):
            return
        if not pt.point.converged:  # no orbit held at the target: its release would measure nothing
            pt.stability = {"not_measured": NOT_CONVERGED}
            return
        try:
            fit, info = measure(pt.measurement)
        except ValueError as exc:  # too few periods in the linear range, or no trusted fit: said, kept
            self.emit("message", text=f"multipliers not measured: {exc}")
            pt.stability = {"not_measured": str(exc)}
            return
        pt.multipliers = fit.multipliers
        pt.stability = {**info, "residual": fit.residual}

    @staticmethod
    def _probe(loop, p: CBCParameters, target: np.ndarray, ff: np.ndarray) -> FeedforwardSecant:
        """The closed loop's ``d X1 / d Uff1`` by finite differences at the approach's orbit
        (1 % of the feedforward, in phase and in quadrature): the first Newton steps' slope."""
        delta = 0.01 * abs(ff[0])
        x0 = loop.hold(target, ff, settle_time=p.settle_time, measure_periods=p.measure_periods).response[0]
        xs = []
        for step in (delta, 1j * delta):
            probe = ff.copy()
            probe[0] += step
            xs.append(
                loop.hold(
                    target, probe, settle_time=p.settle_time, measure_periods=p.measure_periods
                ).response[0]
            )
        return FeedforwardSecant.from_probes(complex(x0), complex(xs[0]), complex(xs[1]), delta)

    @staticmethod
    def _release(loop, p: CBCParameters) -> dict[str, Any]:
        """Gains to zero, drive held: the response's departure from the orbit and its growth rate."""
        times, x1 = loop.free_run(p.release_seconds)
        x0 = x1[0]
        deviation = np.abs(x1 - x0) / abs(x0)
        # the linear range: from 0.5 % (above the first periods' ramp, the control term's step
        # at the release) to 5 % of A (beyond it the departure slows: at A 0.360 mm the rate fitted
        # up to 10 % was 13 % low, up to 5 % 4 %; at 0.350/0.355 mm 33/17 % high against 27/14 %)
        rate, used = growth_rate(times, deviation, 0.005, LINEAR_DEPARTURE)
        return {
            "seconds": p.release_seconds,
            "growth_rate": rate,
            "samples_fitted": used,
            "deviation": deviation.tolist(),
        }


def _line(pt: CBCPoint) -> str:
    q = pt.point
    state = "converged" if q.converged else "not converged"
    return (
        f"A {q.amplitude_m * 1e3:.4f} mm, F1 {q.force_fundamental_n:.4f} N, {q.phase_deg:.1f} deg, "
        f"{state} in {q.iterations}, drive harmonics {q.drive_harmonics_ratio * 100:.2f} %"
    )


__all__ = [
    "REAL_TIME_NOTE",
    "CBCParameters",
    "CBCPoint",
    "ControlBasedContinuation",
    "ProcedureResult",
    "Status",
    "cbc_point",
]
