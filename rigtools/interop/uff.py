"""UFF (universal file format) dataset 58 export with pyuff: time records, spectra, FRFs and
coherence, each with its function type, node and direction numbers and unit exponents.

Node and direction numbering (one numbering for every export, documented in ``rig export --help``):

=====================  ====  =================================================
channel                node  where
=====================  ====  =================================================
``force``              1     active blade, force sensor (the FRF reference)
``active_shroud_*``    2     active blade shroud (tip)
``passive_shroud_*``   3     passive blade shroud (tip)
``drive``              100   drive voltage to the shaker amplifier
anything else          101+  in channel order
=====================  ====  =================================================

Direction 2 (+Y) for every channel: the blades' thin (impact) direction, the axis the sensors
measure (``rigtools.sim.params``: x along the blade, y thin). A UFF file is in SI (a dataset 164 with units
code 1, m/N/s/K, comes first); the exponents of each 58 record say what the ordinate is: length 1
for displacement, velocity and acceleration (the specific data type tells which), force 1 for
force, doubled for auto spectra (units squared); an FRF carries the response in the numerator and the force in the denominator record.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

# UFF 58 function types (record 6, field 1)
FUNC_TIME, FUNC_AUTO_SPECTRUM, FUNC_FRF, FUNC_COHERENCE = 1, 2, 4, 6  # the types pyuff writes
# specific data types (records 8-10, field 1)
DATA_UNKNOWN, DATA_GENERAL, DATA_DISPLACEMENT, DATA_VELOCITY, DATA_ACCELERATION = 0, 1, 8, 11, 12
DATA_FORCE, DATA_TIME, DATA_FREQUENCY = 13, 17, 18
# quantity -> (specific data type, length exponent, force exponent)
QUANTITY_CODES = {
    "acceleration": (DATA_ACCELERATION, 1, 0),
    "velocity": (DATA_VELOCITY, 1, 0),
    "displacement": (DATA_DISPLACEMENT, 1, 0),
    "force": (DATA_FORCE, 0, 1),
    "voltage": (DATA_GENERAL, 0, 0),
}
FIXED_NODES = {"force": 1, "drive": 100}
DIRECTION_Y = 2
SI_UNITS_CODE = 1


def node_of(channel: str, order: int) -> int:
    """The UFF node number of a channel (see the module docstring); ``order`` is its position."""
    if channel in FIXED_NODES:
        return FIXED_NODES[channel]
    if channel.startswith("active_shroud"):
        return 2
    if channel.startswith("passive_shroud"):
        return 3
    return 101 + order


@dataclass(frozen=True)
class UffFunction:
    """One UFF 58 function: what it is, where, and its values.

    Attributes
    ----------
    func_type
        :data:`FUNC_TIME`, :data:`FUNC_SPECTRUM`, :data:`FUNC_FRF`, :data:`FUNC_COHERENCE`, ...
    description
        ID line 1 (80 characters at most are kept by the format).
    response, reference
        ``(channel name, node)`` of the response and of the reference (the force for FRFs; the
        response itself for time records and spectra).
    response_quantity, reference_quantity
        Keys of :data:`QUANTITY_CODES` (the reference's only matters for FRFs).
    x
        Abscissa: evenly spaced times (s) or frequencies (Hz).
    data
        Ordinate values: real, or complex for FRFs.
    units_label
        Ordinate units label, e.g. ``"m/s^2"`` or ``"m/s^2/N"``.
    """

    func_type: int
    description: str
    response: tuple[str, int]
    reference: tuple[str, int]
    response_quantity: str
    reference_quantity: str
    x: np.ndarray
    data: np.ndarray
    units_label: str
    date: str = ""

    def dataset(self) -> dict:
        """The pyuff dataset dict (every field of dataset 58 filled in)."""
        time_axis = self.func_type == FUNC_TIME
        num = QUANTITY_CODES.get(self.response_quantity, (DATA_UNKNOWN, 0, 0))
        den = QUANTITY_CODES.get(self.reference_quantity, (DATA_UNKNOWN, 0, 0))
        if self.func_type == FUNC_COHERENCE:
            num = den = (DATA_GENERAL, 0, 0)
        elif self.func_type == FUNC_AUTO_SPECTRUM:  # units squared
            num = (num[0], 2 * num[1], 2 * num[2])
        ratio = self.func_type == FUNC_FRF
        x = np.asarray(self.x, dtype=float)
        inc = float(x[1] - x[0]) if x.size > 1 else 0.0
        complex_data = np.iscomplexobj(self.data)
        return {
            "type": 58,
            "binary": 1,
            "id1": self.description[:80],
            "id2": "shrouded-blade-rig export",
            "id3": "",
            "id4": self.date[:80],
            "id5": "",
            "func_type": self.func_type,
            "ver_num": 0,
            "load_case_id": 0,
            "rsp_ent_name": self.response[0][:10],
            "rsp_node": self.response[1],
            "rsp_dir": DIRECTION_Y,
            "ref_ent_name": self.reference[0][:10],
            "ref_node": self.reference[1],
            "ref_dir": DIRECTION_Y,
            "ord_data_type": 6 if complex_data else 4,
            "num_pts": int(x.size),
            "abscissa_spacing": 1,
            "abscissa_min": float(x[0]) if x.size else 0.0,
            "abscissa_inc": inc,
            "z_axis_value": 0.0,
            "abscissa_spec_data_type": DATA_TIME if time_axis else DATA_FREQUENCY,
            "abscissa_len_unit_exp": 0,
            "abscissa_force_unit_exp": 0,
            "abscissa_temp_unit_exp": 0,
            "abscissa_axis_lab": "Time" if time_axis else "Frequency",
            "abscissa_axis_units_lab": "s" if time_axis else "Hz",
            "ordinate_spec_data_type": num[0],
            "ordinate_len_unit_exp": num[1],
            "ordinate_force_unit_exp": num[2],
            "ordinate_temp_unit_exp": 0,
            "ordinate_axis_lab": self.response_quantity[:20],
            "ordinate_axis_units_lab": self.units_label[:20],
            "orddenom_spec_data_type": den[0] if ratio else 0,
            "orddenom_len_unit_exp": den[1] if ratio else 0,
            "orddenom_force_unit_exp": den[2] if ratio else 0,
            "orddenom_temp_unit_exp": 0,
            "orddenom_axis_lab": self.reference_quantity[:20] if ratio else "",
            "orddenom_axis_units_lab": "N" if ratio else "",
            "z_axis_spec_data_type": 0,
            "z_axis_len_unit_exp": 0,
            "z_axis_force_unit_exp": 0,
            "z_axis_temp_unit_exp": 0,
            "z_axis_axis_lab": "",
            "z_axis_axis_units_lab": "",
            "data": np.asarray(self.data, dtype=complex if complex_data else float),
            "x": x,
        }


def units_dataset() -> dict:
    """The dataset 164 saying the file is in SI (m, N, s, K), as pyuff writes it."""
    return {
        "type": 164,
        "units_code": SI_UNITS_CODE,
        "units_description": "SI units",
        "temp_mode": 2,
        "length": 1.0,
        "force": 1.0,
        "temp": 1.0,
        "temp_offset": 273.15,
    }


def write_uff(path: str | Path, functions: list[UffFunction]) -> int:
    """Write the units dataset and ``functions`` as UFF 58 (binary, double precision) to ``path``.

    Returns the number of 58 datasets written. The file is written whole or not at all
    (:func:`rigtools.derived_files.atomic_write`; the caller checks that it may be replaced).
    """
    import pyuff

    from rigtools.derived_files import atomic_write

    sets = [units_dataset()] + [f.dataset() for f in functions]

    def write(tmp: Path) -> None:
        tmp.unlink()  # pyuff appends to a new file: the temporary file mkstemp made goes first
        pyuff.UFF(str(tmp)).write_sets(sets, "add", force_double=True)

    atomic_write(path, write)
    return len(functions)


WHAT = ("time", "spectra", "frf")


def recording_functions(
    recording,
    what: tuple[str, ...] = WHAT,
    *,
    frf_options=None,
    reference: str | None = None,
    complete_only: bool = False,
) -> list[UffFunction]:
    """The UFF functions of an open recording.

    Parameters
    ----------
    recording
        An open :class:`rigtools.recording.reader.Recording`.
    what
        Any of ``"frf"`` (H1 of every response over the force with its coherence: the very
        estimate ``rig analyze`` reports, :func:`rigtools.analyze.point_frf_estimate`, for the
        points it treats as broadband), ``"time"`` (every channel of every point) and
        ``"spectra"`` (auto spectra, RMS² per bin: half the square of the flattop
        peak-amplitude spectrum of :func:`rigtools.analysis.spectra.amplitude_spectrum`, so a
        sine of amplitude A reads A²/2). FRFs come first in the file, so a reader that takes
        the FRF kind from the first record (sdypy-EMA) reads them right.
    frf_options
        :class:`rigtools.analyze.FRFOptions` (estimate overrides), as ``rig analyze`` takes them.
    reference
        The excitation channel of the FRFs (default: the recording's force channel).
    complete_only
        Leave out points that did not end (a run cut off mid-point): never exported as data.

    Time records and spectra carry reference node 0 (they have no reference). ID line 4 holds
    the recording's date (``DD-MMM-YY HH:MM:SS``, UTC).
    """
    from rigtools.analysis.spectra import amplitude_spectrum
    from rigtools.analyze import PROCEDURE_FRF, point_frf_estimate

    procedure = str((recording.experiment or {}).get("procedure", ""))
    date = uff_date(getattr(recording, "created", ""))
    frfs: list[UffFunction] = []
    others: list[UffFunction] = []
    none = ("", 0)
    for point in recording.points:
        if complete_only and not point.complete:
            continue
        names = list(point.channels)
        n = point.n_samples
        if n < 2:
            continue
        label = f"point {point.index:04d}"
        for order, name in enumerate(names):
            ch = point.channels[name]
            where = (name, node_of(name, order))
            if "time" in what:
                others.append(
                    UffFunction(
                        FUNC_TIME,
                        f"{label} {name} time record",
                        where,
                        none,
                        ch.quantity,
                        "",
                        ch.t0 + np.arange(n) / ch.sample_rate,
                        ch[:n],
                        ch.units,
                        date,
                    )
                )
            if "spectra" in what:
                f, amp = amplitude_spectrum(ch[:n], ch.sample_rate)
                others.append(
                    UffFunction(
                        FUNC_AUTO_SPECTRUM,
                        f"{label} {name} auto spectrum, RMS^2 per bin (flattop)",
                        where,
                        none,
                        ch.quantity,
                        "",
                        f,
                        amp**2 / 2,
                        f"({ch.units})^2",
                        date,
                    )
                )
        broadband = point.sample_rate is not None and ("fe" not in point.params or procedure in PROCEDURE_FRF)
        if "frf" in what and broadband:
            if reference is not None and reference in point.channels:
                point = _with_force(point, reference)
            est, resp, force, method, _ = point_frf_estimate(point, options=frf_options)
            ref = point.channels[force]
            ref_where = (
                force,
                node_of("force", 0) if force == "force" else node_of(force, names.index(force)),
            )
            for i, name in enumerate(resp):
                ch = point.channels[name]
                where = (name, node_of(name, names.index(name)))
                text = method.describe(float(point.sample_rate))
                frfs.append(
                    UffFunction(
                        FUNC_FRF,
                        f"{label} H1 {name}/{force}; {text}",
                        where,
                        ref_where,
                        ch.quantity,
                        ref.quantity,
                        est.frequency_hz,
                        est.h1[i],
                        f"{ch.units}/{ref.units}",
                        date,
                    )
                )
                if est.n_averages > 1:
                    frfs.append(
                        UffFunction(
                            FUNC_COHERENCE,
                            f"{label} coherence {name}/{force}",
                            where,
                            ref_where,
                            "coherence",
                            "",
                            est.frequency_hz,
                            est.coherence[i],
                            "-",
                            date,
                        )
                    )
    return frfs + others


def uff_date(created: str) -> str:
    """ISO time (``2024-05-01T12:00:00+00:00``) as UFF's ``01-May-24 12:00:00``; empty if unreadable."""
    from datetime import datetime

    try:
        return datetime.fromisoformat(str(created)).strftime("%d-%b-%y %H:%M:%S")
    except ValueError:
        return ""


class _ForceNamed:
    """A point view whose force channel is ``name`` (``--reference``): the other force-quantity
    channels are left out of it."""

    def __init__(self, point, name: str) -> None:
        self._point = point
        self.channels = {c: ch for c, ch in point.channels.items() if c == name or ch.quantity != "force"}

    def __getattr__(self, attr):
        return getattr(self._point, attr)


def _with_force(point, name: str):
    return _ForceNamed(point, name)
