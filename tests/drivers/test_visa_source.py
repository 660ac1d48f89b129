"""The 33500-series SCPI driver against the pyvisa-sim instrument shipped as package data.

The simulator (drivers/data/function_generator_sim.yaml) queues SCPI errors for refused commands
as the real instrument does; the driver must turn them into exceptions. Values read back are
compared with what was set (the simulator formats them as +d.dddddddddddddE+xx, so they round-trip
to at least 1e-12 relative).
"""

from __future__ import annotations

import pytest
import pyvisa

from rigtools.drivers.contracts import DriverUnavailable, LimitExceeded, SignalSourceError, SourceLimits
from rigtools.drivers.visa_source import (
    SIMULATED_RESOURCE,
    WaveformGenerator,
    open_resource_manager,
    simulator_backend,
    simulator_path,
)

LIMITS = SourceLimits(frequency_min=1.0, frequency_max=2000.0, amplitude_max_vpp=2.0)


@pytest.fixture
def rm():
    manager = pyvisa.ResourceManager(simulator_backend())
    yield manager
    manager.close()


@pytest.fixture
def gen(rm):
    with WaveformGenerator(SIMULATED_RESOURCE, LIMITS, resource_manager=rm) as g:
        yield g


def test_simulator_ships_as_package_data_and_lists_the_generator(rm):
    assert simulator_path().is_file()
    assert SIMULATED_RESOURCE in rm.list_resources()


def test_identifies_with_explicit_terminations(gen):
    assert gen.identify().startswith("Keysight Technologies,33521B")
    assert gen._inst.read_termination == "\n" and gen._inst.write_termination == "\n"
    assert gen.errors() == []


def test_sine_settings_round_trip(gen):
    gen.reset()
    gen.configure_sine(60.0, 1.25)
    gen.set_output(True)
    state = gen.state()
    assert state.function == "SIN"
    assert state.frequency == pytest.approx(60.0, rel=1e-12)
    assert state.amplitude_vpp == pytest.approx(1.25, rel=1e-12)
    assert state.offset == 0.0
    assert state.output_on is True
    gen.set_frequency(361.9)
    assert gen.state().frequency == pytest.approx(361.9, rel=1e-12)
    gen.set_output(False)
    assert gen.state().output_on is False


@pytest.mark.parametrize(
    "call, value, text",
    [
        ("set_frequency", 2500.0, "frequency 2500.0 Hz is outside"),
        ("set_frequency", 0.5, "outside the allowed 1..2000 Hz"),
        ("set_frequency", float("nan"), "frequency nan"),
        ("set_amplitude", 2.5, "amplitude 2.5 Vpp is outside"),
        ("set_amplitude", 0.0, "amplitude 0.0 Vpp"),
        ("set_amplitude", -1.0, "amplitude -1.0 Vpp"),
    ],
)
def test_limits_are_enforced_before_sending(gen, monkeypatch, call, value, text):
    sent = []
    monkeypatch.setattr(gen._inst, "write", lambda cmd: sent.append(cmd))
    with pytest.raises(LimitExceeded, match=text):
        getattr(gen, call)(value)
    assert sent == []


def test_simulator_error_response_raises(rm):
    # limits wider than the instrument's 10 Vpp: the driver sends, the instrument refuses
    wide = SourceLimits(frequency_min=1.0, frequency_max=2000.0, amplitude_max_vpp=50.0)
    with WaveformGenerator(SIMULATED_RESOURCE, wide, resource_manager=rm) as g:
        g.set_amplitude(1.0)
        with pytest.raises(SignalSourceError, match=r"'VOLT 30.000000' refused: -100 Command error"):
            g.set_amplitude(30.0)
        assert g.state().amplitude_vpp == pytest.approx(1.0)  # unchanged, queue drained
        with pytest.raises(SignalSourceError, match="refused: -100"):
            g._send("FUNC WOBBLE")
        assert g.errors() == []


def test_error_string_as_a_reply_raises(gen, monkeypatch):
    monkeypatch.setattr(gen._inst, "query", lambda cmd: '-113,"Undefined header"')
    with pytest.raises(SignalSourceError, match="answered with an error"):
        gen.state()
    monkeypatch.setattr(gen._inst, "query", lambda cmd: "ERROR")
    with pytest.raises(SignalSourceError, match="answered with an error"):
        gen._query_float("FREQ?")


def test_exit_turns_the_output_off_even_on_error(rm):
    with pytest.raises(RuntimeError), WaveformGenerator(SIMULATED_RESOURCE, LIMITS, resource_manager=rm) as g:
        g.configure_sine(60.0, 1.0)
        g.set_output(True)
        raise RuntimeError("procedure failed")
    # the simulated instrument keeps its state between sessions: reopen and look
    with WaveformGenerator(SIMULATED_RESOURCE, LIMITS, resource_manager=rm) as g2:
        assert g2.state().output_on is False
    g.close()  # idempotent


def test_unknown_resource_and_missing_visa_library_say_so_in_one_line(rm):
    # pyvisa-sim opens any well-formed name and answers nothing; a real VISA raises on open
    with pytest.warns(UserWarning), pytest.raises(SignalSourceError, match="not a 33500/33600"):
        WaveformGenerator("TCPIP0::10.0.0.9::inst0::INSTR", LIMITS, resource_manager=rm, timeout=0.2)
    with pytest.raises(DriverUnavailable, match="cannot open VISA resource 'nonsense'"):
        WaveformGenerator("nonsense", LIMITS, resource_manager=rm)
    try:
        pyvisa.ResourceManager("").close()
    except (ValueError, OSError):
        with pytest.raises(DriverUnavailable, match="no VISA library available") as info:
            open_resource_manager("")
        assert "\n" not in str(info.value)
    else:  # pragma: no cover - machine with a VISA library
        pytest.skip("a VISA library is installed here")
