"""The per-sample inner loop of control-based continuation: the backend's real-time loop
(:mod:`rigtools.drivers.realtime`; the simulated rig runs it inside its integrator).

The split of the work, as on a rig with a real-time target next to it:

* the loop (down-link): the PD law ``u = Kp (x* - x) + Kd (v* - v)`` per sample at its rate
  and delay, added to the drive at the amplifier's input. The host sends it the target, the
  CBC's harmonics 1..H (:class:`~rigtools.drivers.realtime.HarmonicTarget`), between blocks;
* the host: plays the feedforward (a pure sine, the drive's fundamental the unknown) and keeps
  the outer iteration of :mod:`rigtools.procedures.cbc` unchanged: the target's harmonics 2..H
  take the measured ones, the feedforward the total drive's fundamental, until the total drive
  (host plus loop, what reaches the amplifier) has harmonics 2..10 below the stated fraction;
* the up-link: the loop's own measurement of the displacement and its output, per sample
  (:attr:`rigtools.drivers.simulated.SimulatedRig.loop_log`), from which the host takes the
  response's harmonics (in the loop's clock, the one the target is in) and the total drive's.

The measured multipliers of a converged point (:meth:`RealTimeHarmonicLoop.multipliers`): the
target set to the orbit the loop measured (40 harmonics: the control is then zero), then a few
short releases, each: a 0.02 % larger target for 4 periods (the probe), the target released (open
loop at the orbit's drive), the orbit's target again. A release is placed to begin 3 periods
before the end of a block; from those 3 periods (model-free: the deviation's size and the growth
of its period-to-period step; from the second release on, the fit of the earlier ones) the host
computes how much longer the rig may run free before the deviation since the release passes 3 %
of A, and moves the re-engagement there (``_release_periods``; at most 20 periods): the drift
is bounded whatever the orbit's multiplier and whatever the previous point gave. The loop holds
the orbit 24 periods between releases. Each release's displacement (the loop's own), minus the
orbit averaged over the 16 periods before its probe, is differenced period to period (a small
mismatch of the held drive moves the rig towards a neighbouring orbit: a constant step, which
the difference removes and which would otherwise show as a multiplier 1) from the first instant
at the drive's phase 0 a quarter period or more after the release on (``_section_shift``: every
piece's periods then begin at one phase of the orbit, and the pooled pairs follow one map; cut at
each release's own phase they followed maps between different sections, which no one matrix fits:
+13.9 % at A 0.3843 mm), and the releases' pairs of periods within the 3 % are pooled in one fit
(:func:`rigtools.analysis.floquet.pooled_floquet_multipliers`; long releases, 20 pairs or more,
at 8 instants a period; shorter ones, as an unstable orbit's are, with each period as the
deviation's mean and harmonics 1-3, the impacts' shifted instants left out, in three directions,
the slowest real multiplier and a pair: the instants or more directions fitted to few pairs gave
spurious multipliers, to +119 %) until 12 pairs or 5 releases. Where the fit so far decays
(largest abs(mu) < 1) the following releases also step the drive: the host's drive fundamental is
0.1 % larger while the loop holds the orbit (:data:`DRIVE_PROBE`), so the release plays the
step. The target's probe reaches the differenced transient weakened by abs(mu - 1), and next to the
fold (a real multiplier 0.9-1, the orbits around the F1 minimum) that mode then lay under the held
orbit's wobble (0.1-0.4 % of A, 5-20 times the probe): the fit took the 0.80 pair for the largest
(-10.3 % and -16.8 % on two of five paths measured). A decaying fit is taken only with such a
piece among its own, and any fit only with its one-period map's residual within
:data:`RESIDUAL_LIMIT`; a point whose fit is still not taken after the 5 releases carries no
multiplier, and says why (``multipliers_not_measured``), rather than a wrong one. Afterwards the
loop holds the orbit until its error is back within 1.5 times
what it was before the first probe (or 0.3 % of A; at most 2 s): the measurement leaves the rig
where it found it.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from rigtools.analysis.floquet import (
    MeasuredMultipliers,
    TransientPiece,
    periodic_reference,
    pooled_floquet_multipliers,
)
from rigtools.drivers.contracts import ConfigurationError
from rigtools.drivers.realtime import HarmonicTarget, RealTimeLoop
from rigtools.procedures.cbc_iteration import Gains
from rigtools.procedures.cbc_loop import BufferedHarmonicLoop, LoopMeasurement, fit_matrix
from rigtools.sim.delayed_feedback import loop_gain

#: The real-time loop's gains by default (V/m, V s/m), scheduled with the target's fundamental
#: (:func:`scheduled_gains`). At 64 Hz, 10 kHz and 1.04 ms the delay turns Kp into negative
#: damping at fe (:func:`rigtools.sim.delayed_feedback.loop_gain`: Kp 2000 with Kd 1 nets
#: -485 V/m, with Kd 2 -121 V/m): the controlled orbit's slow mode (sidebands fe +- 8 Hz) is
#: then barely damped, and as the sheet's growth rises the orbit stops being steady (Kd 1 near
#: A 0.38 mm, Kd 2 near 0.42 mm). Kd 3.5 (+426 V/m) holds it further (the model's orbits held
#: point after point, 1 s each: to 0.439 mm), but on the stable side and the F1 minimum's
#: neighbourhood Kd above 3 pulls the controlled rig onto the impact-limited orbit (A ~0.306 mm,
#: F1 rising) when the target moves: Kd 2 there. Kp other than ~2000 V/m loses the sheet's
#: orbits sooner either way (1500 and 2500-4000 V/m, with Kd keeping +260..+670 V/m).
#: Past the ramp the law's output goes through the loop's second-order low-pass at
#: :data:`SCHEDULE_LOWPASS` Hz with Kd 4 (the impacts' broadband content no longer fed back):
#: the model's own orbits held point after point, 1 s each, to A 0.4951 mm (largest multiplier 6.0) within
#: 1e-3 of A, against 0.439 mm for the plain law at any Kp, Kd tried (corners 250-700 Hz, Kd
#: 3-5: 350-400 Hz with Kd 4 best; the landscape is narrow).
#: Why narrow (benchmarks/cbc_realtime_margins.py: loop_gain times the rig's linear plant, drive
#: to displacement through the shaker): the stiffness the loop adds moves the blade's first mode
#: from 52 Hz to about 75 Hz, and there, with the delay, this law's gain margin is 1.13 (blades
#: apart; 1.51 in contact): Kp 2200, a 300 Hz corner or Kd 3.75 bring it to 0.92-1.05. More
#: phase lead buys margin (Kd 5 at 400 Hz: 1.56) but turns C(fe) from pure stiffness
#: (2564 - 55i V/m) to +150..+700i, and every such law tried lost the sheet at 0.40-0.46 mm (the
#: orbit slid to another A at the drive); less stiffness (Kp 1500-1800) too. Within this PD and
#: low-pass the margin near pure stiffness at fe is at most ~1.35, and only with 3-6 times the
#: gain at 0.5-1 kHz: a law with lead at ~75 Hz but none at fe needs another filter.
REALTIME_GAINS = (2000.0, 2.0)
#: At the impacting branch's turn in A (0.3059 mm) the law's gain feeds the weak impacts' timing
#: back as harmonics: Kp 2000, Kd 2 left 1.3 % of drive harmonics at 0.3076 mm in 8 iterations,
#: Kp 1000, Kd 1 (gain margin 2.73) 0.61 %. Soft below SCHEDULE_SOFT_A[0], ramped to
#: REALTIME_GAINS at SCHEDULE_SOFT_A[1] (below the approach's orbit: the up leg's path unchanged).
SOFT_GAINS = (1000.0, 1.0)  # V/m, V s/m
SCHEDULE_SOFT_A = (0.309e-3, 0.316e-3)  # m
SCHEDULE_KD = (2.0, 3.5)  # V s/m: Kd below and above the ramp
SCHEDULE_A = (0.40e-3, 0.43e-3)  # m: the ramp of Kd in the target's fundamental
SCHEDULE_FILTERED_KD = 4.0  # V s/m: Kd with the low-pass, from SCHEDULE_A[1] on
SCHEDULE_LOWPASS = 350.0  # Hz: the loop's output low-pass from SCHEDULE_A[1] on
ORBIT_HARMONICS = 40  # harmonics of the loop's target (above the CBC's H: the measured ones)
PROBE = 2e-4  # the probe: the target this much larger, relative
PROBE_PERIODS = 4
HOLD_PERIODS = 24  # the orbit held before the first probe
REFERENCE_PERIODS = 16  # the orbit: the average of the periods held before each probe
LINEAR_LIMIT = 0.03  # releases and fits end where the growth since the release passes this share of A
OBSERVED = 3  # periods of a release seen before it is extended (or not)
RELEASES = 5  # release pieces at most per point, pooled in one fit
ENOUGH_PAIRS = 12  # the pooled fit stops at this many pairs of periods
RECAPTURE = 24  # periods the loop holds the orbit after a release, before the next piece
LONG_PAIRS = 20  # releases with this many pairs in all: fitted at 8 instants a period, every direction
FIT_HARMONICS = 3  # shorter ones: each period's deviation as its mean and harmonics 1..3 of fe,
FIT_RANK = 3  # in three directions (the slowest real multiplier and a pair)
SETTLED = 0.003  # after the pieces the orbit is held until its error is within this share of A
SETTLE_SECONDS = 2.0  # (or within 1.5 times the error before the first probe), this long at most
MAX_RELEASE = 20  # periods of a release at most
# a pooled fit whose one-period map leaves a larger relative residual is not taken (more releases,
# then no multiplier): the pairs follow no one linear map. On the benchmark's three grids and four
# short paths near the fold (benchmarks/bench_cbc_realtime.py, cbc_realtime_fold_paths.py) the fits
# within 6 % of the model's left at most 0.084; over it: 0.12 at A 0.4125 mm (|mu| 1.97, the fit of
# one release of 10 periods), 0.79 and 0.88 on the upper sheet (1.06 and 0.91 against the model's
# 2.37 and 3.33: fits of 2 pairs). Pieces cut at their releases' own phases (before
# :func:`_section_shift`) left up to 0.41
RESIDUAL_LIMIT = 0.1
SECTION_GUARD = 0.25  # periods: the fitted periods begin at the drive's phase 0 after the release + this
# an orbit whose pieces' fit so far decays (largest |mu| < 1) is probed by its drive as well: the
# host's drive fundamental this much larger while the loop holds the orbit (the loop takes up the
# difference), so that each release steps the drive by it. The target's probe enters the
# period-to-period difference weakened by |mu - 1|: next to the fold (a real multiplier 0.9-1) it
# left that mode under the held orbit's wobble, and the fit took the 0.80 pair for the largest. A
# drive step dU moves the released orbit towards its neighbour (1 - M)^-1 B dU, whose differenced
# transient starts at -B dU: not weakened, however close the multiplier is to 1
DRIVE_PROBE = 1e-3
DRIVE_STEP_BLOCKS = 4  # waited after a change of the host's drive: two blocks queued, the fade, one
GROWTH_FLOOR = 1.3  # the growth per period assumed at least when extending a release
GROWTH_MARGIN = 1.2  # the margin on the growth estimate
# a target lost (the loop no longer holds an orbit near it): the hold stops and lets go, the CBC
# ends the leg (rather than the force's safety abort ending the run)
LOST_FORCE = 0.75  # a block's force peak above this share of the force's abort limit, loop engaged
LOST_ERROR = 0.10  # or the held response's fundamental this far from the target's, relative
# at the top of the sheet the controlled orbit beats with the loop's ~72 Hz mode (sidebands at
# fe +- 8 Hz): from here each measurement spans two beats (16 periods at 64 Hz), not 1.25
WIDE_WINDOW_A = 0.475e-3  # m
WIDE_WINDOW_PERIODS = 16
# and a hold there waits up to this long (s; 3 s below) for two windows that agree: the orbit 2 %
# below grazing wanders by 1-5 % of A over tens of periods (the loop's slow mode and the beat)
# between calm spells of 0.1-0.4 %; 3 s often ended inside a wander (the point then not learnt
# from), 6 s gave 27 points to 0.4829 mm on the grid (26 to 0.4817 mm with 3 s) and 27 to
# the end 0.491 mm on the second (25 to 0.4746 mm)
WIDE_WINDOW_MAX_WAIT = 6.0


def scheduled_gains(amplitude: float) -> tuple[float, float, float | None]:
    """The default law ``(Kp V/m, Kd V s/m, low-pass Hz or None)`` at a target fundamental
    ``amplitude`` (m): Kp 1000, Kd 1 below 0.309 mm (:data:`SOFT_GAINS`), ramped to Kp 2000,
    Kd 2 at 0.316 mm; Kd 2 up to 0.40 mm, rising linearly to 3.5 below 0.43 mm, no low-pass;
    from 0.43 mm Kd 4 with the output low-pass at 350 Hz (see :data:`REALTIME_GAINS`; tuned on
    the simulated rig at 64 Hz, gap 0.5 mm)."""
    a0, a1 = SCHEDULE_A
    if amplitude >= a1:
        return REALTIME_GAINS[0], SCHEDULE_FILTERED_KD, SCHEDULE_LOWPASS
    s0, s1 = SCHEDULE_SOFT_A
    if amplitude < s1:
        s = min(1.0, max(0.0, (amplitude - s0) / (s1 - s0)))
        kp, kd = (soft + s * (full - soft) for soft, full in zip(SOFT_GAINS, REALTIME_GAINS, strict=True))
        return kp, kd, None
    s = min(1.0, max(0.0, (amplitude - a0) / (a1 - a0)))
    return REALTIME_GAINS[0], SCHEDULE_KD[0] + s * (SCHEDULE_KD[1] - SCHEDULE_KD[0]), None


class RealTimeHarmonicLoop(BufferedHarmonicLoop):
    """The CBC's inner loop on the backend's real-time loop (see the module docstring); the
    :class:`~rigtools.procedures.cbc_loop.InnerLoop` protocol, constructed as the buffered loop
    is. Its gains (V/m, V s/m) are the procedure's, fixed for the run, or, when they are the
    defaults (:data:`REALTIME_GAINS`), scheduled with each hold's target fundamental
    (:func:`scheduled_gains`; the device's ``set_loop_gains``).

    Raises
    ------
    ConfigurationError
        The device has no real-time loop.
    """

    name = "realtime"

    def __init__(self, device, cfg, monitor, procedure, fe: float, rows: dict[str, int], **kwargs) -> None:
        if not getattr(device, "has_realtime_loop", False):
            raise ConfigurationError(f"the {device.backend} backend has no real-time inner loop")
        params = getattr(procedure, "params", None)
        kp, kd = (params.kp, params.kd) if params is not None else REALTIME_GAINS
        self.law = RealTimeLoop(kp=kp, kd=kd)
        self.base_gains = (kp, kd)
        self.scheduled = (kp, kd) == REALTIME_GAINS and hasattr(device, "set_loop_gains")
        device.set_realtime_loop(self.law)
        super().__init__(device, cfg, monitor, procedure, fe, rows, **kwargs)
        self.engaged = False
        # the loop's target above the CBC's harmonics: the response's, as last measured (a
        # per-sample loop feeds back every harmonic; a target truncated to H would push)
        self.upper = np.zeros(max(0, ORBIT_HARMONICS - self.n_harmonics), complex)
        self.mean = 0.0  # and the mean (impacts on one side shift it; a target without it pushes)
        rate = device.sample_rate
        self._upper_fits: dict[int, np.ndarray] = {}
        self._line = max(0, round(device.input_to_output_delay() * rate - 0.5))  # the delay line
        self.lost: str | None = None  # why the last hold's target was lost, if it was
        limit = getattr(getattr(cfg, "safety", None), "limits", {}).get("force")
        self._force_guard = None if limit is None else LOST_FORCE * float(limit.abort)

    # -- per block: the host's drive and the loop's target ---------------------------------------
    def _control(self) -> None:
        if not self.active:
            return
        target, ff = self._ramped()
        self.drive.set_harmonics(ff)
        self.device.set_loop_target(self.loop_target(target) if self.engaged else None)

    def loop_target(self, target: np.ndarray) -> HarmonicTarget:
        """The target's harmonics (stream phase) as the loop's :class:`HarmonicTarget`."""
        z = np.concatenate([np.asarray(target, complex), self.upper])
        k = np.arange(1, z.size + 1)
        z = z * np.exp(1j * k * self.drive.phase_offset)
        return HarmonicTarget(self.fe, tuple(z.real), tuple(-z.imag), self.mean)

    def set_gains(self, gains: Gains) -> None:
        """Zero: the loop's output 0 (no target); else the loop's own gains engage it."""
        if gains.zero:
            self.engaged = False
        elif (gains.kp, gains.kd) != self.base_gains:
            raise ConfigurationError(
                f"the real-time loop runs with kp {self.base_gains[0]:g} V/m, kd {self.base_gains[1]:g} V s/m; "
                f"its gains cannot change to {gains.kp:g}, {gains.kd:g} while it runs"
            )
        else:
            self.engaged = True
        self.gains = gains

    def hold(self, target: np.ndarray, feedforward: np.ndarray, **kwargs) -> LoopMeasurement:
        """As the buffered loop's; with scheduled gains, the loop's gains for this target first.

        A target lost (:attr:`lost` says why, else ``None``): a block's force peak past
        :data:`LOST_FORCE` of the force's abort limit while the loop holds it (the hold stops
        there), or the measured fundamental more than :data:`LOST_ERROR` from the target's. The
        loop then lets go (its output 0, the host's drive held) and the measurement returned is
        the latest window's."""
        self.lost = None
        if abs(complex(target[0])) >= WIDE_WINDOW_A:
            kwargs["measure_periods"] = max(kwargs.get("measure_periods", 10), WIDE_WINDOW_PERIODS)
            kwargs["max_wait"] = max(kwargs.get("max_wait", 3.0), WIDE_WINDOW_MAX_WAIT)
        if self.scheduled and self.engaged:
            kp, kd, lowpass = scheduled_gains(abs(complex(target[0])))
            if (kp, kd, lowpass) != (self.law.kp, self.law.kd, self.law.lowpass_hz):
                self.law = replace(self.law, kp=kp, kd=kd, lowpass_hz=lowpass)
                self.device.set_loop_gains(kp, kd, lowpass)
        try:
            m = super().hold(target, feedforward, **kwargs)
        except _ForcePeak as exc:
            self.lost = str(exc)
            self._let_go()
            n = round(kwargs.get("measure_periods", 10) * self.rate / self.fe)
            return self.measure(min(n, self.sink.total))
        a = abs(complex(target[0]))
        error = float(abs(m.response[0] - target[0]) / a) if a > 0 else 0.0
        if self.engaged and error > LOST_ERROR:
            self.lost = f"A {abs(m.response[0]) * 1e3:.4g} mm held, {error:.0%} from the target"
            self._let_go()
        return m

    def read(self) -> np.ndarray:
        """One block, as the buffered loop's; while the loop holds a target, a force peak past
        the guard (:data:`LOST_FORCE`) stops the hold (see :meth:`hold`)."""
        block = super().read()
        if self.active and self.engaged and self._force_guard is not None:
            peak = float(np.max(np.abs(block[self.rows["force"]])))
            if peak >= self._force_guard:
                raise _ForcePeak(
                    f"force peak {peak:.3g} N past {LOST_FORCE:.0%} of its abort limit with the loop on"
                )
        return block

    def forget_shape(self) -> None:
        """The loop's target above the CBC's harmonics and its mean set to zero (a target that is
        a pure sine: the orbit without contact, whose harmonics the next measurements supply)."""
        self.upper[:] = 0.0
        self.mean = 0.0

    def orbit_shape(self) -> tuple[np.ndarray, float]:
        """The loop's target above the CBC's harmonics and its mean (the last measured orbit's):
        to go back to with :meth:`restore_shape`."""
        return self.upper.copy(), self.mean

    def restore_shape(self, shape: tuple[np.ndarray, float]) -> None:
        """The loop's target above the CBC's harmonics and its mean as :meth:`orbit_shape` gave
        them (an outer iterate not learnt from: see :func:`rigtools.procedures.cbc.cbc_point`)."""
        self.upper[:] = shape[0]
        self.mean = shape[1]

    def gain_at_fe(self) -> complex:
        """The law's gain at fe (:func:`rigtools.sim.delayed_feedback.loop_gain`, V/m): for the
        slope ``d X1 / d U1 = 1 / K`` of a stiff loop."""
        return loop_gain(
            self.law.kp, self.law.kd, self.law.delay_s, self.law.rate_hz, self.fe, self.law.lowpass_hz
        )

    def _let_go(self) -> None:
        """The loop's output 0 (not engaged), the host's drive as it is."""
        self.set_gains(Gains(0.0))
        self.device.set_loop_target(None)

    # -- measurements ----------------------------------------------------------------------------
    def _loop_rows(self, start: int, n: int) -> tuple[np.ndarray, np.ndarray]:
        """``(total drive, loop's displacement)`` at amplifier samples ``start..start+n``."""
        back = self.device.drive_samples - start  # samples from ``start`` to the latest
        try:
            log = self.device.loop_log_tail(back)[:, :n]
            drive = self.device.drive_log_tail(back)[:n]
        except ValueError as e:
            raise RuntimeError(f"the loop's record: {e}") from None
        if log.shape[1] < n:
            raise RuntimeError(f"the loop's record ends {n - log.shape[1]} samples short of {start + n}")
        return drive + log[0], log[1]

    def measure(self, n: int) -> LoopMeasurement:
        """As the buffered loop's, with ``response`` the loop's own displacement (its clock: the
        target's) and ``drive`` the total drive at the amplifier (host plus loop, in the host's
        drive clock)."""
        m = super().measure(n)
        total, x = self._loop_rows(m.start, m.samples)
        # the loop's sample i holds its value at the step's end (i + 1) / fs; the drive written
        # as sample j reaches the amplifier as sample j + line
        if m.samples not in self._upper_fits:
            self._upper_fits[m.samples] = fit_matrix(m.samples, self.rate, self.fe, ORBIT_HARMONICS)
        coef = x @ self._upper_fits[m.samples]
        k = np.arange(1, ORBIT_HARMONICS + 1)
        xs = (coef[:ORBIT_HARMONICS] - 1j * coef[ORBIT_HARMONICS:]) * np.exp(
            -1j * k * float(self.drive.phase_at(m.start + 1))
        )
        m.response = xs[: self.n_harmonics]
        self.upper = xs[self.n_harmonics :]
        self.mean = float(np.mean(x))  # over whole periods
        m.drive = self.harmonics(total[None, :], m.start - self._line)[0]
        if m.channels is not None:
            m.channels[-1] = m.drive
        return m

    def free_run(self, seconds: float, period_samples: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The target released (the loop's output 0), the host's drive held: the response's
        fundamental per period over ``seconds`` s."""
        self.engaged = False
        self.device.set_loop_target(None)
        return super().free_run(seconds, period_samples)

    # -- stability ---------------------------------------------------------------------------
    def multipliers(self, m: LoopMeasurement) -> tuple[MeasuredMultipliers, dict[str, float]]:
        """Probe and release the converged orbit of ``m`` in short pieces (see the module
        docstring).

        Returns
        -------
        (MeasuredMultipliers, info)
            The pooled fit, and ``release_periods`` (the longest piece), ``releases`` (pieces),
            ``growth`` (the largest growth per period seen in a release, model-free),
            ``error_before``/``error_after`` (the loop's largest error from the orbit over
            16 periods before the first probe and over the last block after
            the measurement, shares of A), ``probe`` (the target's, relative) and
            ``drive_probe`` (the drive's step, relative; 0 where the fit never decayed).
        """
        _, x = self._loop_rows(m.start, m.samples)
        t = (m.start + 1 + np.arange(x.size)) / self.rate
        orbit = HarmonicTarget.fit(t, x, self.fe, ORBIT_HARMONICS)
        amplitude = float(abs(m.response[0]))
        # hold the orbit itself (control zero) with the whole total drive from the host, so that
        # the release plays exactly the drive that held it (its harmonics, below the tolerance,
        # left out would move the rig to a neighbouring orbit: a multiplier of 1 in the fit)
        ff = np.array(m.drive, complex)
        self._ramp = None
        saved = (self.target, self.feedforward)
        self.active = False  # the targets below are scheduled here, not per block
        pieces: list[TransientPiece] = []
        lengths: list[int] = []
        growth, fit, stepped = 1.0, None, False
        try:
            self.drive.set_harmonics(ff)
            self.device.set_loop_target(orbit)
            self.wait(HOLD_PERIODS / self.fe)
            before = self._error(orbit, REFERENCE_PERIODS)
            for _ in range(RELEASES):
                if not stepped and fit is not None and fit.max_modulus < 1.0:
                    stepped = self._drive_times(ff, 1 + DRIVE_PROBE)
                piece, periods, seen = self._release_piece(orbit, amplitude, fit)
                growth = max(growth, seen)
                lengths.append(periods)
                if piece is None:  # growing past the linear range within the periods observed:
                    break  # another piece fits no better and moves the rig off the orbit again
                pieces.append(piece)
                try:
                    fit = _pooled_fit(pieces, self.rate, self.fe)
                except ValueError:
                    fit = None
                decaying = fit is not None and fit.max_modulus < 1.0
                enough = fit is not None and fit.periods[1] >= ENOUGH_PAIRS and not _rejection(fit)
                if enough and (stepped or not decaying):
                    break  # a decaying fit only with a piece probed by the drive among its own
            if stepped:
                self._drive_times(ff, 1.0)
            after = self._settle(orbit, amplitude, before)
        finally:
            self.active = True
            self.set_point(*saved, 0.0)
        info = {
            "release_periods": float(max(lengths)),
            "releases": float(len(lengths)),
            "growth": growth,
            "error_before": before / amplitude,
            "error_after": after / amplitude,
        }
        if fit is None:
            raise ValueError(
                f"{len(lengths)} releases of {'/'.join(map(str, lengths))} periods left too few periods "
                f"in the linear range (deviation within {LINEAR_LIMIT:.0%} of A)"
            )
        why = _rejection(fit)
        if why:
            raise ValueError(f"{len(lengths)} releases of {'/'.join(map(str, lengths))} periods: {why}")
        return fit, {**info, "probe": PROBE, "drive_probe": DRIVE_PROBE if stepped else 0.0}

    def _release_piece(
        self, orbit: HarmonicTarget, amplitude: float, fit: MeasuredMultipliers | None
    ) -> tuple[TransientPiece | None, int, float]:
        """One probe and release of the held ``orbit``: the release begins :data:`OBSERVED`
        periods before the end of a block, the orbit's target re-engaged at that end; from those
        periods the deviation's size and its growth per period (model-free) decide how much
        longer the release runs (:func:`_release_periods`; a previous piece's ``fit`` of the same
        point a floor to the growth), then the loop holds the orbit again :data:`RECAPTURE`
        periods. Returns the differenced deviation over the release with the periods in the
        linear range (``None``: too few), the periods released and the growth seen."""
        p = round(self.rate / self.fe)
        block = self.stream.n
        end = self.sink.total + block
        while end - (OBSERVED + PROBE_PERIODS + 1) * p < self.sink.total:
            end += block
        release = end - OBSERVED * p
        start = release - (PROBE_PERIODS + REFERENCE_PERIODS) * p
        self.device.set_loop_target(_scaled(orbit, 1 + PROBE), at=(release - PROBE_PERIODS * p) / self.rate)
        self.device.set_loop_target(None, at=release / self.rate)
        self.device.set_loop_target(orbit, at=end / self.rate)
        self.wait((end - self.sink.total) / self.rate)
        _, xs = self._loop_rows(start, end - start)
        free = self._free(self._deviation(xs), release - start, OBSERVED, p)
        growth = None if fit is None else fit.max_modulus
        more = _release_periods(free, LINEAR_LIMIT * amplitude, growth) if self.sink.total == end else 0
        if more:  # the target stays released: the re-engagement moves later
            self.device.set_loop_target(None, at=end / self.rate)
            self.device.set_loop_target(orbit, at=(end + more * p) / self.rate)
        periods = OBSERVED + more
        stop = release + periods * p
        self.wait((stop + RECAPTURE * p - self.sink.total) / self.rate)
        _, xs = self._loop_rows(start, stop - start + 1)  # the sample at the re-engagement: still free
        deviation = self._deviation(xs)
        free = self._free(deviation, release - start, periods, p)
        steps = np.abs(np.diff(free, axis=0)).max(axis=1)
        seen = float(np.max(steps[1:] / np.maximum(steps[:-1], 1e-300))) if steps.size > 1 else 1.0
        # the linear range: the periods before the growth since the release passes LINEAR_LIMIT
        # of A (the step a held-drive mismatch leaves is not the transient's)
        over = np.flatnonzero(np.abs(free - free[0]).max(axis=1) > LINEAR_LIMIT * amplitude)
        linear = int(over[0]) if over.size else periods
        turns = float(self.drive.phase_at(release)) / (2 * math.pi)
        piece = _differenced_piece(
            deviation[release - start :], _section_shift(turns, self.rate / self.fe), periods, linear, p
        )
        return piece, periods, seen

    def _drive_times(self, ff: np.ndarray, factor: float) -> bool:
        """The host's drive: ``ff`` with its fundamental times ``factor``, waited for until it
        reaches the amplifier (the loop holds the orbit meanwhile). Returns True."""
        drive = np.array(ff, complex)
        drive[0] *= factor
        self.drive.set_harmonics(drive)
        self.wait(DRIVE_STEP_BLOCKS * self.stream.n / self.rate)
        return True

    def _error(self, orbit: HarmonicTarget, periods: int) -> float:
        """The largest distance of the loop's displacement from ``orbit`` over the last ``periods``."""
        n = periods * round(self.rate / self.fe)
        _, xs = self._loop_rows(self.sink.total - n, n)
        t = (self.sink.total - n + 1 + np.arange(n)) / self.rate
        return float(np.max(np.abs(xs - orbit.evaluate(t)[0])))

    def _settle(self, orbit: HarmonicTarget, amplitude: float, before: float) -> float:
        """Hold ``orbit`` until the loop's error over the last block is within :data:`SETTLED` of
        ``amplitude`` or 1.5 times ``before`` (at most :data:`SETTLE_SECONDS`): the measurement
        leaves the rig where it found it. Returns that error."""
        end = self.sink.total + SETTLE_SECONDS * self.rate
        periods = max(1, self.stream.n // round(self.rate / self.fe))
        error = self._error(orbit, periods)
        while self.sink.total < end and error > max(SETTLED * amplitude, 1.5 * before):
            self.read()
            error = self._error(orbit, periods)
        return error

    def _deviation(self, xs: np.ndarray) -> np.ndarray:
        """``xs`` minus the orbit: the average of its first :data:`REFERENCE_PERIODS` periods."""
        return xs - periodic_reference(
            xs, self.rate, self.fe, 0, REFERENCE_PERIODS * round(self.rate / self.fe)
        )

    @staticmethod
    def _free(deviation: np.ndarray, at: int, periods: int, p: int) -> np.ndarray:
        """``(periods, p)``: the deviation over the ``periods`` released from sample ``at``."""
        return deviation[at : at + periods * p].reshape(periods, p)


class _ForcePeak(RuntimeError):
    """A force peak past the guard while the loop holds a target (caught by ``hold``)."""


def _release_periods(free: np.ndarray, limit: float, growth: float | None = None) -> int:
    """Periods more to release after the observed ones ``free`` (``(periods, samples)``, the
    deviation since the release): its growth since the release kept within ``limit``, the
    period-to-period step growing by :data:`GROWTH_MARGIN` times ``growth`` a period (a fit of
    the same orbit's earlier releases), or where none, times the largest growth of the step the
    release itself shows (model-free), at least :data:`GROWTH_FLOOR`; 0 when the deviation is
    already past a third of the limit; at most :data:`MAX_RELEASE` periods in all."""
    steps = np.abs(np.diff(free, axis=0)).max(axis=1)
    level = float(np.abs(free[-1] - free[0]).max())
    if level >= limit / 3 or steps.size < 2:
        return 0
    if growth is None:
        growth = max(GROWTH_FLOOR, float(np.max(steps[1:] / np.maximum(steps[:-1], 1e-300))))
    grow = GROWTH_MARGIN * growth
    size, step, more = level, float(steps[-1]), 0
    while more + free.shape[0] < MAX_RELEASE:
        step *= grow
        if size + step > limit:
            break
        size += step
        more += 1
    return more


def _section_shift(turns: float, per: float) -> int:
    """Samples from a release at the drive's phase ``turns`` (in turns; ``per`` samples a period)
    to the first instant at the drive's phase 0 at least :data:`SECTION_GUARD` of a period after
    it (the loop's delayed output gone): where the piece's fitted periods begin.

    Every piece of a point then starts at the same phase of the orbit (fe is held), so the
    one-period map fitted to the pooled pairs is the map between sections at one phase. Pieces cut
    at their releases' own phases (a release is placed against the end of a block: 1024 samples,
    not a whole number of periods, 800 at 64 Hz) each follow the map between their own sections,
    the same multipliers in another matrix, which no single matrix fits: at A 0.3843 mm (grid
    0.2995:0.4895 mm) the pooled fit gave 1.703 against the model's 1.494, residual 0.26; the same
    pieces cut at one phase 1.469, residual 0.006."""
    guard = round(SECTION_GUARD * per)
    return guard + round((-(turns + guard / per)) % 1.0 * per)


def _differenced_piece(
    deviation: np.ndarray, shift: int, periods: int, linear: int, p: int
) -> TransientPiece | None:
    """A release's piece of the pooled fit: ``deviation`` (from the orbit, from the release's
    sample on, at least ``periods * p + 1`` samples; ``p`` samples a period) over the ``periods``
    released, the first ``linear`` of them within the linear range, differenced period to period
    from ``shift`` samples after the release (:func:`_section_shift`) on: z[k + 1] - z[k] follows
    the same map as z[k], without the step to a neighbouring orbit that any mismatch of the held
    drive leaves (a multiplier 1). Each pair spans three periods, all within the linear range.
    ``None``: not one pair."""
    last = math.floor(linear - 2 - shift / p)
    if last < 1:
        return None
    d = deviation[shift:]
    step = d[p:] - d[:-p]
    return TransientPiece(step[: (periods - 1) * p - shift + 1], 0, last)


def _pooled_fit(pieces: list[TransientPiece], rate: float, fe: float) -> MeasuredMultipliers:
    """The pooled fit of the releases. Long releases (a stable or weakly unstable orbit: at least
    :data:`LONG_PAIRS` pairs) are fitted at 8 instants a period in every direction above the floor:
    a multiplier near 1 (the fold), weak in the differenced deviation, is kept. Short ones (the
    deviation at the linear limit within a few periods) are fitted on each period's mean and
    harmonics 1-3 in :data:`FIT_RANK` directions: more directions fitted to few pairs, or instants
    at which an impact's shifted instant lands, gave spurious multipliers."""
    fit = pooled_floquet_multipliers(pieces, rate, fe)
    if fit.periods[1] < LONG_PAIRS:
        fit = pooled_floquet_multipliers(pieces, rate, fe, harmonics=FIT_HARMONICS, rank=FIT_RANK)
    return fit


def _rejection(fit: MeasuredMultipliers) -> str:
    """Why a pooled fit is not taken (``""``: it is): its one-period map's relative residual above
    :data:`RESIDUAL_LIMIT`, i.e. the pooled pairs follow no one linear map of a period."""
    if fit.residual > RESIDUAL_LIMIT:
        return (
            f"the pooled fit's residual {fit.residual:.2g} is above {RESIDUAL_LIMIT:g}: its pairs of "
            f"periods follow no one linear map (its largest multiplier {fit.max_modulus:.3g} not taken)"
        )
    return ""


def _scaled(target: HarmonicTarget, factor: float) -> HarmonicTarget:
    return HarmonicTarget(
        target.fe_hz,
        tuple(factor * c for c in target.cos),
        tuple(factor * s for s in target.sin),
        target.mean,
    )


__all__ = ["REALTIME_GAINS", "RealTimeHarmonicLoop", "scheduled_gains"]
