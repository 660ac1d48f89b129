"""NI-DAQmx backend of :class:`rigtools.drivers.contracts.AcquisitionDevice`.

Two tasks on one sample clock rate:

* ``ai``: IEPE accelerometers (``add_ai_accel_chan``, mV/g, internal excitation current, read in
  m/s^2), the IEPE force sensor (``add_ai_force_iepe_chan``, mV/N, read in N), plain voltages;
  continuous, read in blocks (~0.1 s) with :class:`AnalogMultiChannelReader` into a freshly
  allocated float64 array (no copies);
* ``ao``: the drive voltage to the shaker amplifier, continuous and non-regenerating, written with
  :class:`AnalogSingleChannelWriter` (``auto_start=False``), started on the AI start trigger so
  output sample *k* and input sample *k* share the same clock tick.

Start order: the caller writes the first drive block(s), :meth:`NiDaqDevice.start` starts ``ao``
(armed, waiting for the trigger) and then ``ai`` (which fires the trigger). The actual coerced
sample rate is read back from ``ai.timing.samp_clk_rate`` and the output is timed at that rate.

DAQmx errors are turned into :mod:`rigtools.drivers.contracts` faults (one line, the DAQmx code kept in
``.code``); on any fault the drive is brought to zero and both tasks are stopped before the error
propagates. Without the NI-DAQmx driver, :class:`~rigtools.drivers.contracts.DriverUnavailable` says so and
points at the simulated rig.

Bringing the drive to zero (:meth:`NiDaqDevice.stop`, also on :meth:`~NiDaqDevice.close`, on a
fault and on Ctrl-C through ``with``): the output is non-regenerating, so samples already queued
cannot be rewritten; they play out. While the AO task is still generating, ``stop`` appends a
raised-cosine ramp from the last written sample to exactly 0 V over ``abort_ramp_time``
(<= 0.1 s) and a few zeros, waits until the device has generated every written sample
(``out_stream.total_samp_per_chan_generated``, bounded wait), then stops AO and then AI. If the
AO task has already failed (output underflow), it has stopped by itself: the output then sits at
0 V through ``ao_idle_output_behavior = ZERO_VOLTS`` where the device supports it, else a
one-sample on-demand task writes 0 V.

Worst-case time from a fault to 0 V: the samples written but not yet generated plus the ramp,
``(written - generated) / rate + abort_ramp_time``. The queue is bounded so that this stays
within ``max_time_to_zero`` (0.1 s): the AO host buffer holds exactly
:func:`rigtools.drivers.safety.output_queue_limit` samples (0.1 s with a 50 ms ramp: 45 ms, 2304 samples
at 51.2 kS/s), so no writer can be further ahead (writes wait for room), and
:attr:`NiDaqDevice.output_queue_limit` tells :class:`rigtools.acquisition.BlockStream` to
stream in pieces (0.1 s blocks read as five 20 ms pieces) of which two fit. The onboard output
FIFO is asked to stay small too (``output_onbrd_buf_size`` set to one piece and data transfer
requested when it is half full or less, where the device allows).
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Sequence
from typing import NamedTuple

import nidaqmx
import numpy as np
from nidaqmx.constants import (
    AccelSensitivityUnits,
    AccelUnits,
    AcquisitionType,
    AOIdleOutputBehavior,
    Coupling,
    DigitalWidthUnits,
    ExcitationSource,
    ForceIEPESensorSensitivityUnits,
    ForceUnits,
    OutputDataTransferCondition,
    RegenerationMode,
    VoltageUnits,
)
from nidaqmx.errors import DaqError, DaqNotFoundError, DaqNotSupportedError
from nidaqmx.stream_readers import AnalogMultiChannelReader
from nidaqmx.stream_writers import AnalogSingleChannelWriter

from rigtools.drivers.contracts import (
    AcquisitionDevice,
    ConfigurationError,
    DaqFault,
    DeviceInfo,
    DriverError,
    DriverUnavailable,
    InputChannelSpec,
    InputOverflow,
    InvalidSamples,
    LimitExceeded,
    OutputChannelSpec,
    OutputUnderflow,
    ReadTimeout,
    SamplesNoLongerAvailable,
    SensorOverload,
)
from rigtools.drivers.drive_signals import raised_cosine
from rigtools.drivers.errors import one_line
from rigtools.drivers.safety import MAX_ABORT_RAMP, MAX_TIME_TO_ZERO, output_queue_limit

NO_DRIVER_MESSAGE = "NI-DAQmx driver not found on this machine; use --backend sim to run on the simulated rig"
NOT_SUPPORTED_MESSAGE = (
    "NI-DAQmx is not supported on this platform; use --backend sim to run on the simulated rig"
)

# DAQmx error code -> fault class (codes from nidaqmx.error_codes.DAQmxErrors)
FAULT_BY_CODE: dict[int, type[DaqFault]] = {
    -200279: SamplesNoLongerAvailable,  # SAMPLES_NO_LONGER_AVAILABLE: software buffer wrapped
    -200010: InputOverflow,  # INPUT_FIFO_OVERFLOW
    -200361: InputOverflow,  # INPUT_FIFO_OVERFLOW_2 (onboard memory)
    -200019: InputOverflow,  # ADC_OVERRUN
    -200016: OutputUnderflow,  # OUTPUT_FIFO_UNDERFLOW
    -200621: OutputUnderflow,  # OUTPUT_FIFO_UNDERFLOW_2
    -200018: OutputUnderflow,  # DAC_UNDERFLOW
    -200290: OutputUnderflow,  # GEN_STOPPED_TO_PREVENT_REGEN_OF_OLD_SAMPLES
    -200284: ReadTimeout,  # SAMPLES_NOT_YET_AVAILABLE (read timed out)
    -200474: ReadTimeout,  # OPERATION_TIMED_OUT
}

BUFFER_SECONDS = 2.0  # AI host buffer, in seconds of samples
DEFAULT_BLOCK_SECONDS = 0.1
ZERO_TAIL_SECONDS = 0.01  # zeros after the stop ramp, so the output rests at 0 V when AO stops
WAIT_MARGIN_SECONDS = 0.5  # extra time allowed for the queued drive and the ramp to play out
POLL_SECONDS = 0.005  # polling interval while waiting for the ramp to be generated

# indirections so tests can run the stop sequence without waiting
_sleep = time.sleep
_clock = time.monotonic


def map_daq_error(exc: DaqError, partial: np.ndarray | None = None) -> DaqFault:
    """The contract fault for a DAQmx error: a known class, or a generic :class:`DaqFault`.

    The message is the first line of the DAQmx text plus the code, so it stays one line.
    """
    code = int(exc.error_code)
    cls = FAULT_BY_CODE.get(code, DaqFault)
    return cls(f"{one_line(exc, first=True)} (DAQmx {code})", partial=partial, code=code)


def _unavailable(exc: Exception) -> DriverUnavailable:
    if isinstance(exc, DaqNotSupportedError):
        return DriverUnavailable(NOT_SUPPORTED_MESSAGE)
    return DriverUnavailable(NO_DRIVER_MESSAGE)


class _Session(NamedTuple):
    """What :meth:`NiDaqDevice.configure` set up, for the streaming calls."""

    ai: nidaqmx.Task
    ao: nidaqmx.Task
    reader: AnalogMultiChannelReader
    writer: AnalogSingleChannelWriter
    output: OutputChannelSpec


class NiDaqDevice(AcquisitionDevice):
    """Force, accelerations and the shaker drive on NI-DAQmx hardware (e.g. a DSA module).

    Examples
    --------
    The contract's order: configure, queue the first two drive blocks, start, read. It needs the
    NI-DAQmx driver and the rig's device (not run by the test suite, which has no hardware):

    >>> from rigtools.config import load_rig
    >>> from rigtools.drivers.drive_signals import SineDrive
    >>> cfg = load_rig("lab.toml")  # doctest: +SKIP
    >>> with NiDaqDevice(abort_ramp_time=cfg.safety.abort_ramp_time) as daq:  # doctest: +SKIP
    ...     rate = daq.configure(cfg.daq.input_specs(), cfg.daq.output_spec(), cfg.daq.sample_rate)
    ...     drive = SineDrive(rate, 60.0, max_drive=cfg.safety.max_drive, ramp_time=0.5)
    ...     drive.set_target(1.0)
    ...     daq.write(drive.next_block(daq.block_size))
    ...     daq.write(drive.next_block(daq.block_size))
    ...     daq.start()
    ...     block = daq.read()  # (input channels, block_size), SI units
    >>> block.shape == (len(cfg.daq.input_specs()), daq.block_size)  # doctest: +SKIP
    True
    """

    backend = "nidaqmx"
    has_realtime_loop = False  # buffered I/O only: rigtools.drivers.realtime.NO_REALTIME_LOOP

    def __init__(self, abort_ramp_time: float = 0.05, max_time_to_zero: float = MAX_TIME_TO_ZERO) -> None:
        """
        Parameters
        ----------
        abort_ramp_time
            Duration of the ramp to 0 V appended on :meth:`stop` (normal end, fault, Ctrl-C), s,
            in (0, 0.1]; the rig file's ``[safety] abort_ramp_time``.
        max_time_to_zero
            Bound on the time from a stop or fault to 0 V, the queued drive included, s: sets
            the AO buffer (:func:`rigtools.drivers.safety.output_queue_limit`).
        """
        if not 0 < abort_ramp_time <= MAX_ABORT_RAMP:
            raise ConfigurationError(
                f"abort ramp time {abort_ramp_time!r} s must be in (0, {MAX_ABORT_RAMP}] s"
            )
        self.abort_ramp_time = float(abort_ramp_time)
        self.max_time_to_zero = float(max_time_to_zero)
        self._ai: nidaqmx.Task | None = None
        self._ao: nidaqmx.Task | None = None
        self._reader: AnalogMultiChannelReader | None = None
        self._writer: AnalogSingleChannelWriter | None = None
        self._inputs: tuple[InputChannelSpec, ...] = ()
        self._output: OutputChannelSpec | None = None
        self._rate = math.nan
        self._requested_rate = math.nan
        self._volts_scale = np.ones((0, 1))
        self._scaled = False
        self._block = 0
        self._ao_buffer = 0
        self._running = False
        self._written = 0
        self._last_value = 0.0  # last drive sample written, V
        self._ao_failed = False  # the AO task stopped on an error (underflow): no ramp possible
        self._idle_is_zero = False
        self._delay = 0.0

    # ------------------------------------------------------------------ configuration

    def configure(
        self,
        inputs: Sequence[InputChannelSpec],
        output: OutputChannelSpec,
        sample_rate: float,
        block_size: int | None = None,
    ) -> float:
        if self._ai is not None:
            raise ConfigurationError("device already configured; close it first")
        inputs = tuple(inputs)
        if not inputs:
            raise ConfigurationError("no input channels given")
        if len({s.name for s in inputs}) != len(inputs):
            raise ConfigurationError("input channel names must be unique")
        if not (sample_rate > 0 and math.isfinite(sample_rate)):
            raise ConfigurationError(f"sample rate {sample_rate!r} S/s must be > 0")
        for spec in inputs:
            if spec.kind == "voltage" and spec.iepe:
                raise ConfigurationError(
                    f"channel {spec.name!r}: a voltage channel takes no excitation current"
                )
        try:
            ai = self._ai = nidaqmx.Task()
            ao = self._ao = nidaqmx.Task()
        except (DaqNotFoundError, DaqNotSupportedError) as exc:
            self._close_tasks()
            raise _unavailable(exc) from None
        self._inputs, self._output = inputs, output
        # DAQmx scales accel and force channels itself; voltage channels are divided here by
        # their V/V sensitivity (e.g. an amplifier monitor at 0.1 V/V), as the simulated rig does
        self._volts_scale = np.array([1.0 / s.sensitivity if s.kind == "voltage" else 1.0 for s in inputs])[
            :, None
        ]
        self._scaled = bool(np.any(self._volts_scale != 1.0))
        self._requested_rate = float(sample_rate)
        try:
            for spec in inputs:
                self._add_input(ai, spec)
            ao_chan = ao.ao_channels.add_ao_voltage_chan(
                output.physical_channel,
                name_to_assign_to_channel=output.name,
                min_val=output.min_voltage,
                max_val=output.max_voltage,
                units=VoltageUnits.VOLTS,
            )
            try:
                ao_chan.ao_idle_output_behavior = AOIdleOutputBehavior.ZERO_VOLTS
                self._idle_is_zero = True
            except DaqError:  # not every device has it; close() then writes 0 V
                self._idle_is_zero = False

            buffer = max(int(BUFFER_SECONDS * sample_rate), 2 * (block_size or 1))
            ai.timing.cfg_samp_clk_timing(
                sample_rate, sample_mode=AcquisitionType.CONTINUOUS, samps_per_chan=buffer
            )
            self._rate = float(ai.timing.samp_clk_rate)  # the coerced, actual rate
            self._block = int(block_size) if block_size else max(1, round(DEFAULT_BLOCK_SECONDS * self._rate))
            self._ao_buffer = output_queue_limit(self._rate, self.abort_ramp_time, self.max_time_to_zero)
            ao.timing.cfg_samp_clk_timing(
                self._rate, sample_mode=AcquisitionType.CONTINUOUS, samps_per_chan=self._ao_buffer
            )
            self._limit_onboard_fifo(ao, ao_chan)
            ao_rate = float(ao.timing.samp_clk_rate)
            if not math.isclose(ao_rate, self._rate, rel_tol=1e-9):
                raise ConfigurationError(
                    f"input and output clocks coerced to different rates ({self._rate} and "
                    f"{ao_rate} S/s); choose a rate both support"
                )
            # AO waits for the AI start trigger: both start on the same clock edge
            ao.triggers.start_trigger.cfg_dig_edge_start_trig(ai.triggers.start_trigger.term)
            ao.out_stream.regen_mode = RegenerationMode.DONT_ALLOW_REGENERATION

            self._reader = AnalogMultiChannelReader(ai.in_stream)
            self._writer = AnalogSingleChannelWriter(ao.out_stream, auto_start=False)
            self._delay = self._read_delay(ai, ao)
        except DaqError as exc:
            self._close_tasks()
            raise ConfigurationError(
                f"NI-DAQmx refused the configuration: {one_line(exc, first=True)} (DAQmx {exc.error_code})"
            ) from exc
        except DriverError:
            self._close_tasks()
            raise
        return self._rate

    def _limit_onboard_fifo(self, ao: nidaqmx.Task, ao_chan) -> None:
        """Keep the onboard output FIFO short where the device allows (best effort)."""
        try:
            ao_chan.ao_data_xfer_req_cond = OutputDataTransferCondition.ON_BOARD_MEMORY_HALF_FULL_OR_LESS
        except (DaqError, AttributeError, TypeError):
            pass
        try:
            ao.out_stream.output_onbrd_buf_size = max(2, self._ao_buffer // 2)
        except (DaqError, AttributeError, TypeError):
            pass

    @property
    def output_queue_limit(self) -> int | None:
        """The AO host buffer: the most drive samples queued ahead (see the module docstring)."""
        return self._ao_buffer or None

    def _add_input(self, ai: nidaqmx.Task, spec: InputChannelSpec) -> None:
        excitation = ExcitationSource.INTERNAL if spec.iepe else ExcitationSource.NONE
        chans = ai.ai_channels
        # a sensor channel (DAQmx scales by the sensitivity): its call and units by kind
        sensors = {
            "accel": (
                chans.add_ai_accel_chan,
                AccelUnits.METERS_PER_SECOND_SQUARED,
                AccelSensitivityUnits.MILLIVOLTS_PER_G,
            ),
            "force": (
                chans.add_ai_force_iepe_chan,
                ForceUnits.NEWTONS,
                ForceIEPESensorSensitivityUnits.MILLIVOLTS_PER_NEWTON,
            ),
        }
        if spec.kind in sensors:
            add, units, sensitivity_units = sensors[spec.kind]
            chan = add(
                spec.physical_channel,
                name_to_assign_to_channel=spec.name,
                min_val=spec.min_value,
                max_val=spec.max_value,
                units=units,
                sensitivity=spec.sensitivity,
                sensitivity_units=sensitivity_units,
                current_excit_source=excitation,
                current_excit_val=spec.excitation_current,
            )
        else:  # DAQmx reads the terminal's volts: its range is the sensor's times the sensitivity
            chan = chans.add_ai_voltage_chan(
                spec.physical_channel,
                name_to_assign_to_channel=spec.name,
                min_val=spec.min_value * spec.sensitivity,
                max_val=spec.max_value * spec.sensitivity,
                units=VoltageUnits.VOLTS,
            )
        if spec.iepe:
            chan.ai_coupling = Coupling.AC  # IEPE: the sensor's bias voltage is blocked

    def _read_delay(self, ai: nidaqmx.Task, ao: nidaqmx.Task) -> float:
        """AI plus AO filter delay in seconds; 0 where the device does not report one."""
        total = 0.0
        for chan, value, units in (
            (ai.ai_channels.all, "ai_filter_delay", "ai_filter_delay_units"),
            (ao.ao_channels.all, "ao_filter_delay", "ao_filter_delay_units"),
        ):
            try:
                delay = float(getattr(chan, value))
                unit = getattr(chan, units)
            except (DaqError, TypeError, ValueError):
                continue
            if unit == DigitalWidthUnits.SAMPLE_CLOCK_PERIODS:
                total += delay / self._rate
            elif unit == DigitalWidthUnits.SECONDS:
                total += delay
        return total

    # ------------------------------------------------------------------------ properties

    def input_to_output_delay(self) -> float:
        return self._delay

    def time_to_zero(self) -> float:
        """Worst case from a fault to 0 V at the output, s: a full AO host buffer still to play,
        then the ramp (the onboard FIFO, kept to half a piece where the device allows, adds its
        depth)."""
        return (self._ao_buffer + self.ramp_samples) / self._rate

    def info(self) -> DeviceInfo:
        details: dict[str, str] = {}
        with contextlib.suppress(Exception):  # informational only; never fail a run for it
            if self._ai is not None:
                details["devices"] = ", ".join(
                    f"{d.name} ({d.product_type}, s/n {d.serial_num:X})" for d in self._ai.devices
                )
        details["drive_idle_zero_volts"] = str(self._idle_is_zero)
        details["abort_ramp_time_s"] = f"{self.ramp_samples / self._rate:g}"
        details["max_time_to_zero_s"] = f"{self.time_to_zero():.3g}"
        return DeviceInfo(self.backend, self._rate, self._requested_rate, self._block, self._delay, details)

    # ----------------------------------------------------------------------- streaming

    def _require_configured(self) -> _Session:
        """The configured tasks and streams; raises if :meth:`configure` has not succeeded."""
        if (
            self._ai is None
            or self._ao is None
            or self._writer is None
            or self._reader is None
            or self._output is None
        ):
            raise ConfigurationError("device not configured; call configure() first")
        return _Session(self._ai, self._ao, self._reader, self._writer, self._output)

    def write(self, drive: np.ndarray) -> None:
        session = self._require_configured()
        data = np.ascontiguousarray(drive, dtype=np.float64)
        if data.ndim != 1 or data.size == 0:
            raise LimitExceeded(f"drive block must be 1-D and non-empty, got shape {data.shape}")
        if not np.all(np.isfinite(data)):
            raise LimitExceeded("drive block holds NaN or inf; nothing written")
        low, high = session.output.min_voltage, session.output.max_voltage
        if data.min() < low or data.max() > high:
            raise LimitExceeded(
                f"drive {data.min():.4g}..{data.max():.4g} V is outside the output range "
                f"{low}..{high} V; nothing written"
            )
        try:
            session.writer.write_many_sample(data, timeout=10.0)
        except DaqError as exc:
            self._fail(map_daq_error(exc))
        self._written += data.size
        self._last_value = float(data[-1])

    def start(self) -> None:
        session = self._require_configured()
        if self._running:
            return
        if self._written == 0:
            raise ConfigurationError("write at least one drive block before start()")
        try:
            session.ao.start()  # armed: waits for the AI start trigger
            self._running = True
            session.ai.start()  # fires the trigger: AO and AI start on the same edge
        except DaqError as exc:
            self._fail(map_daq_error(exc))

    def read(self, n_samples: int | None = None, timeout: float = 10.0) -> np.ndarray:
        session = self._require_configured()
        n = int(n_samples or self._block)
        data = np.empty((len(self._inputs), n), dtype=np.float64)
        try:
            session.reader.read_many_sample(data, number_of_samples_per_channel=n, timeout=timeout)
        except DaqError as exc:
            got = int(getattr(exc, "samps_per_chan_read", 0) or 0)
            self._fail(map_daq_error(exc, partial=data[:, :got] * self._volts_scale if got else None))
        if self._scaled:
            data *= self._volts_scale
        if not np.all(np.isfinite(data)):
            bad = [s.name for s, row in zip(self._inputs, data, strict=True) if not np.all(np.isfinite(row))]
            self._fail(InvalidSamples(f"non-finite samples on {', '.join(bad)}", partial=data))
        try:
            overloaded = session.ai.in_stream.overloaded_chans_exist
            names = list(session.ai.in_stream.overloaded_chans) if overloaded else []
        except DaqError:  # devices without overload detection
            names = []
        if names:
            self._fail(SensorOverload(f"input overload on {', '.join(names)}", partial=data))
        return data

    def _fail(self, fault: DaqFault) -> None:
        """Bring the drive to zero, stop both tasks, then raise ``fault``."""
        if isinstance(fault, OutputUnderflow):
            self._ao_failed = True  # DAQmx has stopped the AO task: nothing more can be written
        self.stop()
        raise fault

    # ------------------------------------------------------------------------- shutdown

    @property
    def ramp_samples(self) -> int:
        """Samples of the stop ramp: ``abort_ramp_time * rate``, rounded down (never longer)."""
        return max(1, math.floor(self.abort_ramp_time * self._rate + 1e-9))

    def stop_ramp(self) -> np.ndarray:
        """The samples :meth:`stop` appends: a raised-cosine ramp from the last written sample to
        exactly 0 V over :attr:`ramp_samples`, then ``ZERO_TAIL_SECONDS`` of zeros."""
        ramp = self._last_value * (1.0 - raised_cosine(self.ramp_samples))
        ramp[-1] = 0.0
        zeros = np.zeros(max(1, round(ZERO_TAIL_SECONDS * self._rate)))
        return np.concatenate([ramp, zeros])

    def stop(self) -> None:
        """Ramp the drive to 0 V, stop output then input, leave the output at 0 V. Never raises
        a DAQmx error; idempotent. See the module docstring for the sequence and its timing.

        Ctrl-C during the wait cuts it short: the tasks are still stopped (the output then takes
        its idle 0 V, or the on-demand 0 V) before the interrupt propagates.
        """
        if self._ao is None:
            return
        try:
            if self._running and not self._ao_failed and self._writer is not None:
                self._ramp_to_zero(self._ao, self._writer)
        finally:
            for task in (self._ao, self._ai):
                if task is not None:
                    with contextlib.suppress(DaqError):
                        task.stop()
            was_running, self._running = self._running, False
            if was_running and not self._idle_is_zero and self._output is not None:
                self._write_zero_on_demand(self._output)

    def _ramp_to_zero(self, ao: nidaqmx.Task, writer: AnalogSingleChannelWriter) -> None:
        """Append the stop ramp and wait (bounded) until the device has generated all of it."""
        tail = self.stop_ramp()
        try:
            queued = self._written - int(ao.out_stream.total_samp_per_chan_generated)
        except DaqError:  # the task failed since the last write: it has stopped
            self._ao_failed = True
            return
        budget = (max(queued, 0) + tail.size) / self._rate + WAIT_MARGIN_SECONDS
        try:
            writer.write_many_sample(tail, timeout=budget)
        except DaqError:
            self._ao_failed = True  # underflowed meanwhile or no room: it stops as it is
            return
        self._written += tail.size
        self._last_value = 0.0
        deadline = _clock() + budget
        while True:
            try:
                generated = int(ao.out_stream.total_samp_per_chan_generated)
            except DaqError:  # underflow after the zeros: everything was generated
                return
            if generated >= self._written or _clock() > deadline:
                return
            _sleep(min(POLL_SECONDS, (self._written - generated) / self._rate))

    def _write_zero_on_demand(self, output: OutputChannelSpec) -> None:
        """A stopped AO task holds its last value; on such devices, set 0 V with a fresh task."""
        try:
            with nidaqmx.Task() as zero:
                zero.ao_channels.add_ao_voltage_chan(
                    output.physical_channel,
                    min_val=output.min_voltage,
                    max_val=output.max_voltage,
                    units=VoltageUnits.VOLTS,
                )
                zero.write(0.0, auto_start=True)
                zero.stop()
        except (DaqError, DaqNotFoundError, DaqNotSupportedError):
            pass

    def _close_tasks(self) -> None:
        for task in (self._ao, self._ai):
            if task is not None:
                try:
                    task.close()
                except DaqError:
                    pass
        self._ai = self._ao = None
        self._reader = self._writer = None

    def close(self) -> None:
        if self._ao is not None:
            self.stop()
        self._close_tasks()
