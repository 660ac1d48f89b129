"""The narrow hardware contract every backend implements, and the errors it raises.

Two devices stand between a procedure and the rig:

* :class:`AcquisitionDevice` -- synchronised analog input (force, accelerations) and the analog
  drive output that feeds the shaker amplifier (NI-DAQmx in :mod:`rigtools.drivers.nidaq`, the simulated
  rig in :mod:`rigtools.drivers.simulated`);
* :class:`SignalSource` -- an instrument that makes the sine itself (a 33500-series waveform
  generator in :mod:`rigtools.drivers.visa_source`), for rigs where the DAQ only listens.

Both are context managers whose exit brings the output to zero and off on every path (normal end,
error, Ctrl-C). Everything is SI: read blocks are in m/s^2, N or V; drive blocks in V.

Errors are plain exceptions rooted at :class:`DriverError` (``drivers`` does not import
``rigtools``); each names the fault in one line, so ``str(exc)`` is what a user should see. The
CLI maps them to exit codes: :class:`DriverUnavailable` like ``rigtools.errors.HardwareUnavailable``
(3), the rest as failures of the run.

Typical acquisition loop::

    with device:                                   # exit: drive to zero, tasks stopped, closed
        rate = device.configure(inputs, output, 51200.0)
        n = device.block_size                      # about 0.1 s
        device.write(drive.next_block(n))          # prime the (non-regenerating) output:
        device.write(drive.next_block(n))          #   stay at least one block ahead
        device.start()
        while running:
            block = device.read()                  # (n_channels, n) float64, channel order
            device.write(drive.next_block(n))
        device.stop()
"""

from __future__ import annotations

import abc
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from types import TracebackType
from typing import TYPE_CHECKING, Literal

if TYPE_CHECKING:  # typing.Self is 3.11+; the annotations are strings (PEP 563), never evaluated
    from typing import Self

    # numpy only in annotations: the rig file's [daq] builds these specs without loading numpy
    import numpy as np

STANDARD_GRAVITY = 9.80665  # m/s^2 per g, exactly (CGPM 1901)

ChannelKind = Literal["accel", "force", "voltage"]

# kind -> (SI units of the read values, quantity name, conventional sensitivity units)
_KIND_UNITS: dict[str, tuple[str, str, str]] = {
    "accel": ("m/s^2", "acceleration", "mV/g"),
    "force": ("N", "force", "mV/N"),
    "voltage": ("V", "voltage", "V/V"),
}


# --------------------------------------------------------------------------------------- errors


class DriverError(Exception):
    """Root of every error raised by a driver. ``str(exc)`` is one line for the user."""

    fault: str = "driver error"


class DriverUnavailable(DriverError):
    """The hardware or its driver library is not present on this machine."""

    fault = "hardware unavailable"


class ConfigurationError(DriverError, ValueError):
    """Channels, rates or limits that the device (or the driver) cannot accept."""

    fault = "invalid configuration"


class LimitExceeded(DriverError, ValueError):
    """A setting refused before it was sent, because it is outside the configured limits."""

    fault = "limit exceeded"


class DaqFault(DriverError):
    """A fault during a running acquisition; the run must stop with the drive at zero.

    Parameters
    ----------
    message
        One line naming the fault (the class's ``fault`` is prefixed when missing).
    partial
        Samples read before the fault in the block that failed, ``(n_channels, m)``, or ``None``.
        Blocks returned before the fault are the caller's and stay valid.
    code
        The backend's numeric error code when there is one (e.g. the DAQmx code).
    """

    fault = "acquisition fault"

    def __init__(
        self, message: str = "", *, partial: np.ndarray | None = None, code: int | None = None
    ) -> None:
        text = message or self.fault
        if not text.lower().startswith(self.fault.lower()):
            text = f"{self.fault}: {text}"
        super().__init__(text)
        self.partial = partial
        self.code = code


class InputOverflow(DaqFault):
    """The device's input buffer overflowed: the host did not read fast enough."""

    fault = "input overflow"


class SamplesNoLongerAvailable(DaqFault):
    """The software input buffer wrapped before the samples were read (data lost)."""

    fault = "samples no longer available"


class OutputUnderflow(DaqFault):
    """The drive output ran out of samples (non-regenerating output not fed in time)."""

    fault = "output underflow"


class ReadTimeout(DaqFault):
    """A block did not arrive within the timeout."""

    fault = "read timeout"


class AmplifierTimeout(DaqFault):
    """The shaker amplifier (or signal source) stopped answering."""

    fault = "amplifier timeout"


class SensorOverload(DaqFault):
    """An input exceeded its range (sensor or ADC saturated)."""

    fault = "sensor overload"


class InvalidSamples(DaqFault):
    """The device returned non-finite samples (NaN or inf)."""

    fault = "invalid samples"


class SimulationDiverged(DaqFault):
    """The simulated rig's physics diverged mid-run (e.g. a contact too stiff for the time step):
    its state is lost; the drive is ramped to zero on a model at rest."""

    fault = "simulation diverged"


class SafetyAbort(DaqFault):
    """A safety limit was crossed; names the channel, the value and the limit."""

    fault = "safety abort"

    def __init__(
        self,
        message: str = "",
        *,
        channel: str = "",
        value: float = math.nan,
        limit: float = math.nan,
        partial: np.ndarray | None = None,
    ) -> None:
        super().__init__(message, partial=partial)
        self.channel = channel
        self.value = value
        self.limit = limit


class SignalSourceError(DriverError):
    """The signal source reported an error (e.g. ``SYST:ERR?`` not ``+0,"No error"``)."""

    fault = "signal source error"


# ------------------------------------------------------------------------------ channel specs


@dataclass(frozen=True)
class InputChannelSpec:
    """One analog input as wired on the rig.

    Parameters
    ----------
    name
        Channel name used in recordings, e.g. ``"force"``, ``"active_shroud_accel"``.
    physical_channel
        Device terminal, e.g. ``"Dev1/ai0"`` (the simulated rig accepts any text).
    kind
        ``"accel"`` (IEPE accelerometer), ``"force"`` (IEPE force sensor) or ``"voltage"``.
    sensitivity
        In ``sensitivity_units``: mV/g for accelerometers, mV/N for force sensors, V/V for voltage.
    sensitivity_units
        Must match the kind (``"mV/g"``, ``"mV/N"``, ``"V/V"``).
    excitation_current
        IEPE constant-current excitation in A (typically 0.002-0.010); 0 for none.
    min_value, max_value
        Expected range in SI units of the channel (m/s^2, N, V); the device picks its gain from it.
    location
        Where the sensor sits, e.g. ``"active blade shroud, x = 0.180 m"``.
    """

    name: str
    physical_channel: str
    kind: ChannelKind
    sensitivity: float = 1.0
    sensitivity_units: str = "V/V"
    excitation_current: float = 0.0
    min_value: float = -10.0
    max_value: float = 10.0
    location: str = ""

    def __post_init__(self) -> None:
        if self.kind not in _KIND_UNITS:
            raise ConfigurationError(
                f"channel {self.name!r}: kind {self.kind!r} is not one of accel, force, voltage"
            )
        expected = _KIND_UNITS[self.kind][2]
        if self.sensitivity_units != expected:
            raise ConfigurationError(
                f"channel {self.name!r}: sensitivity units {self.sensitivity_units!r} do not suit "
                f"kind {self.kind!r} (expected {expected!r})"
            )
        if not (self.sensitivity > 0 and math.isfinite(self.sensitivity)):
            raise ConfigurationError(f"channel {self.name!r}: sensitivity {self.sensitivity!r} must be > 0")
        if not (0.0 <= self.excitation_current <= 0.025):
            raise ConfigurationError(
                f"channel {self.name!r}: excitation current {self.excitation_current!r} A is "
                "outside 0..0.025 A"
            )
        if not self.min_value < self.max_value:
            raise ConfigurationError(
                f"channel {self.name!r}: min_value {self.min_value!r} must be below "
                f"max_value {self.max_value!r}"
            )

    @property
    def units(self) -> str:
        """SI units of the values read (``"m/s^2"``, ``"N"`` or ``"V"``)."""
        return _KIND_UNITS[self.kind][0]

    @property
    def quantity(self) -> str:
        """``"acceleration"``, ``"force"`` or ``"voltage"`` (as in recordings)."""
        return _KIND_UNITS[self.kind][1]

    @property
    def volts_per_unit(self) -> float:
        """Sensor output in V per SI unit: mV/g -> V/(m/s^2), mV/N -> V/N, V/V -> 1."""
        if self.kind == "accel":
            return self.sensitivity * 1e-3 / STANDARD_GRAVITY
        if self.kind == "force":
            return self.sensitivity * 1e-3
        return self.sensitivity

    @property
    def iepe(self) -> bool:
        """True when the channel powers an IEPE sensor (AC-coupled)."""
        return self.excitation_current > 0


@dataclass(frozen=True)
class OutputChannelSpec:
    """The analog drive output (to the shaker amplifier's input), in volts.

    ``min_voltage``/``max_voltage`` are the device range; the safety module's maximum drive is
    usually tighter.
    """

    name: str = "drive"
    physical_channel: str = "Dev1/ao0"
    min_voltage: float = -10.0
    max_voltage: float = 10.0

    def __post_init__(self) -> None:
        if not self.min_voltage < 0.0 < self.max_voltage:
            raise ConfigurationError(
                f"output {self.name!r}: range {self.min_voltage}..{self.max_voltage} V must contain 0 V"
            )

    @property
    def units(self) -> str:
        return "V"


@dataclass(frozen=True)
class DeviceInfo:
    """What a backend says about itself, for a recording's ``experiment`` description."""

    backend: str  # "nidaqmx" | "simulated" | ...
    sample_rate: float  # actual (coerced) rate, S/s
    requested_sample_rate: float
    block_size: int  # samples per channel per read() by default
    input_to_output_delay: float  # s, see AcquisitionDevice.input_to_output_delay
    details: dict[str, str] = field(default_factory=dict)  # device names, serials, ...


# ---------------------------------------------------------------------------- the contracts


class AcquisitionDevice(abc.ABC):
    """Synchronised analog inputs plus one drive output on a shared sample clock.

    Life cycle: ``configure`` -> ``write`` (prime) -> ``start`` -> (``read``/``write``)* ->
    ``stop`` -> ``close``. The output is continuous and non-regenerating: the caller keeps
    writing at least as many drive samples as it reads, and stays one block ahead. Input and
    output sample *k* share the same clock tick (the output starts on the input's start
    trigger), up to :meth:`input_to_output_delay`.

    ``with device:`` guarantees on every exit path that the drive is brought to zero, the tasks
    are stopped and the device is closed (:meth:`close`). Implementations put their work in the
    abstract methods; the context manager here is shared.
    """

    backend: str = "abstract"
    #: Whether the backend runs a per-sample real-time inner loop (:mod:`rigtools.drivers.realtime`):
    #: the simulated rig does, inside its integrator; a buffered DAQ (NI-DAQmx) does not.
    has_realtime_loop: bool = False

    @abc.abstractmethod
    def configure(
        self,
        inputs: Sequence[InputChannelSpec],
        output: OutputChannelSpec,
        sample_rate: float,
        block_size: int | None = None,
    ) -> float:
        """Create the input channels, the drive output and their shared sample clock.

        Parameters
        ----------
        inputs
            Input channels, in the row order of the blocks :meth:`read` returns.
        output
            The drive output.
        sample_rate
            Requested rate in S/s (the same for inputs and output).
        block_size
            Samples per channel per :meth:`read`; default about 0.1 s of samples.

        Returns
        -------
        float
            The actual sample rate the device coerced the request to (record this one).
        """

    # Backends keep their configured state in these four attributes; the properties are shared.
    _rate: float = 0.0
    _block: int = 0
    _inputs: tuple[InputChannelSpec, ...] = ()
    _running: bool = False

    @property
    def sample_rate(self) -> float:
        """Actual sample rate in S/s (valid after :meth:`configure`)."""
        return self._rate

    @property
    def block_size(self) -> int:
        """Default samples per channel per :meth:`read`."""
        return self._block

    @property
    def input_channels(self) -> tuple[InputChannelSpec, ...]:
        """The configured inputs in block row order."""
        return self._inputs

    @property
    def running(self) -> bool:
        """True between :meth:`start` and :meth:`stop`."""
        return self._running

    @property
    def output_queue_limit(self) -> int | None:
        """Most drive samples that may be written ahead of the samples read (``None``: no
        bound). Written drive plays out before a stop's ramp, so this bounds the time from a
        fault to 0 V; :class:`rigtools.acquisition.BlockStream` streams in pieces that keep
        two of them within it."""
        return None

    @abc.abstractmethod
    def write(self, drive: np.ndarray) -> None:
        """Append drive samples (1-D, volts) to the output stream.

        Raises
        ------
        LimitExceeded
            If a sample is outside the output channel's range or not finite (nothing is written).
        OutputUnderflow
            If the device already ran out of drive samples.
        """

    @abc.abstractmethod
    def start(self) -> None:
        """Start output and input together (output armed first, on the input start trigger).

        At least one block must have been written first.
        """

    @abc.abstractmethod
    def read(self, n_samples: int | None = None, timeout: float = 10.0) -> np.ndarray:
        """Read the next block, blocking until it is there.

        Parameters
        ----------
        n_samples
            Samples per channel; default :attr:`block_size`.
        timeout
            Seconds to wait for the block.

        Returns
        -------
        numpy.ndarray
            ``(n_channels, n_samples)`` float64 in SI units, rows in :attr:`input_channels`
            order. Consecutive blocks are contiguous in time (no gaps, no overlap).

        Raises
        ------
        DaqFault
            A subclass naming the fault (:class:`~rigtools.drivers.contracts.InputOverflow`,
            :class:`~rigtools.drivers.contracts.SamplesNoLongerAvailable`,
            :class:`~rigtools.drivers.contracts.OutputUnderflow`,
            :class:`~rigtools.drivers.contracts.SensorOverload`,
            :class:`~rigtools.drivers.contracts.InvalidSamples`, ...). The
            device has already driven the output to zero and stopped.
        """

    @abc.abstractmethod
    def stop(self) -> None:
        """Bring the drive to zero and stop output and input. Idempotent; never raises for a
        device that is already stopped."""

    @abc.abstractmethod
    def close(self) -> None:
        """:meth:`stop` if needed, leave the output at 0 V and release the device. Idempotent."""

    @abc.abstractmethod
    def input_to_output_delay(self) -> float:
        """Delay in **seconds** between the drive and the inputs on the shared clock.

        A drive sample written at output index *k* shows its effect (through an ideal, delay-free
        test article) at input index ``k + input_to_output_delay() * sample_rate``: the sum of
        the DAC and ADC pipeline (filter group) delays. Zero when inputs and output are
        perfectly aligned. Procedures use it to align force/drive phases.
        """

    def info(self) -> DeviceInfo:
        """A description of the configured device for recordings."""
        return DeviceInfo(
            self.backend, self.sample_rate, self.sample_rate, self.block_size, self.input_to_output_delay()
        )

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


@dataclass(frozen=True)
class SourceState:
    """What a signal source reports about its output."""

    function: str  # e.g. "SIN"
    frequency: float  # Hz
    amplitude_vpp: float  # V peak-to-peak
    offset: float  # V
    output_on: bool


@dataclass(frozen=True)
class SourceLimits:
    """Limits a signal source enforces before sending anything."""

    frequency_min: float = 1.0  # Hz
    frequency_max: float = 5000.0  # Hz
    amplitude_max_vpp: float = 2.0  # V peak-to-peak into the amplifier

    def __post_init__(self) -> None:
        if not 0 < self.frequency_min < self.frequency_max:
            raise ConfigurationError(
                f"frequency limits {self.frequency_min}..{self.frequency_max} Hz are not a range"
            )
        if not self.amplitude_max_vpp > 0:
            raise ConfigurationError(f"amplitude limit {self.amplitude_max_vpp} Vpp must be > 0")


class SignalSource(abc.ABC):
    """A sine source feeding the shaker amplifier; offset is always 0 V.

    ``with source:`` turns the output off and closes the connection on every exit path.
    Settings outside :attr:`limits` raise :class:`LimitExceeded` before anything is sent;
    an error reported by the instrument raises :class:`SignalSourceError`.
    """

    limits: SourceLimits

    @abc.abstractmethod
    def identify(self) -> str:
        """The instrument's identification (``*IDN?``)."""

    @abc.abstractmethod
    def reset(self) -> None:
        """Reset to a known state: sine, output off, offset 0 V, amplitude at the minimum."""

    @abc.abstractmethod
    def set_frequency(self, hz: float) -> None:
        """Set the sine frequency in Hz."""

    @abc.abstractmethod
    def set_amplitude(self, vpp: float) -> None:
        """Set the amplitude in V peak-to-peak (into a high-impedance load)."""

    @abc.abstractmethod
    def set_output(self, on: bool) -> None:
        """Switch the output on or off."""

    @abc.abstractmethod
    def state(self) -> SourceState:
        """Query the instrument's present settings."""

    @abc.abstractmethod
    def errors(self) -> list[str]:
        """Drain and return the instrument's error queue (empty when there is none)."""

    @abc.abstractmethod
    def close(self) -> None:
        """Output off, release the connection. Idempotent."""

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
