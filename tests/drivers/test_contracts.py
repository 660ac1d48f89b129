"""The hardware contract: channel specs, fault classes, and the exit paths of the context managers."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from rigtools.config import load_rig
from rigtools.drivers import contracts
from rigtools.drivers.contracts import (
    AcquisitionDevice,
    AmplifierTimeout,
    ConfigurationError,
    DaqFault,
    DriverError,
    DriverUnavailable,
    InputChannelSpec,
    InputOverflow,
    InvalidSamples,
    LimitExceeded,
    OutputChannelSpec,
    OutputUnderflow,
    SafetyAbort,
    SamplesNoLongerAvailable,
    SensorOverload,
    SignalSource,
    SourceLimits,
    SourceState,
)


def test_sensitivity_in_si_per_unit():
    # 10 mV/g = 0.010 V per 9.80665 m/s^2 (g by definition); 11.24 mV/N = 0.01124 V/N
    acc = InputChannelSpec("a", "Dev1/ai1", "accel", 10.0, "mV/g", 0.004, -4900, 4900)
    force = InputChannelSpec("f", "Dev1/ai0", "force", 11.24, "mV/N", 0.004, -200, 200)
    volt = InputChannelSpec("v", "Dev1/ai3", "voltage", 1.0, "V/V")
    assert acc.volts_per_unit == pytest.approx(0.010 / 9.80665, rel=1e-15)
    assert force.volts_per_unit == pytest.approx(0.01124, rel=1e-15)
    assert (acc.units, acc.quantity, force.units, force.quantity, volt.units) == (
        "m/s^2",
        "acceleration",
        "N",
        "force",
        "V",
    )
    assert acc.iepe and not volt.iepe


@pytest.mark.parametrize(
    "kwargs, text",
    [
        (dict(kind="strain"), "kind 'strain'"),
        (dict(sensitivity_units="mV/N"), "do not suit kind 'accel'"),
        (dict(sensitivity=0.0), "sensitivity 0.0"),
        (dict(excitation_current=0.05), "excitation current"),
        (dict(min_value=5.0, max_value=-5.0), "below"),
    ],
)
def test_bad_channel_specs_are_refused_in_one_line(kwargs, text):
    base = dict(
        name="a",
        physical_channel="Dev1/ai1",
        kind="accel",
        sensitivity=10.0,
        sensitivity_units="mV/g",
        excitation_current=0.004,
        min_value=-1.0,
        max_value=1.0,
    )
    with pytest.raises(ConfigurationError, match=text) as info:
        InputChannelSpec(**{**base, **kwargs})
    assert "\n" not in str(info.value)
    with pytest.raises(ConfigurationError, match="contain 0 V"):
        OutputChannelSpec(min_voltage=1.0, max_voltage=5.0)
    with pytest.raises(ConfigurationError):
        SourceLimits(frequency_min=10.0, frequency_max=5.0)


def test_specs_are_frozen_and_built_from_the_rig_file():
    cfg = load_rig()
    specs = cfg.daq.input_specs()
    assert [s.name for s in specs] == ["force", "active_shroud_accel", "passive_shroud_accel"]
    assert specs[0].sensitivity_units == "mV/N" and specs[1].sensitivity_units == "mV/g"
    assert specs[1].sensitivity == pytest.approx(10.0, rel=1e-12)
    with pytest.raises(AttributeError):
        specs[0].sensitivity = 1.0  # frozen
    out = cfg.daq.output_spec()
    assert (out.physical_channel, out.min_voltage, out.max_voltage) == ("Dev1/ao0", -10.0, 10.0)


@pytest.mark.parametrize(
    "cls, fault",
    [
        (InputOverflow, "input overflow"),
        (SamplesNoLongerAvailable, "samples no longer available"),
        (OutputUnderflow, "output underflow"),
        (AmplifierTimeout, "amplifier timeout"),
        (SensorOverload, "sensor overload"),
        (InvalidSamples, "invalid samples"),
        (SafetyAbort, "safety abort"),
    ],
)
def test_faults_name_themselves_in_one_line_and_keep_the_data(cls, fault):
    partial = np.ones((3, 7))
    err = cls("on Dev1/ai0 at block 12", partial=partial)
    assert str(err) == f"{fault}: on Dev1/ai0 at block 12"
    assert isinstance(err, DaqFault) and isinstance(err, DriverError)
    assert err.partial is partial
    assert str(cls()) == fault
    assert str(cls(f"{fault} twice")) == f"{fault} twice"  # no doubled prefix


def test_error_families():
    assert issubclass(DriverUnavailable, DriverError) and not issubclass(DriverUnavailable, DaqFault)
    assert issubclass(LimitExceeded, ValueError) and issubclass(ConfigurationError, ValueError)
    abort = SafetyAbort(
        "force peak 70 N reached the abort limit 60 N", channel="force", value=70.0, limit=60.0
    )
    assert (abort.channel, abort.value, abort.limit) == ("force", 70.0, 60.0)


class FakeDevice(AcquisitionDevice):
    """A minimal device that records what the shared context manager does."""

    backend = "fake"

    def __init__(self):
        self.log = []

    def configure(self, inputs, output, sample_rate, block_size=None):
        return sample_rate

    sample_rate = 1000.0
    block_size = 100
    input_channels = ()
    running = False

    def write(self, drive):
        self.log.append(("write", float(np.max(np.abs(drive)))))

    def start(self):
        self.log.append("start")

    def read(self, n_samples=None, timeout=10.0):
        raise InputOverflow("Dev1")

    def stop(self):
        self.log.append("stop")

    def close(self):
        self.log.append("close")

    def input_to_output_delay(self):
        return 0.0


@pytest.mark.parametrize("exc", [None, RuntimeError, KeyboardInterrupt, InputOverflow])
def test_acquisition_context_manager_closes_on_every_exit_path(exc):
    dev = FakeDevice()
    try:
        with dev as d:
            assert d is dev
            d.write(np.ones(10))
            d.start()
            if exc is InputOverflow:
                d.read()
            elif exc is not None:
                raise exc()
    except (RuntimeError, KeyboardInterrupt, InputOverflow):
        pass
    assert dev.log[-1] == "close"
    info = dev.info()
    assert (info.backend, info.sample_rate, info.block_size) == ("fake", 1000.0, 100)


def test_the_contracts_are_abstract_with_the_documented_methods():
    for cls, methods in [
        (
            AcquisitionDevice,
            {"configure", "write", "start", "read", "stop", "close", "input_to_output_delay"},
        ),
        (
            SignalSource,
            {"identify", "reset", "set_frequency", "set_amplitude", "set_output", "state", "errors", "close"},
        ),
    ]:
        assert cls.__abstractmethods__ == frozenset(methods)
        with pytest.raises(TypeError):
            cls()
    params = inspect.signature(AcquisitionDevice.configure).parameters
    assert list(params) == ["self", "inputs", "output", "sample_rate", "block_size"]
    assert SourceState("SIN", 60.0, 1.0, 0.0, True).output_on


def test_signal_source_exit_closes():
    closed = []

    class Source(SignalSource):
        limits = SourceLimits()
        identify = reset = set_frequency = set_amplitude = set_output = state = errors = lambda self, *a: None

        def close(self):
            closed.append(True)

    with pytest.raises(ValueError), Source():
        raise ValueError("boom")
    assert closed == [True]
    assert contracts.STANDARD_GRAVITY == 9.80665
