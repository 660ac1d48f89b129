"""The NI-DAQmx backend, checked call by call against autospecs of the real nidaqmx classes.

No NI-DAQmx driver is needed: ``nidaqmx.Task`` and the stream reader/writer are replaced by
``create_autospec`` mocks (the task's timing, triggers, streams and channel collections are
autospecced too, so a misspelt method or a wrong argument name fails here as it would on
hardware). The expected arguments are written out from the rig file's channel map, not from the
driver's code.
"""

from __future__ import annotations

from unittest import mock

import nidaqmx
import numpy as np
import pytest
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
    RegenerationMode,
    VoltageUnits,
)
from nidaqmx.errors import DaqError, DaqNotFoundError, DaqNotSupportedError, DaqReadError, DaqWriteError
from nidaqmx.stream_readers import AnalogMultiChannelReader
from nidaqmx.stream_writers import AnalogSingleChannelWriter
from nidaqmx.task import InStream, OutStream, Task, Timing
from nidaqmx.task.channels import AIChannel, AOChannel
from nidaqmx.task.collections import AIChannelCollection, AOChannelCollection
from nidaqmx.task.triggering import StartTrigger, Triggers

from rigtools.config import load_rig
from rigtools.drivers import nidaq
from rigtools.drivers.contracts import (
    ConfigurationError,
    DaqFault,
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
from rigtools.drivers.nidaq import NiDaqDevice

AI_TRIGGER = "/Dev1/ai/StartTrigger"


def make_task(rate: float) -> mock.NonCallableMagicMock:
    """An autospecced Task whose sub-objects are autospecced as well."""
    task = mock.create_autospec(Task, instance=True)
    task.timing = mock.create_autospec(Timing, instance=True)
    task.timing.samp_clk_rate = rate
    task.triggers = mock.create_autospec(Triggers, instance=True)
    task.triggers.start_trigger = mock.create_autospec(StartTrigger, instance=True)
    task.triggers.start_trigger.term = AI_TRIGGER
    task.in_stream = mock.create_autospec(InStream, instance=True)
    task.in_stream.overloaded_chans_exist = False
    task.out_stream = mock.create_autospec(OutStream, instance=True)
    task.ai_channels = mock.create_autospec(AIChannelCollection, instance=True)
    task.ao_channels = mock.create_autospec(AOChannelCollection, instance=True)
    for method in ("add_ai_accel_chan", "add_ai_force_iepe_chan", "add_ai_voltage_chan"):
        getattr(task.ai_channels, method).return_value = mock.create_autospec(AIChannel, instance=True)
    task.ao_channels.add_ao_voltage_chan.return_value = mock.create_autospec(AOChannel, instance=True)
    # no filter delay reported unless a test says so
    task.ai_channels.all = mock.create_autospec(AIChannel, instance=True)
    type(task.ai_channels.all).ai_filter_delay = mock.PropertyMock(side_effect=DaqError("n/a", -200452))
    task.ao_channels.all = mock.create_autospec(AOChannel, instance=True)
    type(task.ao_channels.all).ao_filter_delay = mock.PropertyMock(side_effect=DaqError("n/a", -200452))
    return task


class Rig:
    """The patched world: tasks in creation order (ai, ao, then any on-demand zero task).

    The AO task's ``out_stream.total_samp_per_chan_generated`` is a property mock on the
    timeline (``"generated"``): by default the device has generated everything written; a test
    can give it a sequence. ``nidaq._sleep``/``nidaq._clock`` are a fake clock: sleeping only
    advances it (``sleeps`` lists the requests), so no test waits.
    """

    def __init__(self, monkeypatch, ai_rate=51200.0, ao_rate=None, idle_zero_supported=True):
        self.ai = make_task(ai_rate)
        self.ao = make_task(ai_rate if ao_rate is None else ao_rate)
        self.zero = make_task(ai_rate)
        self.zero.__enter__.return_value = self.zero
        if not idle_zero_supported:
            chan = self.ao.ao_channels.add_ao_voltage_chan.return_value
            type(chan).ao_idle_output_behavior = mock.PropertyMock(
                side_effect=DaqError("Specified property is not supported", -200452)
            )
        self.task_cls = mock.Mock(side_effect=[self.ai, self.ao, self.zero])
        self.reader_cls = mock.create_autospec(AnalogMultiChannelReader)
        self.writer_cls = mock.create_autospec(AnalogSingleChannelWriter)
        self.reader = self.reader_cls.return_value
        self.writer = self.writer_cls.return_value
        self.written: list[np.ndarray] = []
        self.writer.write_many_sample.side_effect = self._record_write
        # one timeline across both tasks, the reader and the writer, for ordering checks
        self.timeline = mock.Mock()
        self.timeline.attach_mock(self.ai.start, "ai_start")
        self.timeline.attach_mock(self.ao.start, "ao_start")
        self.timeline.attach_mock(self.ai.stop, "ai_stop")
        self.timeline.attach_mock(self.ao.stop, "ao_stop")
        self.timeline.attach_mock(self.ai.close, "ai_close")
        self.timeline.attach_mock(self.ao.close, "ao_close")
        self.timeline.attach_mock(self.writer.write_many_sample, "write")
        self.generated = mock.PropertyMock(side_effect=lambda: sum(w.size for w in self.written))
        type(self.ao.out_stream).total_samp_per_chan_generated = self.generated
        self.timeline.attach_mock(self.generated, "generated")
        self.now = 0.0
        self.sleeps: list[float] = []
        monkeypatch.setattr(nidaq, "_clock", lambda: self.now)
        monkeypatch.setattr(nidaq, "_sleep", self._sleep)
        monkeypatch.setattr(nidaq.nidaqmx, "Task", self.task_cls)
        monkeypatch.setattr(nidaq, "AnalogMultiChannelReader", self.reader_cls)
        monkeypatch.setattr(nidaq, "AnalogSingleChannelWriter", self.writer_cls)

    def _record_write(self, data, timeout=10.0):
        self.written.append(np.array(data, copy=True))
        return len(data)

    def _sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)
        self.now += seconds

    def order(self) -> list[str]:
        return [name for name, _, _ in self.timeline.mock_calls]


@pytest.fixture
def specs():
    cfg = load_rig()
    return cfg.daq.input_specs(), cfg.daq.output_spec()


def configured(monkeypatch, specs, **kw) -> tuple[Rig, NiDaqDevice]:
    rig = Rig(monkeypatch, **kw)
    dev = NiDaqDevice()
    dev.configure(specs[0], specs[1], 51200.0)
    return rig, dev


def test_channels_are_created_with_sensitivities_units_and_iepe_excitation(monkeypatch, specs):
    rig, dev = configured(monkeypatch, specs)
    # expected from the default rig file: force 11.24 mV/N +-200 N; accels 10 mV/g +-4900 m/s^2;
    # 4 mA internal IEPE excitation on all three
    accel = {
        "min_val": -4900.0,
        "max_val": 4900.0,
        "units": AccelUnits.METERS_PER_SECOND_SQUARED,
        "sensitivity": 10.0,
        "sensitivity_units": AccelSensitivityUnits.MILLIVOLTS_PER_G,
        "current_excit_source": ExcitationSource.INTERNAL,
        "current_excit_val": 0.004,
    }
    assert rig.ai.ai_channels.mock_calls[:3] == [
        mock.call.add_ai_force_iepe_chan(
            "Dev1/ai0",
            name_to_assign_to_channel="force",
            min_val=-200.0,
            max_val=200.0,
            units=ForceUnits.NEWTONS,
            sensitivity=11.24,
            sensitivity_units=ForceIEPESensorSensitivityUnits.MILLIVOLTS_PER_NEWTON,
            current_excit_source=ExcitationSource.INTERNAL,
            current_excit_val=0.004,
        ),
        mock.call.add_ai_accel_chan("Dev1/ai1", name_to_assign_to_channel="active_shroud_accel", **accel),
        mock.call.add_ai_accel_chan("Dev1/ai2", name_to_assign_to_channel="passive_shroud_accel", **accel),
    ]
    assert rig.ai.ai_channels.add_ai_accel_chan.return_value.ai_coupling == Coupling.AC
    assert rig.ai.ai_channels.add_ai_force_iepe_chan.return_value.ai_coupling == Coupling.AC
    rig.ao.ao_channels.add_ao_voltage_chan.assert_called_once_with(
        "Dev1/ao0", name_to_assign_to_channel="drive", min_val=-10.0, max_val=10.0, units=VoltageUnits.VOLTS
    )
    chan = rig.ao.ao_channels.add_ao_voltage_chan.return_value
    assert chan.ao_idle_output_behavior == AOIdleOutputBehavior.ZERO_VOLTS
    rig.ai.ai_channels.add_ai_voltage_chan.assert_not_called()
    assert dev.block_size == 5120  # 0.1 s at 51.2 kS/s


def test_voltage_channel_without_excitation(monkeypatch):
    rig = Rig(monkeypatch)
    dev = NiDaqDevice()
    dev.configure(
        [InputChannelSpec("amp_monitor", "Dev1/ai3", "voltage", 1.0, "V/V", 0.0, -5, 5)],
        OutputChannelSpec(),
        51200.0,
    )
    rig.ai.ai_channels.add_ai_voltage_chan.assert_called_once_with(
        "Dev1/ai3", name_to_assign_to_channel="amp_monitor", min_val=-5, max_val=5, units=VoltageUnits.VOLTS
    )
    with pytest.raises(ConfigurationError, match="takes no excitation"):
        NiDaqDevice().configure(
            [InputChannelSpec("v", "Dev1/ai3", "voltage", 1.0, "V/V", 0.004, -5, 5)],
            OutputChannelSpec(),
            51200.0,
        )


def test_voltage_channel_sensitivity_scales_range_and_readings_like_the_simulated_rig(monkeypatch):
    # an amplifier monitor at 0.1 V/V reading a +-50 V coil voltage: the terminal sees +-5 V, and
    # a terminal reading of 1.2 V is 12 V at the coil (rigtools.drivers.sensor_chain divides the same way)
    rig = Rig(monkeypatch)
    dev = NiDaqDevice()
    dev.configure(
        [InputChannelSpec("coil_monitor", "Dev1/ai3", "voltage", 0.1, "V/V", 0.0, -50, 50)],
        OutputChannelSpec(),
        51200.0,
    )
    rig.ai.ai_channels.add_ai_voltage_chan.assert_called_once_with(
        "Dev1/ai3",
        name_to_assign_to_channel="coil_monitor",
        min_val=-5.0,
        max_val=5.0,
        units=VoltageUnits.VOLTS,
    )
    rig.reader.read_many_sample.side_effect = lambda data, **kw: data.fill(1.2)
    dev.write(np.zeros(16))
    dev.start()
    np.testing.assert_allclose(dev.read(16), 12.0, rtol=1e-15)


def test_shared_rate_is_the_coerced_ai_rate_and_ao_starts_on_the_ai_trigger(monkeypatch, specs):
    # the device coerces 51.2 kS/s to 51.2e3 * 1.0001 (made up): AO must be timed at that rate
    coerced = 51205.12
    rig = Rig(monkeypatch, ai_rate=coerced)
    dev = NiDaqDevice()
    actual = dev.configure(specs[0], specs[1], 51200.0)
    assert actual == coerced and dev.sample_rate == coerced
    rig.ai.timing.cfg_samp_clk_timing.assert_called_once_with(
        51200.0, sample_mode=AcquisitionType.CONTINUOUS, samps_per_chan=102400
    )
    # AO host buffer = the output queue limit: 0.1 s to zero with the 50 ms ramp, 90 % of the
    # 50 ms left for queued drive at the coerced rate: floor(0.045 * 51205.12) = 2304 samples
    rig.ao.timing.cfg_samp_clk_timing.assert_called_once_with(
        coerced, sample_mode=AcquisitionType.CONTINUOUS, samps_per_chan=2304
    )
    rig.ao.triggers.start_trigger.cfg_dig_edge_start_trig.assert_called_once_with(AI_TRIGGER)
    rig.ai.triggers.start_trigger.cfg_dig_edge_start_trig.assert_not_called()  # AI is the master
    assert rig.ao.out_stream.regen_mode == RegenerationMode.DONT_ALLOW_REGENERATION
    rig.reader_cls.assert_called_once_with(rig.ai.in_stream)
    rig.writer_cls.assert_called_once_with(rig.ao.out_stream, auto_start=False)
    rig.ai.start.assert_not_called()
    rig.ao.start.assert_not_called()


def test_ai_and_ao_coerced_to_different_rates_is_refused_and_tasks_closed(monkeypatch, specs):
    rig = Rig(monkeypatch, ai_rate=51200.0, ao_rate=51000.0)
    with pytest.raises(ConfigurationError, match="different rates"):
        NiDaqDevice().configure(specs[0], specs[1], 51200.0)
    rig.ai.close.assert_called_once_with()
    rig.ao.close.assert_called_once_with()


def test_start_writes_first_then_arms_ao_then_starts_ai(monkeypatch, specs):
    rig, dev = configured(monkeypatch, specs)
    with pytest.raises(ConfigurationError, match="before start"):
        dev.start()
    first = 0.5 * np.sin(np.linspace(0, 2 * np.pi, 5120))
    dev.write(first)
    dev.write(first)
    dev.start()
    assert rig.order() == ["write", "write", "ao_start", "ai_start"]
    np.testing.assert_array_equal(rig.written[0], first)
    rig.writer.write_many_sample.assert_called_with(mock.ANY, timeout=10.0)
    assert dev.running


def test_read_fills_a_preallocated_float64_block_in_channel_order(monkeypatch, specs):
    rig, dev = configured(monkeypatch, specs)
    expected = np.arange(3 * 5120, dtype=float).reshape(3, 5120)

    def fill(data, number_of_samples_per_channel=-1, timeout=10.0):
        assert data.dtype == np.float64 and data.shape == (3, number_of_samples_per_channel)
        data[:] = expected[:, :number_of_samples_per_channel]
        return number_of_samples_per_channel

    rig.reader.read_many_sample.side_effect = fill
    dev.write(np.zeros(5120))
    dev.start()
    block = dev.read()
    np.testing.assert_array_equal(block, expected)
    rig.reader.read_many_sample.assert_called_once_with(
        mock.ANY, number_of_samples_per_channel=5120, timeout=10.0
    )
    assert [s.name for s in dev.input_channels] == ["force", "active_shroud_accel", "passive_shroud_accel"]
    small = dev.read(100, timeout=2.0)
    assert small.shape == (3, 100)
    rig.reader.read_many_sample.assert_called_with(mock.ANY, number_of_samples_per_channel=100, timeout=2.0)


RAMP = 2560  # 50 ms (the default rig's abort_ramp_time) at 51.2 kS/s
ZEROS = 512  # 10 ms of zeros after the ramp


def check_stop_ramp(tail: np.ndarray, last: float, n_ramp: int = RAMP) -> None:
    """A stop tail: ``n_ramp`` samples from ``last`` down to exactly 0 V (raised cosine, monotone,
    never overshooting), then zeros. Reference: the ramp's first sample is the last written one
    times (1 + cos(pi / n)) / 2, i.e. within pi^2 / (4 n^2) of it."""
    assert tail.size == n_ramp + ZEROS
    ramp = tail[:n_ramp]
    assert ramp[0] == pytest.approx(last, rel=np.pi**2 / (4 * n_ramp**2) * 1.01, abs=1e-15)
    assert ramp[-1] == 0.0 and np.all(tail[n_ramp:] == 0.0)
    mag = ramp * np.sign(last) if last else ramp  # |drive|, same sign throughout
    assert np.all(np.diff(mag) <= 0.0) and np.all(mag >= 0.0)
    # no step: the largest change per sample is the raised cosine's steepest, pi/2 |last| / n
    assert np.max(np.abs(np.diff(np.concatenate([[last], ramp])))) <= np.pi / 2 * abs(last) / n_ramp * 1.0001


@pytest.mark.parametrize(
    "code, fault",
    [
        (-200279, SamplesNoLongerAvailable),
        (-200010, InputOverflow),
        (-200284, ReadTimeout),
        (-200999, DaqFault),
    ],
)
def test_input_faults_ramp_the_still_running_drive_to_zero_then_stop(monkeypatch, specs, code, fault):
    """AI faults leave AO generating: the stop ramp is appended, waited for, then AO and AI stop."""
    rig, dev = configured(monkeypatch, specs, idle_zero_supported=False)
    rig.reader.read_many_sample.side_effect = DaqReadError(
        "Attempted to read samples that are no longer available.\nMore text", code, samps_per_chan_read=7
    )
    dev.write(np.full(5120, 0.3))
    dev.start()
    with pytest.raises(fault) as info:
        dev.read()
    err = info.value
    assert type(err) is fault
    assert "\n" not in str(err) and f"DAQmx {code}" in str(err) and err.code == code
    assert str(err).startswith(fault.fault)
    assert err.partial.shape == (3, 7)  # samples read before the fault kept
    check_stop_ramp(rig.written[-1], 0.3)
    order = rig.order()
    assert order[order.index("ai_start") + 1 :] == ["generated", "write", "generated", "ao_stop", "ai_stop"]
    # the device stops on its own 0 V sample; the on-demand task still confirms 0 V
    rig.zero.write.assert_called_once_with(0.0, auto_start=True)
    assert not dev.running
    dev.close()
    rig.ai.close.assert_called_once_with()
    rig.ao.close.assert_called_once_with()
    assert rig.task_cls.call_count == 3  # no second zero task on close


@pytest.mark.parametrize("code", [-200016, -200621, -200018, -200290])
def test_underflow_on_read_means_ao_stopped_so_no_ramp_and_zero_on_demand(monkeypatch, specs, code):
    rig, dev = configured(monkeypatch, specs, idle_zero_supported=False)
    rig.reader.read_many_sample.side_effect = DaqReadError("Output underflow", code, samps_per_chan_read=0)
    dev.write(np.full(5120, 0.3))
    dev.start()
    with pytest.raises(OutputUnderflow, match=f"DAQmx {code}") as info:
        dev.read()
    assert info.value.partial is None
    order = rig.order()
    assert order[order.index("ai_start") + 1 :] == ["ao_stop", "ai_stop"]
    assert len(rig.written) == 1  # nothing written to a failed task
    rig.zero.ao_channels.add_ao_voltage_chan.assert_called_once_with(
        "Dev1/ao0", min_val=-10.0, max_val=10.0, units=VoltageUnits.VOLTS
    )
    rig.zero.write.assert_called_once_with(0.0, auto_start=True)
    dev.close()
    assert rig.order()[-2:] == ["ao_close", "ai_close"] and rig.task_cls.call_count == 3


def test_write_underflow_is_mapped_and_relies_on_idle_zero_volts(monkeypatch, specs):
    rig, dev = configured(monkeypatch, specs)
    dev.write(np.zeros(5120))
    dev.start()
    rig.writer.write_many_sample.side_effect = [
        DaqWriteError("Output underflow", -200621, samps_per_chan_written=0),
        5120,
    ]
    with pytest.raises(OutputUnderflow, match="DAQmx -200621"):
        dev.write(np.zeros(5120))
    rig.ao.stop.assert_called_once_with()
    rig.ai.stop.assert_called_once_with()
    assert rig.writer.write_many_sample.call_count == 2  # the failed write only; no ramp after it
    assert rig.task_cls.call_count == 2  # idle behaviour is 0 V: no zero task


def test_stop_appends_the_ramp_from_the_last_sample_waits_for_it_then_stops_ao_then_ai(monkeypatch, specs):
    """Normal stop in mid-sine: the tail starts at the last written sample (-0.73 V), 2560
    samples (0.05 s x 51.2 kS/s) to exactly 0 V, 512 zeros; the device reports the samples
    generated so far three times before all of them are out; the sleeps ask for no more than the
    5 ms poll and never more than what is left to play."""
    rig, dev = configured(monkeypatch, specs)
    block = 0.8 * np.sin(2 * np.pi * 60 * np.arange(5120) / 51200.0 + 2.0)
    block[-1] = -0.73
    dev.write(block)
    dev.write(block)
    dev.start()
    written = 2 * 5120 + RAMP + ZEROS
    rig.generated.side_effect = [6000, 7000, 9000, written - 100, written]
    dev.stop()
    assert len(rig.written) == 3
    write = rig.writer.write_many_sample.call_args_list[-1]
    check_stop_ramp(write.args[0], -0.73)
    # timeout: what was queued (10240 - 6000) plus the tail, in s, plus the 0.5 s margin
    assert write.kwargs["timeout"] == pytest.approx((10240 - 6000 + RAMP + ZEROS) / 51200 + 0.5)
    assert rig.order()[-8:] == [
        "generated",
        "write",
        "generated",
        "generated",
        "generated",
        "generated",
        "ao_stop",
        "ai_stop",
    ]
    assert rig.sleeps == [0.005, 0.005, pytest.approx(100 / 51200.0)]
    assert not dev.running
    dev.stop()  # idempotent: nothing more written
    assert len(rig.written) == 3
    # the AO host buffer bounds the queue: buffer + ramp within 0.1 s
    assert dev.output_queue_limit == 2304
    assert dev.time_to_zero() == pytest.approx((2304 + RAMP) / 51200.0) and dev.time_to_zero() <= 0.1


def test_ramp_time_is_configurable_up_to_a_tenth_of_a_second(monkeypatch, specs):
    rig = Rig(monkeypatch)
    dev = NiDaqDevice(abort_ramp_time=0.1)
    dev.configure(specs[0], specs[1], 51200.0)
    dev.write(np.full(5120, 2.0))
    dev.start()
    dev.stop()
    check_stop_ramp(rig.written[-1], 2.0, n_ramp=5120)
    for bad in (0.0, 0.11, -0.05):
        with pytest.raises(ConfigurationError, match="abort ramp time"):
            NiDaqDevice(abort_ramp_time=bad)


def test_wait_for_the_ramp_is_bounded(monkeypatch, specs):
    """A device whose generated count stalls: the wait gives up after the queued samples plus
    the tail plus the 0.5 s margin, and AO/AI are stopped anyway."""
    rig, dev = configured(monkeypatch, specs)
    dev.write(np.full(5120, 1.0))
    dev.start()
    rig.generated.side_effect = None
    rig.generated.return_value = 100
    dev.stop()
    budget = (5120 - 100 + RAMP + ZEROS) / 51200.0 + 0.5
    assert budget < sum(rig.sleeps) <= budget + 0.0051
    assert rig.order()[-2:] == ["ao_stop", "ai_stop"]


def test_ctrl_c_during_the_wait_still_stops_both_tasks_and_zeroes(monkeypatch, specs):
    rig, dev = configured(monkeypatch, specs, idle_zero_supported=False)
    dev.write(np.full(5120, 1.0))
    dev.start()
    rig.generated.side_effect = [0, 10, 20]

    def interrupted(seconds):
        raise KeyboardInterrupt

    monkeypatch.setattr(nidaq, "_sleep", interrupted)
    with pytest.raises(KeyboardInterrupt):
        dev.stop()
    assert rig.order()[-2:] == ["ao_stop", "ai_stop"]
    rig.zero.write.assert_called_once_with(0.0, auto_start=True)
    assert not dev.running


def test_task_failing_at_the_ramp_write_is_stopped_without_waiting(monkeypatch, specs):
    rig, dev = configured(monkeypatch, specs)
    dev.write(np.full(5120, 1.0))
    dev.start()
    rig.writer.write_many_sample.side_effect = DaqWriteError(
        "Output underflow", -200290, samps_per_chan_written=0
    )
    dev.stop()
    assert rig.order()[-4:] == ["generated", "write", "ao_stop", "ai_stop"]
    assert rig.sleeps == []


def test_non_finite_samples_and_overload_are_faults_with_the_block_kept(monkeypatch, specs):
    rig, dev = configured(monkeypatch, specs)

    def nan_on_accel(data, number_of_samples_per_channel=-1, timeout=10.0):
        data[:] = 1.0
        data[1, 10] = np.nan
        return number_of_samples_per_channel

    rig.reader.read_many_sample.side_effect = nan_on_accel
    dev.write(np.zeros(5120))
    dev.start()
    with pytest.raises(InvalidSamples, match="active_shroud_accel") as info:
        dev.read()
    assert info.value.partial.shape == (3, 5120)
    rig.ao.stop.assert_called_once_with()

    rig2, dev2 = configured(monkeypatch, specs)
    rig2.reader.read_many_sample.side_effect = lambda data, **kw: data.fill(0.0)
    rig2.ai.in_stream.overloaded_chans_exist = True
    rig2.ai.in_stream.overloaded_chans = ["force"]
    dev2.write(np.zeros(5120))
    dev2.start()
    with pytest.raises(SensorOverload, match="overload on force"):
        dev2.read()
    rig2.ai.stop.assert_called_once_with()


def test_drive_outside_range_or_not_finite_is_refused_before_writing(monkeypatch, specs):
    rig, dev = configured(monkeypatch, specs)
    with pytest.raises(LimitExceeded, match="outside the output range"):
        dev.write(np.array([0.0, 10.5]))
    with pytest.raises(LimitExceeded, match="NaN"):
        dev.write(np.array([0.0, np.nan]))
    with pytest.raises(LimitExceeded, match="1-D"):
        dev.write(np.zeros((2, 3)))
    rig.writer.write_many_sample.assert_not_called()


@pytest.mark.parametrize("how", ["normal", "exception", "ctrl-c"])
def test_context_manager_zeroes_stops_and_closes_on_every_exit_path(monkeypatch, specs, how):
    rig = Rig(monkeypatch)

    def run():
        with NiDaqDevice() as dev:
            dev.configure(specs[0], specs[1], 51200.0)
            dev.write(np.full(5120, 1.0))
            dev.start()
            if how == "exception":
                raise RuntimeError("procedure failed")
            if how == "ctrl-c":
                raise KeyboardInterrupt

    if how == "normal":
        run()
    else:
        with pytest.raises((RuntimeError, KeyboardInterrupt)):
            run()
    assert rig.order() == [
        "write",
        "ao_start",
        "ai_start",
        "generated",
        "write",
        "generated",
        "ao_stop",
        "ai_stop",
        "ao_close",
        "ai_close",
    ]
    check_stop_ramp(rig.written[-1], 1.0)
    assert rig.task_cls.call_count == 2  # idle behaviour = 0 V: no on-demand zero task needed


def test_close_without_start_closes_tasks_only(monkeypatch, specs):
    rig, dev = configured(monkeypatch, specs)
    dev.close()
    dev.close()  # idempotent
    assert rig.order() == ["ao_stop", "ai_stop", "ao_close", "ai_close"]
    assert rig.written == []


def test_filter_delays_add_up_to_the_input_to_output_delay(monkeypatch, specs):
    rig = Rig(monkeypatch)
    ai_all, ao_all = rig.ai.ai_channels.all, rig.ao.ao_channels.all
    type(ai_all).ai_filter_delay = mock.PropertyMock(return_value=38.0)
    ai_all.ai_filter_delay_units = DigitalWidthUnits.SAMPLE_CLOCK_PERIODS
    type(ao_all).ao_filter_delay = mock.PropertyMock(return_value=1.0e-4)
    ao_all.ao_filter_delay_units = DigitalWidthUnits.SECONDS
    dev = NiDaqDevice()
    dev.configure(specs[0], specs[1], 51200.0)
    # 38 sample periods at 51.2 kS/s plus 0.1 ms
    assert dev.input_to_output_delay() == pytest.approx(38 / 51200.0 + 1e-4, rel=1e-12)


def test_without_driver_one_line_suggests_simulated_rig(monkeypatch, specs):
    for exc in (
        DaqNotFoundError("Could not find an installation of NI-DAQmx."),
        DaqNotSupportedError("NI-DAQmx not supported on this device or platform."),
    ):
        monkeypatch.setattr(nidaq.nidaqmx, "Task", mock.Mock(side_effect=exc))
        with pytest.raises(DriverUnavailable) as info:
            NiDaqDevice().configure(specs[0], specs[1], 51200.0)
        assert "\n" not in str(info.value) and "--backend sim" in str(info.value)


def test_on_this_machine_without_nidaqmx_the_real_call_says_unavailable(specs):
    try:
        _ = nidaqmx.system.System.local().driver_version  # raises without the NI driver
    except (DaqNotFoundError, DaqNotSupportedError):
        pass
    else:  # pragma: no cover - only on a machine with NI-DAQmx
        pytest.skip("NI-DAQmx is installed here")
    with pytest.raises(DriverUnavailable, match="NI-DAQmx driver not found"):
        NiDaqDevice().configure(specs[0], specs[1], 51200.0)
