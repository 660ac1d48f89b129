"""The front door: `import rigtools` is light and lazy, every public name is documented with an
Examples section, procedure parameters take quantity strings, and the reference page is the
models'."""

import subprocess
import sys
import typing

import pytest

import rigtools
from rigtools.errors import UserError
from rigtools.procedures import reference_table
from rigtools.procedures.base import validate
from rigtools.procedures.dwell import DwellParameters
from rigtools.procedures.reference import PROCEDURES, parameter_rows


def test_import_rigtools_loads_no_heavy_package():
    code = (
        "import sys, rigtools; heavy = [m for m in ('numpy', 'scipy', 'h5py', 'pydantic', 'numba',"
        " 'rigtools.sim', 'rigtools.config') if m in sys.modules]; print(heavy)"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"


def test_import_rigtools_sim_loads_no_orchestration():
    code = (
        "import sys, rigtools.sim; print([m for m in sys.modules if m.startswith('rigtools.')"
        " and not m.startswith(('rigtools.sim', 'rigtools._checkout'))])"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"


@pytest.mark.parametrize("name", rigtools.__all__)
def test_every_public_name_resolves_and_has_numpy_docstring_with_examples(name):
    obj = getattr(rigtools, name)
    doc = obj.__doc__ or ""
    assert doc.strip(), name
    if callable(obj) and not isinstance(obj, type):
        assert "Examples\n" in doc and ">>>" in doc, f"{name}: no Examples section"
    assert name in dir(rigtools)


def test_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        rigtools.nothing  # noqa: B018 - the look-up is the test


def test_quantity_strings_equal_si_floats_and_bad_ones_name_parameter_and_unit():
    a = validate(DwellParameters, fe="60 Hz", force="15 N", gap="0.5 mm", control={"initial_drive": "2 Vpp"})
    b = validate(DwellParameters, fe=60.0, force=15.0, gap=5e-4, control={"initial_drive": 1.0})
    assert a == b
    with pytest.raises(
        UserError, match=r"^fe = '30 kHz': outside the allowed range \(0, 25000\] Hz \(= 30000 Hz\)$"
    ):
        validate(DwellParameters, fe="30 kHz", force=1)
    with pytest.raises(UserError, match=r"^gap = 0.5: outside the allowed range \[0, 0.05\] m"):
        validate(DwellParameters, fe=60, force=1, gap=0.5)
    with pytest.raises(UserError, match=r"^fe = '60 kg': '60 kg' is a mass, expected a frequency$"):
        validate(DwellParameters, fe="60 kg", force=1)


def test_front_door_refuses_a_bad_quantity_before_touching_the_rig(tmp_path):
    with pytest.raises(UserError, match=r"^force = '15 Hz': '15 Hz' is a frequency, expected a force$"):
        rigtools.dwell("60 Hz", "15 Hz", tmp_path / "d.h5", backend="sim")
    assert not (tmp_path / "d.h5").exists()
    with pytest.raises(UserError, match="backend = 'usb'"):
        rigtools.dwell("60 Hz", "15 N", tmp_path / "d.h5", backend="usb")


def test_reference_table_lists_every_parameter_of_every_model_with_unit_default_and_range():
    text = reference_table()
    for _title, model, _function, _command in PROCEDURES:
        rows = parameter_rows(model)
        assert [r["name"] for r in rows] == list(model.model_fields)
        for r in rows:
            line = f"| {r['name']} | {r['unit']} | {r['default']} | {r['range']} | {r['description']} |"
            assert line in text
    # spot checks against the models' own numbers, independent of the renderer
    dwell = {r["name"]: r for r in parameter_rows(DwellParameters)}
    assert (dwell["fe"]["unit"], dwell["fe"]["range"], dwell["fe"]["default"]) == (
        "Hz",
        "(0, 25000]",
        "required",
    )
    assert (dwell["gap"]["unit"], dwell["gap"]["range"], dwell["gap"]["default"]) == (
        "m",
        "[0, 0.05]",
        "None",
    )
    assert dwell["record_periods"]["default"] == "60"
    control = {r["name"]: r for r in parameter_rows(PROCEDURES[-1][1])}
    assert control["initial_drive"]["unit"] == "V peak" and control["control_ramp"]["unit"] == "s"
    tap = {r["name"]: r for r in parameter_rows(PROCEDURES[4][1])}
    assert tap["blade"]["range"] == "active, passive" and tap["position"]["unit"] == "m"
    # every quantity-typed field of the models shows its unit
    for _title, model, _f, _c in PROCEDURES:
        for r in parameter_rows(model):
            hints = typing.get_type_hints(model, include_extras=True)[r["name"]]
            if "quantity_validator" in repr(hints) or "parse" in repr(hints):
                assert r["unit"], (model.__name__, r["name"])
