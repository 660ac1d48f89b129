"""A simulated rig behind the :class:`rigtools.drivers.contracts.AcquisitionDevice` contract.

What happens to each block of drive samples (volts, as written by the procedure):

1. a DAQ delay line of whole samples (with the half sample of step 4, nearest to the test
   article's ``input_to_output_delay``);
2. the voltage amplifier (gain ``G``) puts ``G * drive`` across the shaker coil;
3. the physics: the electrodynamic shaker (coil ``R``, ``L``, force factor ``Bl``, armature mass
   on its suspension) rigidly coupled through the force sensor to the active blade, and the
   vibro-impact FE model of both blades of the *test article*, integrated with its state carried
   from block to block. Near a resonance of the blade the back-EMF and the armature take up the
   coil's force, so the sensor force dips as on a real rig;
4. the DAQ's anti-alias filter, modelled as an integrating sampler: each sample is the mean of
   the signal over its sample interval (:func:`rigtools.sim.rig_physics.interval_means`), not its value at an instant.
   The contact makes the accelerations jump at every impact; point samples would fold that
   broadband content down between the harmonics. The boxcar adds half a sample of group delay
   on every channel; :meth:`SimulatedRig.input_to_output_delay` reports the delay line plus
   that half sample;
5. each input channel's measurement chain (:mod:`rigtools.drivers.sensor_chain`): sensitivity, sensor and
   ADC noise, IEPE high-pass, 24-bit quantisation over the channel range; the reading is scaled
   back to SI units as DAQmx does.

The *test article* (:class:`rigtools.drivers.test_article.TestArticle`) is not the nominal
model: a bolted root (springs instead of the clamp, so the flexural frequencies come out 1-3 %
low), its own damping ratio, small mass deviations of the shroud and the force sensor, all set in
the rig file's ``[test_article]`` section.

Physics backends (``model=``), in :mod:`rigtools.sim.rig_physics` (this module is the device
around them: delay line, amplifier, channels, noise, faults, timing, the hammer's schedule):

``"vibro-impact"``
    :class:`rigtools.sim.rig_physics.VibroImpactPhysics`, the stepper on a reduced model of the
    test article, with the shroud contact and the shaker coupling (the default).
``"linear"``
    :class:`rigtools.sim.rig_physics.LinearModalPhysics`: exact discrete-time propagation (zero-order hold) of the active
    blade's modes coupled to the shaker, without contact (the passive blade stays at rest). Used
    to cross-check the vibro-impact path with impacts off.

It runs as fast as it can by default; ``pace=True`` sleeps so that blocks arrive in wall-clock
time like a real device's. Faults can be injected (:class:`Fault`); on a fault, on
:meth:`~SimulatedRig.stop` and on :meth:`~SimulatedRig.close` the drive that reaches the
amplifier is ramped to zero over ``abort_ramp_time`` (<= 0.1 s) with the physics still running,
then the device stops; :attr:`SimulatedRig.drive_log` holds every drive sample the amplifier got.
"""

from __future__ import annotations

import math
import re
import time
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from rigtools.drivers.contracts import (
    AcquisitionDevice,
    AmplifierTimeout,
    ConfigurationError,
    DaqFault,
    DeviceInfo,
    InputChannelSpec,
    InputOverflow,
    InvalidSamples,
    LimitExceeded,
    OutputChannelSpec,
    OutputUnderflow,
    SensorOverload,
    SimulationDiverged,
)
from rigtools.drivers.drive_signals import raised_cosine
from rigtools.drivers.errors import one_line
from rigtools.drivers.realtime import HarmonicTarget, RealTimeLoop
from rigtools.drivers.realtime_pll import PllCommand, RealTimePll
from rigtools.drivers.safety import MAX_TIME_TO_ZERO, output_queue_limit
from rigtools.drivers.sample_log import SampleLog
from rigtools.drivers.sensor_chain import SensorChain, SensorModel
from rigtools.drivers.shaker import ShakerParams
from rigtools.drivers.test_article import TestArticle
from rigtools.sim.delayed_feedback import DelayedFeedback
from rigtools.sim.params import RigParams, SimulationInputError
from rigtools.sim.realtime_pll import PllFeedback
from rigtools.sim.rig_model import RigModel, build_rig_model
from rigtools.sim.rig_physics import SIGNAL_INDEX, SIGNALS, LinearModalPhysics, VibroImpactPhysics

__all__ = [
    "FAULT_KINDS",
    "SIGNALS",
    "Fault",
    "SimulatedHammer",
    "SimulatedRig",
    "TestArticle",
    "default_signal",
]


# ------------------------------------------------------------------------------------ faults

_FAULTS: dict[str, type[DaqFault]] = {
    "input_overflow": InputOverflow,
    "amplifier_timeout": AmplifierTimeout,
    "sensor_overload": SensorOverload,
    "nan_samples": InvalidSamples,
}
FAULT_KINDS = tuple(_FAULTS)
FAULT_TEXT = re.compile(r"\s*([\w-]+)\s*@\s*([0-9.eE+-]+)\s*(s|ms|us|µs)?\s*(?::\s*([\w.-]+))?\s*")
_TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6}


@dataclass(frozen=True)
class Fault:
    """A fault to inject, in the middle of block ``at_block`` (0-based) or at time ``at_time`` (s).

    ``kind`` is one of :data:`FAULT_KINDS`; ``channel`` names the input that overloads or turns to
    NaN (default: the first input).
    """

    kind: str
    at_block: int | None = None
    at_time: float | None = None
    channel: str | None = None

    def __post_init__(self) -> None:
        kind = self.kind.replace("-", "_").lower()
        if kind not in _FAULTS:
            known = ", ".join(k.replace("_", "-") for k in FAULT_KINDS)
            raise ConfigurationError(f"unknown kind {self.kind!r} of fault (known: {known})")
        object.__setattr__(self, "kind", kind)
        if (self.at_block is None) == (self.at_time is None):
            raise ConfigurationError(f"fault {kind}: give exactly one of at_block or at_time")
        if (self.at_block is not None and self.at_block < 0) or (
            self.at_time is not None and self.at_time < 0
        ):
            raise ConfigurationError(f"fault {kind}: the time must be >= 0 s")

    @classmethod
    def parse(cls, text: str) -> Fault:
        """The one text form of a fault: ``"KIND@TIME[:CHANNEL]"``, TIME from the start of the run
        in seconds (a plain number) or with a unit ``s``, ``ms`` or ``us``; ``"@3"`` is 3 s, never
        a block (a block is given only as ``Fault(kind, at_block=N)``). E.g. ``"input-overflow@1.5"``,
        ``"nan-samples@250 ms:force"``.

        Raises
        ------
        ConfigurationError
            One line: the form not read, an unknown kind, a negative time.
        """
        match = FAULT_TEXT.fullmatch(text)
        if not match:
            raise ConfigurationError(
                f"cannot read fault {text!r}: write KIND@TIME[:CHANNEL], e.g. 'input-overflow@1.5:force'"
            )
        kind, at, unit, channel = match.groups()
        try:
            seconds = float(at) * _TIME_UNITS[unit or "s"]
        except ValueError:
            raise ConfigurationError(f"cannot read fault {text!r}: {at!r} is not a time") from None
        return cls(kind, at_time=seconds, channel=channel)

    def sample(self, block_size: int, sample_rate: float) -> int:
        """Index of the first sample the fault spoils."""
        if self.at_block is not None:
            return self.at_block * block_size + block_size // 2
        assert self.at_time is not None  # __post_init__: exactly one of the two is given
        return round(self.at_time * sample_rate)


# ------------------------------------------------------------------------------------ hammer


@dataclass(frozen=True)
class SimulatedHammer:
    """An operator hitting a blade with an impact hammer, at regular intervals (SI).

    Each hit is a half-sine force pulse ``F(t) = peak * sin(pi t / duration)`` normal to the
    blade (y) at ``position`` (m from the root) of ``blade``; hit ``i`` starts at
    ``first + i * interval`` with its peak scattered by ``scatter`` (relative, uniform, seeded)
    as a hand-held hammer's would be. ``hits`` hits in all (``None``: as long as the run lasts).
    """

    blade: str = "passive"
    position: float = 0.085
    peak: float = 20.0
    duration: float = 5e-4
    interval: float = 2.5
    first: float = 0.3
    scatter: float = 0.1
    hits: int | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        if self.blade not in ("active", "passive"):
            raise ConfigurationError(f"hammer blade {self.blade!r}: use active or passive")
        for name in ("position", "peak", "duration", "interval", "first"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0) or (name != "first" and v == 0):
                raise ConfigurationError(f"hammer {name} = {v!r} must be > 0")
        if self.duration >= self.interval:
            raise ConfigurationError("hammer: the pulse must be shorter than the interval between hits")

    def _peak(self, i: int) -> float:
        u = np.random.default_rng([self.seed, i]).uniform(-1.0, 1.0)
        return self.peak * (1.0 + self.scatter * u)

    def impulses(self, k0: int, n: int, dt: float) -> np.ndarray:
        """Impulse of the hammer force over each sample interval ``[k dt, (k + 1) dt)``,
        ``k = k0 .. k0 + n - 1``, N*s (exact integrals of the half-sines)."""
        out = np.zeros(n)
        t0, t1 = k0 * dt, (k0 + n) * dt
        i_lo = max(0, math.floor((t0 - self.first - self.duration) / self.interval))
        i_hi = math.floor((t1 - self.first) / self.interval)
        if self.hits is not None:
            i_hi = min(i_hi, self.hits - 1)
        w = math.pi / self.duration
        for i in range(i_lo, i_hi + 1):
            ts = self.first + i * self.interval
            a = max(k0, math.floor(ts / dt))
            b = min(k0 + n, math.ceil((ts + self.duration) / dt))
            if b <= a:
                continue
            edges = np.clip(np.arange(a, b + 1) * dt - ts, 0.0, self.duration)
            # int F dt = peak / w * (cos(w s0) - cos(w s1))
            out[a - k0 : b - k0] += self._peak(i) / w * -np.diff(np.cos(w * edges))
        return out


# ------------------------------------------------------------------------------ the device


def default_signal(spec: InputChannelSpec) -> str:
    """Which physical signal an input measures, from its kind and name.

    force -> ``force`` (``hammer_force`` if the name says hammer); voltage -> ``coil_voltage`` (amplifier monitor); accel -> ``passive_tip_accel``
    if the name says passive, ``force_point_accel`` if it says force/drive point, else
    ``active_tip_accel``.
    """
    name = spec.name.lower()
    if spec.kind == "force":
        return "hammer_force" if "hammer" in name else "force"
    if spec.kind == "voltage":
        return "coil_current" if "current" in name else "coil_voltage"
    if "passive" in name:
        return "passive_tip_accel"
    if "point" in name or "sensor" in name or "drive" in name:
        return "force_point_accel"
    return "active_tip_accel"


class _Session(NamedTuple):
    """What :meth:`SimulatedRig.configure` set up, for the streaming calls."""

    chain: SensorChain
    output: OutputChannelSpec
    physics: LinearModalPhysics | VibroImpactPhysics


class SimulatedRig(AcquisitionDevice):
    """The rig simulated by the FE model, behind the acquisition-device contract.

    Parameters
    ----------
    params
        The *nominal* rig (:class:`rigtools.sim.params.RigParams`); the simulated test article is
        ``test_article.apply(params)``.
    shaker
        Amplifier and shaker.
    test_article
        Deviations of the test article and its measurement chain.
    model
        ``"vibro-impact"``, ``"linear"`` or ``"auto"`` (vibro-impact when available).
    pace
        Sleep so that blocks arrive in wall-clock time.
    faults
        Faults to inject (:class:`Fault` or their text form, see :meth:`Fault.parse`).
    abort_ramp_time
        Ramp of the drive to zero on stop, close and faults, s (<= 0.1).
    signal_map
        Input channel name -> one of :data:`SIGNALS`, overriding :func:`default_signal`.
    seed
        Noise seed (``None``: the operating system's entropy, another draw every run;
        :func:`rigtools.procedures.rig.open_device` gives 0).
    keep_truth
        Keep the physical signals of every block (interval means as the sampler sees them,
        before the sensors) in :attr:`truth_log` (grows with the run: tests only).
    drive_log_seconds
        How much of the amplifier's drive :attr:`drive_log` keeps (the latest), s.
    max_time_to_zero
        The output queue is bounded as on the NI backend
        (:func:`rigtools.drivers.safety.output_queue_limit`): at most this long from a stop or fault to
        0 V, the queued drive playing out first; writes beyond it are refused. ``None``: no
        bound (block-size studies).
    """

    backend = "simulated"
    has_realtime_loop = True  # emulated inside the integrator: set_realtime_loop, set_loop_target

    def __init__(
        self,
        params: RigParams,
        shaker: ShakerParams | None = None,
        test_article: TestArticle | None = None,
        *,
        model: str = "auto",
        pace: bool = False,
        faults: Sequence[Fault | str] = (),
        abort_ramp_time: float = 0.05,
        signal_map: dict[str, str] | None = None,
        seed: int | None = None,
        keep_truth: bool = False,
        drive_log_seconds: float = 60.0,
        max_time_to_zero: float | None = MAX_TIME_TO_ZERO,
        hammer: SimulatedHammer | None = None,
    ) -> None:
        if not 0 < abort_ramp_time <= 0.1:
            raise ConfigurationError(f"abort_ramp_time = {abort_ramp_time} s must be in (0, 0.1]")
        if model not in ("auto", "vibro-impact", "linear"):
            raise ConfigurationError(f"model {model!r} is not one of auto, vibro-impact, linear")
        if model == "auto":
            model = "vibro-impact"
        self.nominal = params
        self.shaker = shaker or ShakerParams()
        self.test_article = test_article or TestArticle()
        self.article_params = self.test_article.apply(params)
        self.model_kind = model
        self.pace = pace
        self.faults = tuple(f if isinstance(f, Fault) else Fault.parse(f) for f in faults)
        self.abort_ramp_time = abort_ramp_time
        self.signal_map = dict(signal_map or {})
        self.seed = seed
        self.keep_truth = keep_truth
        self.drive_log_seconds = float(drive_log_seconds)
        self.max_time_to_zero = max_time_to_zero
        self.hammer = hammer
        self._queue_limit: int | None = None
        self._rig_model: RigModel | None = None
        self._physics: LinearModalPhysics | VibroImpactPhysics | None = None
        self._physics_dt: float | None = None
        self._inputs: tuple[InputChannelSpec, ...] = ()
        self._output: OutputChannelSpec | None = None
        self._rate = 0.0
        self._block = 0
        self._running = False
        self._closed = False
        self._queue: deque[np.ndarray] = deque()
        self._queued = 0
        self._written = 0
        self._delay_line = np.zeros(0)
        self._last_drive = 0.0
        self._read_samples = 0
        self._blocks_read = 0
        self._wall0 = 0.0
        self._chain: SensorChain | None = None
        self._rows = np.zeros(0, dtype=int)
        self._drive_log = SampleLog()
        self.realtime_loop: RealTimeLoop | RealTimePll | None = None
        self._feedback: DelayedFeedback | PllFeedback | None = None
        self._loop_log = SampleLog((2,))
        self.drive_samples = 0  # drive samples that reached the amplifier since configure
        self.truth_log: list[np.ndarray] = []
        self.fault_sample: int | None = None

    @classmethod
    def from_config(cls, config, **kwargs) -> SimulatedRig:
        """From a validated rig file (:class:`rigtools.config.RigConfig`, duck-typed)."""
        kwargs.setdefault("abort_ramp_time", config.safety.abort_ramp_time)
        return cls(config.to_params(), config.shaker.to_params(), config.test_article.to_params(), **kwargs)

    # ------------------------------------------------------------------ configuration

    def rig_model(self) -> RigModel:
        """FE model (:class:`rigtools.sim.rig_model.RigModel`) of the test article (built once)."""
        if self._rig_model is None:
            self._rig_model = build_rig_model(self.article_params)
        return self._rig_model

    def configure(
        self,
        inputs: Sequence[InputChannelSpec],
        output: OutputChannelSpec,
        sample_rate: float,
        block_size: int | None = None,
    ) -> float:
        if self._running:
            raise ConfigurationError("stop the device before configuring it again")
        if not (sample_rate > 0 and math.isfinite(sample_rate)):
            raise ConfigurationError(f"sample rate {sample_rate!r} S/s must be > 0")
        if not inputs:
            raise ConfigurationError("configure at least one input channel")
        names = [s.name for s in inputs]
        if len(set(names)) != len(names):
            raise ConfigurationError(f"duplicate input channel names in {names}")
        rows = []
        for spec in inputs:
            sig = self.signal_map.get(spec.name, default_signal(spec))
            if sig not in SIGNAL_INDEX:
                raise ConfigurationError(
                    f"channel {spec.name!r}: signal {sig!r} unknown (known: {', '.join(SIGNALS)})"
                )
            rows.append(SIGNAL_INDEX[sig])
        for fault in self.faults:
            if fault.channel is not None and fault.channel not in names:
                raise ConfigurationError(f"fault {fault.kind}: no input channel {fault.channel!r}")
        self._inputs, self._output, self._rows = tuple(inputs), output, np.array(rows)
        self._rate = float(sample_rate)
        self._block = int(block_size) if block_size else max(1, round(0.1 * self._rate))
        ta = self.test_article
        noise = {"force": ta.force_noise, "accel": ta.accel_noise, "voltage": 0.0}
        sensors = [
            SensorModel(
                volts_per_unit=s.volts_per_unit,
                full_scale_volts=max(abs(s.min_value), abs(s.max_value)) * s.volts_per_unit,
                noise_rms=noise[s.kind],
                adc_noise_rms=ta.adc_noise,
                highpass_hz=ta.iepe_highpass if s.iepe else 0.0,
            )
            for s in inputs
        ]
        self._chain = SensorChain(sensors, self._rate, seed=self.seed)
        dt = 1.0 / self._rate
        if self._physics is None or self._physics_dt != dt:
            coupling = self.shaker.coupling()
            if self.model_kind == "linear":
                self._physics = LinearModalPhysics(self.rig_model(), coupling, dt)
            else:
                try:
                    self._physics = VibroImpactPhysics(self.rig_model(), coupling, dt)
                except SimulationInputError as exc:
                    raise ConfigurationError(f"sample rate {self._rate:g} S/s: {exc}") from None
            self._physics_dt = dt
        self._apply_hammer(self._physics)
        self._feedback = self._make_feedback()
        self._queue_limit = (
            None
            if self.max_time_to_zero is None
            else output_queue_limit(self._rate, self.abort_ramp_time, self.max_time_to_zero)
        )
        self._reset_stream()
        return self._rate

    def set_hammer(self, hammer: SimulatedHammer | None) -> None:
        """An operator with an impact hammer (:class:`SimulatedHammer`; ``None``: none). Its
        hits are timed from the start of the stream; a ``hammer`` force input records them."""
        self.hammer = hammer
        if self._physics is not None:
            self._apply_hammer(self._physics)

    def _apply_hammer(self, physics: LinearModalPhysics | VibroImpactPhysics) -> None:
        if not isinstance(physics, VibroImpactPhysics):
            if self.hammer is not None:
                raise ConfigurationError(
                    "the linear model holds the active blade alone: an impact "
                    "hammer needs the vibro-impact model"
                )
            return
        hammer = self.hammer
        try:
            physics.set_hit_point(
                None if hammer is None else hammer.blade, 0.0 if hammer is None else hammer.position
            )
        except SimulationInputError as exc:
            raise ConfigurationError(str(exc)) from None

    @property
    def output_queue_limit(self) -> int | None:
        """Most drive samples queued ahead of the inputs (see ``max_time_to_zero``)."""
        return self._queue_limit

    def _reset_stream(self) -> None:
        if self._physics is not None:
            self._physics.reset()
        if self._chain is not None:
            self._chain.reset()
        self._queue.clear()
        self._queued = self._written = self._read_samples = self._blocks_read = 0
        # the sampler adds half a sample: the whole-sample line that brings the sum nearest
        line = round(self.test_article.input_to_output_delay * self._rate - 0.5)
        self._delay_line = np.zeros(max(0, int(line)))
        self._last_drive = 0.0
        self._drive_log, self.truth_log = SampleLog(), []
        self.drive_samples = 0
        self._loop_log = SampleLog((2,))
        if self._feedback is not None:
            self._feedback.reset()
            if isinstance(self.realtime_loop, RealTimeLoop):
                self._feedback.set_target(self.realtime_loop.target, 0.0)
        self.fault_sample = None
        self._closed = False

    def _require_configured(self) -> _Session:
        """What :meth:`configure` set up; raises if it has not succeeded."""
        if self._chain is None or self._output is None or self._physics is None:
            raise ConfigurationError("device not configured; call configure() first")
        return _Session(self._chain, self._output, self._physics)

    def input_to_output_delay(self) -> float:
        """The simulated DAQ's delay line (whole samples) plus the integrating sampler's half
        sample of group delay, s."""
        return (self._delay_line.size + 0.5) / self._rate if self._rate else 0.0

    def info(self) -> DeviceInfo:
        details = {
            "model": self.model_kind,
            "pace": str(self.pace),
            "seed": str(self.seed),  # the noise draw: "None" is the operating system's entropy
            "test_article": repr(self.test_article),
            "shaker": repr(self.shaker),
        }
        return DeviceInfo(
            self.backend, self._rate, self._rate, self._block, self.input_to_output_delay(), details
        )

    @property
    def drive_log(self) -> np.ndarray:
        """The drive samples that reached the amplifier (after the delay line), V, including the
        ramp to zero after a stop or a fault: the last :attr:`drive_log_seconds` of them (memory
        stays bounded over long runs; sample 0 of the array is amplifier sample
        ``drive_samples - drive_log.size``)."""
        return self._drive_log.array()

    @property
    def loop_log(self) -> np.ndarray:
        """The real-time loop's record, ``(2, n)``, one column per amplifier sample (aligned with
        :attr:`drive_log`, the same length kept; column ``i`` of a stream is the step ending at
        ``(i + 1) / sample_rate``): row 0 its output ``u`` (V at the amplifier's
        input), row 1 the active shroud's displacement at the sample's end (m, the quantity the
        loop measures, noise-free). Empty without a loop."""
        return self._loop_log.array()

    def drive_log_tail(self, samples: int) -> np.ndarray:
        """The latest ``samples`` of :attr:`drive_log` (the rest not copied: a loop reads its
        record after every block).

        Raises
        ------
        ValueError
            More samples asked for than the log holds.
        """
        return self._drive_log.tail(samples)

    def loop_log_tail(self, samples: int) -> np.ndarray:
        """The latest ``samples`` columns of :attr:`loop_log` (as :meth:`drive_log_tail`)."""
        return self._loop_log.tail(samples)

    # ------------------------------------------------------------------ real-time loop

    def set_realtime_loop(self, loop: RealTimeLoop | RealTimePll | None) -> None:
        """Run ``loop`` (:class:`rigtools.drivers.realtime.RealTimeLoop`, or the phase-locked
        loop :class:`rigtools.drivers.realtime_pll.RealTimePll`) per sample inside the
        integration from the next configure or stream start (``None``: no loop). Its target
        starts as ``loop.target``; :meth:`set_loop_target` changes it between blocks (a PLL:
        :meth:`set_pll_command`).

        Raises
        ------
        ConfigurationError
            The linear model (no loop there), or a loop the integration cannot run (one line).
        """
        if loop is not None and self.model_kind != "vibro-impact":
            raise ConfigurationError("the real-time loop runs in the vibro-impact model only")
        if self._running:
            raise ConfigurationError("stop the device before changing its real-time loop")
        self.realtime_loop = loop
        self._feedback = self._make_feedback()
        if self._feedback is not None and isinstance(loop, RealTimeLoop):
            self._feedback.set_target(loop.target, self._feedback.time)

    def set_loop_target(self, target: HarmonicTarget | None, at: float | None = None) -> None:
        """The loop follows ``target`` for the measurement instants from now on (the samples
        read so far; its output changes a loop delay later); ``None``: output 0 from then.
        ``at`` (s on the loop's clock, not before now): from that instant instead, as a real-time
        target takes a change time-stamped (a probe of a few periods inside one block); changes
        scheduled at or after it are dropped.

        Raises
        ------
        ConfigurationError
            No real-time loop set, or the device not configured.
        """
        if self._feedback is None:
            raise ConfigurationError("no real-time loop: call set_realtime_loop() (and configure) first")
        if at is not None and at < self._feedback.time - 0.5 / self._rate:
            raise ConfigurationError(
                f"loop target at {at:g} s: the loop is already at {self._feedback.time:g} s"
            )
        self._feedback.set_target(target, at)

    def set_loop_gains(self, kp: float, kd: float, lowpass_hz: float | None = None) -> None:
        """New gains of the running real-time loop (V/m, V s/m) and its output low-pass (Hz,
        ``None``: none; :class:`~rigtools.drivers.realtime.RealTimeLoop`) from the next sample
        on, its rate, delay and target kept: as a real-time target takes new gains between
        blocks (a gain schedule along a continuation).

        Raises
        ------
        ConfigurationError
            No real-time loop (:class:`~rigtools.drivers.realtime.RealTimeLoop`) set, or gains not
            finite (one line).
        """
        loop = self.realtime_loop
        if not isinstance(self._feedback, DelayedFeedback) or not isinstance(loop, RealTimeLoop):
            raise ConfigurationError("no real-time loop: call set_realtime_loop() (and configure) first")
        self.realtime_loop = replace(loop, kp=float(kp), kd=float(kd), lowpass_hz=lowpass_hz)  # validates
        self._feedback.kp, self._feedback.kd = float(kp), float(kd)
        self._feedback.set_lowpass(lowpass_hz)

    def set_pll_command(self, command: PllCommand) -> None:
        """The real-time PLL follows ``command`` (phase target, amplitude) from its next tick.

        Raises
        ------
        ConfigurationError
            No real-time PLL set (:meth:`set_realtime_loop`), or the device not configured.
        """
        if not isinstance(self._feedback, PllFeedback):
            raise ConfigurationError("no real-time PLL: call set_realtime_loop(RealTimePll(...)) first")
        self._feedback.set_command(command)

    def pll_oscillator(self, first: int, n: int) -> np.ndarray:
        """The real-time PLL's up-link: ``(3, n)`` its oscillator's phase (rad, unwrapped) and
        frequency (Hz) at the ends of amplifier samples ``first .. first + n - 1`` (the input
        samples of the same indices), and its own phase estimate (deg)."""
        if not isinstance(self._feedback, PllFeedback):
            raise ConfigurationError("no real-time PLL: call set_realtime_loop(RealTimePll(...)) first")
        try:
            return self._feedback.oscillator(first, n)
        except SimulationInputError as exc:
            raise ConfigurationError(str(exc)) from None

    def _make_feedback(self) -> DelayedFeedback | PllFeedback | None:
        loop = self.realtime_loop
        if loop is None or self._rate <= 0:
            return None
        if isinstance(loop, RealTimePll):
            return self._make_pll(loop)
        try:
            return DelayedFeedback(
                loop.rate_hz,
                loop.delay_s,
                loop.kp,
                loop.kd,
                self.shaker.amplifier_gain,
                1.0 / self._rate,
                loop.lowpass_hz,
            )
        except SimulationInputError as exc:
            raise ConfigurationError(str(exc)) from None

    def _make_pll(self, loop: RealTimePll) -> PllFeedback:
        try:
            return PllFeedback(
                loop.rate_hz,
                loop.delay_s,
                loop.kp,
                loop.ki,
                loop.f_start,
                loop.f_min,
                loop.f_max,
                loop.min_force,
                self.shaker.amplifier_gain,
                1.0 / self._rate,
            )
        except SimulationInputError as exc:
            raise ConfigurationError(str(exc)) from None

    @property
    def gap(self) -> float:
        """The test article's shroud gap in use, m (set by hand on the real rig)."""
        if isinstance(self._physics, VibroImpactPhysics):
            return self._physics.gap
        return self.article_params.contact.gap

    def set_gap(self, gap: float) -> None:
        """Set the shroud gap directly, m (on the real rig the operator sets it by hand).

        The running state carries on: what a very slow hand adjustment would do. The linear
        model has no contact and ignores it.
        """
        if not (math.isfinite(gap) and gap >= 0):
            raise ConfigurationError(f"gap {gap!r} m must be >= 0")
        if isinstance(self._physics, VibroImpactPhysics):
            self._physics.set_gap(gap)
        self.article_params = replace(
            self.article_params, contact=replace(self.article_params.contact, gap=float(gap))
        )
        self._rig_model = None  # built again with this gap when next needed (a new sample rate)

    @property
    def samples_read(self) -> int:
        """Samples per channel returned by :meth:`read` so far."""
        return self._read_samples

    # ------------------------------------------------------------------ streaming

    def write(self, drive: np.ndarray) -> None:
        session = self._require_configured()
        data = np.array(drive, dtype=np.float64, copy=True)
        if data.ndim != 1 or data.size == 0:
            raise LimitExceeded(f"drive block must be 1-D and non-empty, got shape {data.shape}")
        d_min, d_max = float(data.min()), float(data.max())  # NaN or inf shows in these
        if not (math.isfinite(d_min) and math.isfinite(d_max)):
            raise LimitExceeded("drive block holds NaN or inf; nothing written")
        low, high = session.output.min_voltage, session.output.max_voltage
        if d_min < low or d_max > high:
            raise LimitExceeded(
                f"drive {d_min:.4g}..{d_max:.4g} V is outside the output "
                f"range {low}..{high} V; nothing written"
            )
        if self._queue_limit is not None and self._queued + data.size > self._queue_limit:
            raise LimitExceeded(
                f"{self._queued + data.size} drive samples would be queued ahead of the inputs, "
                f"above the output queue limit {self._queue_limit} "
                f"({self._queue_limit / self._rate * 1e3:.0f} ms; write smaller blocks)"
            )
        self._queue.append(data)
        self._queued += data.size
        self._written += data.size

    def start(self) -> None:
        self._require_configured()
        if self._running:
            return
        if self._written == 0:
            raise ConfigurationError("write at least one drive block before start()")
        self._running = True
        self._wall0 = time.perf_counter()

    def _take(self, n: int) -> np.ndarray:
        """The next ``n`` queued drive samples (held at the last value if the queue runs dry)."""
        out = np.empty(n)
        i = 0
        while i < n and self._queue:
            head = self._queue[0]
            m = min(n - i, head.size)
            out[i : i + m] = head[:m]
            if m == head.size:
                self._queue.popleft()
            else:
                self._queue[0] = head[m:]
            i += m
        self._queued -= i
        if i < n:
            out[i:] = out[i - 1] if i else self._last_drive
        return out

    def _advance(
        self,
        physics: LinearModalPhysics | VibroImpactPhysics,
        drive: np.ndarray,
        loop_envelope: np.ndarray | None = None,
    ) -> np.ndarray:
        """Run the drive through delay line, amplifier and physics (with the real-time loop's
        output added at the amplifier's input, scaled by ``loop_envelope``); physical signals out."""
        d = self._delay_line.size
        if d:
            joined = np.concatenate([self._delay_line, drive])
            applied, self._delay_line = joined[: drive.size], joined[drive.size :]
        else:
            applied = drive
        keep = int(self.drive_log_seconds * self._rate)
        self._drive_log.append(applied, keep)
        self.drive_samples += applied.size
        if drive.size:
            self._last_drive = float(drive[-1])
        coil = self.shaker.amplifier_gain * applied
        if not isinstance(physics, VibroImpactPhysics):
            return physics.step(coil)
        k0 = self.drive_samples - applied.size  # amplifier samples since the stream began
        impulses = None if self.hammer is None else self.hammer.impulses(k0, applied.size, 1.0 / self._rate)
        if self._feedback is None:
            return physics.step(coil, impulses)
        signals, u, x = self._feedback.step(physics, coil, impulses, loop_envelope)
        self._loop_log.append(np.vstack([u, x]), keep)
        return signals

    def read(self, n_samples: int | None = None, timeout: float = 10.0) -> np.ndarray:
        session = self._require_configured()
        chain = session.chain
        if not self._running:
            raise ConfigurationError("device not started; call start() first")
        n = int(n_samples or self._block)
        if self._queued < n:
            self._fail(
                OutputUnderflow(
                    f"drive ran out after {self._read_samples + self._queued} samples "
                    f"({n - self._queued} missing): write one block ahead"
                ),
                m=self._queued,
            )
        k0 = self._read_samples
        fault = self._due_fault(k0, n)
        m = n if fault is None else fault[1]
        try:
            physical = self._advance(session.physics, self._take(m))[self._rows]
        except SimulationInputError as exc:  # SimulationDivergedError: the state is lost
            session.physics.reset()
            self._fail(
                SimulationDiverged(f"at t = {k0 / self._rate:.4f} s: {one_line(exc, None)}"),
                m=0,
                k0=k0,
            )
        if m < n:  # a fault cuts the block: pad so the noise stream matches an undisturbed run
            padded = np.zeros((physical.shape[0], n))
            padded[:, :m] = physical
            data = chain.to_volts(padded)[:, :m]
        else:
            data = chain.to_volts(physical)
        first = chain.first_overload
        if first >= 0:
            names = [s.name for s, o in zip(self._inputs, chain.overloaded, strict=True) if o]
            self._fail(
                SensorOverload(
                    f"{', '.join(names)} beyond its range at t = {(k0 + first) / self._rate:.4f} s",
                    partial=chain.to_units(data[:, :first]),
                ),
                m=first,
                k0=k0,
            )
        values = chain.to_units(data)
        if self.keep_truth:
            self.truth_log.append(physical)
        if fault is not None:
            self._inject(fault[0], values, k0, m)
        self._read_samples += n
        self._blocks_read += 1
        if self.pace:
            lag = self._wall0 + self._read_samples / self._rate - time.perf_counter()
            if lag > 0:
                time.sleep(lag)
        return values

    def _due_fault(self, k0: int, n: int) -> tuple[Fault, int] | None:
        for fault in self.faults:
            k = fault.sample(self._block, self._rate)
            if k0 <= k < k0 + n:
                return fault, k - k0
        return None

    def _inject(self, fault: Fault, before: np.ndarray, k0: int, m: int) -> None:
        t = (k0 + m) / self._rate
        channel = fault.channel or self._inputs[0].name
        cls = _FAULTS[fault.kind]
        text = {
            "input_overflow": f"injected at t = {t:.4f} s (block {self._blocks_read}): the host did not read in time",
            "amplifier_timeout": f"injected at t = {t:.4f} s (block {self._blocks_read}): the amplifier stopped answering",
            "sensor_overload": f"injected on {channel} at t = {t:.4f} s (block {self._blocks_read}): beyond its range",
            "nan_samples": f"NaN samples on {channel} at t = {t:.4f} s (block {self._blocks_read}, injected)",
        }[fault.kind]
        self._fail(cls(text, partial=before), m=m, k0=k0)

    def _fail(self, fault: DaqFault, m: int = 0, k0: int | None = None) -> None:
        """Ramp the drive to zero, stop, raise ``fault``."""
        self.fault_sample = (self._read_samples if k0 is None else k0) + m
        self.stop()
        raise fault

    def _ramp_down(self) -> None:
        """Bring the drive to zero as the NI backend does, with the physics running.

        A non-regenerating output cannot take back what is queued: the queued drive plays out,
        then a raised-cosine ramp from its last sample to exactly 0 V over ``abort_ramp_time``,
        then zeros for the delay line to drain. The queue bound keeps the sum within
        ``max_time_to_zero``.
        """
        if self._physics is None:  # never configured: no drive has reached the amplifier
            return
        queued = self._take(self._queued)
        last = float(queued[-1]) if queued.size else self._last_drive
        r = max(1, math.floor(self.abort_ramp_time * self._rate + 1e-9))
        ramp = last * (1.0 - raised_cosine(r))
        ramp[-1] = 0.0
        tail = np.zeros(self._delay_line.size)
        # the real-time loop's output ramps down with the drive reaching the amplifier
        envelope = np.concatenate([np.ones(self._delay_line.size + queued.size), 1.0 - raised_cosine(r)])
        envelope[-1] = 0.0  # as long as the block: the delay line's d samples come out first
        self._advance(self._physics, np.concatenate([queued, ramp, tail]), envelope)
        self._last_drive = 0.0

    def stop(self) -> None:
        """Ramp the drive to zero (``abort_ramp_time``), stop, discard queued drive. Idempotent."""
        if self._running:
            self._running = False
            self._ramp_down()
        self._queue.clear()
        self._queued = 0

    def close(self) -> None:
        self.stop()
        self._closed = True
