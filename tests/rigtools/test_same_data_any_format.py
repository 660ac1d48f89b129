"""The same measurement must import the same whatever file format carried it (issue 29, item 7).

One force record (N) and one acceleration record (g), drawn by hypothesis (length, sample rate,
values), are written by the field's own writers -- a TDMS file with npTDMS, a LabVIEW
measurement (``.lvm``) text as LabVIEW lays it out, a UFF 58 file with pyuff -- and each is
imported with ``rig import``. The three recordings hold the same arrays in SI (the acceleration
times 9.80665), the same units and quantities, the same excitation and the same sample rate,
each within what its format wrote:

- TDMS stores float64 samples and the time step: the arrays are equal to round-off of the g
  conversion (one multiplication: 2 ulp); the rate exactly.
- the LVM text here writes 8 significant digits (``%.7E``, decimal comma): 5e-8 relative per
  sample (half a unit in the 8th digit), plus the conversion;
- UFF 58 ASCII double writes 12 significant digits (``%20.11e``): 5e-12 relative per sample; its
  time step is written with 6 (``%13.5e``), so the rate holds to 5e-6 relative.
"""

from __future__ import annotations

import gzip
import tempfile
from pathlib import Path

import numpy as np
import pyuff
from cli_helpers import run_cli
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

from rigtools.recording import open_recording

G = 9.80665
RATES = [1000.0, 1024.0, 2048.0, 2560.0, 4096.0, 5000.0, 10000.0, 12800.0, 25600.0, 51200.0]


def _tdms(path, force, acc, rate) -> None:
    props = {"wf_increment": 1.0 / rate, "wf_start_offset": 0.0}
    with TdmsWriter(str(path)) as w:
        w.write_segment(
            [
                RootObject({"name": "hammer test"}),
                GroupObject("Test"),
                ChannelObject("Test", "Force", force, properties={**props, "unit_string": "N"}),
                ChannelObject("Test", "Acceleration", acc, properties={**props, "unit_string": "g"}),
            ]
        )


def _lvm(path, force, acc, rate) -> None:
    """LabVIEW's LVM layout (Writer_Version 2, one X column, decimal comma, 8 digits)."""

    def c(v: float) -> str:
        return f"{v:.7E}".replace(".", ",")

    head = ["LabVIEW Measurement\t", "Writer_Version\t2", "Reader_Version\t2", "Separator\tTab"]
    head += ["Decimal_Separator\t,", "Multi_Headings\tYes", "X_Columns\tOne", "Time_Pref\tRelative"]
    head += ["Operator\ttest", "***End_of_Header***\t", ""]
    body = [
        "Channels\t2\t\t",
        f"Samples\t{force.size}\t{force.size}\t",
        "Y_Unit_Label\tNewtons\tg\t",
        "X_Dimension\tTime\tTime\t",
        "X0\t0,0000000000000000E+0\t0,0000000000000000E+0\t",
        f"Delta_X\t{c(1.0 / rate)}\t{c(1.0 / rate)}\t",
        "***End_of_Header***\t",
        "X_Value\tForce\tAcceleration\tComment",
    ]
    body += [f"{c(i / rate)}\t{c(f)}\t{c(a)}" for i, (f, a) in enumerate(zip(force, acc, strict=True))]
    path.write_bytes(gzip.compress(("\n".join(head + body) + "\n").encode()))


def _uff(path, force, acc, rate) -> None:
    """Two UFF 58 time records (function type 1), ASCII double, written by pyuff."""
    records = []
    for node, name, data, units, spec in ((1, "Force", force, "N", 13), (2, "Acceleration", acc, "g", 12)):
        records.append(
            pyuff.prepare_58(
                binary=0,
                id1=f"{name} time",
                id2="analyser",
                id3="",
                id4="",
                id5="",
                func_type=1,
                rsp_ent_name=name,
                rsp_node=node,
                rsp_dir=3,
                ref_ent_name="NONE",
                ref_node=0,
                ref_dir=0,
                ord_data_type=4,
                num_pts=data.size,
                abscissa_spacing=1,
                abscissa_min=0.0,
                abscissa_inc=1.0 / rate,
                abscissa_spec_data_type=17,
                abscissa_axis_units_lab="s",
                ordinate_spec_data_type=spec,
                ordinate_axis_units_lab=units,
                orddenom_spec_data_type=0,
                z_axis_spec_data_type=0,
                data=np.asarray(data, float),
                x=np.arange(data.size) / rate,
            )
        )
    pyuff.UFF(str(path)).write_sets(records, "add")


def _read(path) -> dict:
    """``{quantity: (SI units, samples, sample rate, is the excitation)}`` of the one point."""
    with open_recording(path) as rec:
        (p,) = rec.points
        ref = p.params.get("reference_channel")
        return {
            c.quantity: (c.units, np.asarray(c[:], float), float(p.sample_rate), name == ref)
            for name, c in p.channels.items()
        }


# no shrinking: each example writes and imports three files (a failure shows its example as drawn)
@settings(
    max_examples=6,
    deadline=None,
    phases=(Phase.explicit, Phase.reuse, Phase.generate),
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    n=st.integers(min_value=64, max_value=1500),
    rate=st.sampled_from(RATES),
    seed=st.integers(min_value=0, max_value=2**32 - 1),
    scale=st.floats(min_value=1e-3, max_value=1e3),
)
def test_tdms_lvm_and_uff_of_the_same_data_import_alike(tmp_path, n, rate, seed, scale):
    rng = np.random.default_rng(seed)
    force, acc = scale * rng.standard_normal(n), rng.standard_normal(n)
    got = {}
    folder = Path(tempfile.mkdtemp(dir=tmp_path))  # one per example (pyuff appends to a file)
    for kind, write, suffix in (("tdms", _tdms, "tdms"), ("lvm", _lvm, "lvm.gz"), ("uff", _uff, "uff")):
        src, out = folder / f"data.{suffix}", folder / f"{kind}.h5"
        write(src, force, acc, rate)
        code, _, err = run_cli(["import", kind, str(src), str(out)])
        assert code == 0, (kind, err)
        got[kind] = _read(out)
    written = {"tdms": 2e-16, "lvm": 5e-8, "uff": 5e-12}  # relative precision of each file's samples
    rate_written = {"tdms": 1e-15, "lvm": 5e-8, "uff": 5e-6}
    for kind, channels in got.items():
        assert sorted(channels) == ["acceleration", "force"], (kind, channels.keys())
        units, f, f_rate, f_ref = channels["force"]
        a_units, a, a_rate, a_ref = channels["acceleration"]
        assert (units, a_units, f_ref, a_ref) == ("N", "m/s^2", True, False), kind
        tol = written[kind] + 4e-16  # the file's digits, and the g conversion's round-off
        np.testing.assert_allclose(f, force, rtol=tol, atol=0, err_msg=kind)
        np.testing.assert_allclose(a, acc * G, rtol=tol, atol=0, err_msg=kind)
        assert abs(f_rate / rate - 1) <= rate_written[kind] and a_rate == f_rate, (kind, f_rate, rate)
