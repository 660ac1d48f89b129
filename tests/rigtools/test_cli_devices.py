"""``rig devices``: lists what it can, says in one line why not, exit 0 / 3 / 2."""

from __future__ import annotations

import json
from types import SimpleNamespace

import nidaqmx.system
import pytest
from nidaqmx.errors import DaqNotFoundError

from rigtools.cli import main


def ni_missing() -> bool:
    try:
        _ = nidaqmx.system.System.local().driver_version  # raises without the NI driver
    except DaqNotFoundError:
        return True
    return False


def fake_ni_system():
    chans = lambda prefix, n: [SimpleNamespace(name=f"{prefix}{i}") for i in range(n)]
    dev = SimpleNamespace(
        name="Dev1",
        product_type="NI 9234",
        serial_num=0x1A2B3C,
        ai_physical_chans=chans("Dev1/ai", 4),
        ao_physical_chans=[],
    )
    dev2 = SimpleNamespace(
        name="Dev2",
        product_type="NI 9260",
        serial_num=0xFF,
        ai_physical_chans=[],
        ao_physical_chans=chans("Dev2/ao", 2),
    )
    version = SimpleNamespace(major_version=2024, minor_version=3, update_version=0)
    return SimpleNamespace(driver_version=version, devices=[dev, dev2])


@pytest.mark.skipif(not ni_missing(), reason="NI-DAQmx is installed here")
def test_without_hardware_says_why_and_suggests_the_simulated_rig(capsys):
    code = main(["devices"])
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "NI-DAQmx: cannot list devices: NI-DAQmx driver not installed on this machine"
    assert out[1].startswith("VISA: ")  # listed, or one line saying why not
    assert "--backend sim" in out[-1]
    assert code == (0 if out[1].startswith("VISA (") else 3)


def test_lists_ni_devices_and_simulated_visa_resources(monkeypatch, capsys):
    monkeypatch.setattr(nidaqmx.system.System, "local", staticmethod(fake_ni_system))
    assert main(["devices", "--visa-backend", "simulated"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "NI-DAQmx 2024.3.0: 2 devices"
    assert out[1].split() == ["Dev1", "NI", "9234", "s/n", "1A2B3C", "AI", "4", "AO", "0"]
    assert out[2].split() == ["Dev2", "NI", "9260", "s/n", "FF", "AI", "0", "AO", "2"]
    assert out[3].startswith("VISA (") and out[3].endswith("2 resources")
    assert out[4].strip() == "TCPIP0::192.168.1.20::inst0::INSTR"
    assert not any("--backend sim" in line for line in out)


def test_json_output(monkeypatch, capsys):
    monkeypatch.setattr(nidaqmx.system.System, "local", staticmethod(fake_ni_system))
    assert main(["devices", "--json", "--visa-backend", "simulated"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["nidaqmx"]["available"] is True
    assert data["nidaqmx"]["devices"][0] == {
        "name": "Dev1",
        "product_type": "NI 9234",
        "serial_number": "1A2B3C",
        "ai_channels": ["Dev1/ai0", "Dev1/ai1", "Dev1/ai2", "Dev1/ai3"],
        "ao_channels": [],
    }
    assert data["visa"]["available"] is True and data["visa"]["reason"] is None
    assert "TCPIP0::192.168.1.20::inst0::INSTR" in data["visa"]["resources"]


def test_neither_backend_available_is_exit_3_with_reasons(monkeypatch, capsys):
    def no_driver():
        raise DaqNotFoundError("Could not find an installation of NI-DAQmx.")

    monkeypatch.setattr(nidaqmx.system.System, "local", staticmethod(no_driver))
    import pyvisa

    monkeypatch.setattr(
        pyvisa,
        "ResourceManager",
        lambda backend="": (_ for _ in ()).throw(
            ValueError("Could not locate a VISA implementation. Install either the IVI binary or pyvisa-py.")
        ),
    )
    assert main(["devices", "--json"]) == 3
    data = json.loads(capsys.readouterr().out)
    assert data["nidaqmx"]["reason"] == "NI-DAQmx driver not installed on this machine"
    assert data["visa"]["reason"].startswith("no VISA library available (Could not locate")
    assert main(["devices"]) == 3
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 3 and all(out)


def test_bad_backend_is_one_line_exit_2(capsys):
    assert main(["devices", "--visa-backend", "nonsense"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rig devices: error: --visa-backend 'nonsense'")


def test_missing_or_malformed_simulator_file_is_one_line(tmp_path, capsys):
    assert main(["devices", "--visa-backend", f"{tmp_path / 'nope.yaml'}@sim"]) == 2
    err = capsys.readouterr().err
    assert "no such file" in err and err.count("\n") == 1
    bad = tmp_path / "bad.yaml"
    bad.write_text('spec: "1.1"\ndevices: [\n')  # pyvisa-sim raises a yaml error
    main(["devices", "--json", "--visa-backend", f"{bad}@sim"])
    reason = json.loads(capsys.readouterr().out)["visa"]["reason"]
    assert "Could not parse definitions file" in reason and "Traceback" not in reason


def test_help_documents_exit_codes(capsys):
    with pytest.raises(SystemExit):
        main(["devices", "--help"])
    out = capsys.readouterr().out
    assert "Exit status: 0" in out and "3 neither" in out and "--backend sim" in out
