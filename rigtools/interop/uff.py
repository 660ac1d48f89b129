"""UFF (universal file format) dataset 58 export and import with pyuff. Export: time records, spectra, FRFs and
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
measure (``rigtools.sim.params``: x along the blade, y thin). A channel an import placed keeps
its place: the node, direction code, entity name and ID line 1 of the record it came from
(:mod:`rigtools.interop.uff_places`); another channel of an imported recording, one the table
does not name, gets node 101+ and direction 0 (none), said in one line. A UFF file is in SI (a dataset 164 with units
code 1, m/N/s/K, comes first); the exponents of each 58 record say what the ordinate is: length 1
for displacement, velocity and acceleration (the specific data type tells which), force 1 for
force, doubled for auto spectra (units squared); an FRF carries the response in the numerator and the force in the denominator record.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Unpack

import numpy as np

from rigtools.analysis.spectra import amplitude_spectrum
from rigtools.derived_files import atomic_write
from rigtools.errors import UserError, in_script_words
from rigtools.frf_set import RESPONSE_UNITS, FRFSet, is_frf_set, read_frf_set, write_frf_set
from rigtools.interop.channels import (
    ForeignChannel,
    check_known,
    check_names,
    resolve,
    si_units,
    storable_name,
)
from rigtools.interop.checks import (
    ImportKeywords,
    import_request,
    importer,
    non_finite_reason,
    parsed,
    source_file,
)
from rigtools.interop.directions import DIRECTIONS, direction_text
from rigtools.interop.imported import ForeignPoint, rows_reader, split_by_timing
from rigtools.interop.uff_data import (
    FRF_DATA_RULE,
    _with_force,
    code_against_label,
    coherence_text,
    cut_record,
    frf_kind_from_data,
    rate_of_increment,
    uff_date,
)
from rigtools.interop.uff_places import (  # the rig's numbering (node_of, FIXED_NODES) lives there
    DIRECTION_Y,
    channel_place,
    record_place,
    told_apart,
    unplaced_line,
)
from rigtools.recording import open_recording
from rigtools.recording.summary import left_out_lines
from rigtools.recording_analysis.broadband import PROCEDURE_FRF
from rigtools.recording_analysis.frf_estimate import point_frf_estimate
from rigtools.recording_analysis.results import frf_kind_of_units
from rigtools.recording_analysis.samples import force_channel
from rigtools.recording_analysis.tap_test import analyze_tap_test, is_hit_per_point_tap_test

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
SI_UNITS_CODE = 1
#: ID line 2 of every record ``rig export uff`` writes: the importer reads ID line 4 of such files
EXPORT_MARK = "shrouded-blade-rig export"
_NAME = r"[A-Za-z0-9_][A-Za-z0-9_.\-]*"  # a recording channel name (rigtools.recording.schema)
_ID_LINE_4 = re.compile(rf"channel ({_NAME})(?:; reference ({_NAME}))?")


def id_line_4(channel: str, reference: str = "") -> str:
    """ID line 4 of an exported record: ``channel NAME`` (``channel NAME; reference NAME`` for
    FRFs and coherence), the full channel names the 10-character entity names cut; ``""`` when a
    name is no channel name or the line would pass the format's 80 characters (the importer then
    names the record by entity, node and direction)."""
    line = f"channel {channel}" + (f"; reference {reference}" if reference else "")
    return line if len(line) <= 80 and _ID_LINE_4.fullmatch(line) else ""


def exported_names(s: dict) -> tuple[str, str] | None:
    """``(channel, reference)`` a record ``rig export uff`` wrote names in ID line 4
    (:func:`id_line_4`; reference ``""`` when none), or None for any other record."""
    if str(s.get("id2", "")).strip() != EXPORT_MARK:
        return None
    hit = _ID_LINE_4.fullmatch(str(s.get("id4", "")).strip())
    return (hit.group(1), hit.group(2) or "") if hit else None


@dataclass(frozen=True)
class UffFunction:
    """One UFF 58 function: what it is, where, and its values.

    Attributes
    ----------
    func_type
        :data:`FUNC_TIME`, :data:`FUNC_AUTO_SPECTRUM`, :data:`FUNC_FRF`, :data:`FUNC_COHERENCE`, ...
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
    date
        ID line 3, where dataset 58 keeps when the function was created (``DD-MMM-YY HH:MM:SS``,
        :func:`uff_date`).
    response_direction, reference_direction
        UFF direction codes (:data:`DIRECTIONS`: 1..6 for +X..+RZ, negative for the opposite
        sense, 0 scalar); +Y (the blades' impact direction) unless given.
    channel, reference_channel
        The full names of the response and reference channels (``""``: none), written to ID
        line 4 (:func:`id_line_4`) where the import names the record by them: the entity name
        fields keep 10 characters only, so ``active_shroud_accel`` and ``active_shroud_disp``
        (one node) read alike there.
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
    response_direction: int = DIRECTION_Y
    reference_direction: int = DIRECTION_Y
    channel: str = ""
    reference_channel: str = ""

    def __post_init__(self) -> None:
        for code in (self.response_direction, self.reference_direction):
            if not -len(DIRECTIONS) <= int(code) <= len(DIRECTIONS):
                raise ValueError(f"UFF direction code {code} is not one of -6..6")

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
            "id2": EXPORT_MARK,
            "id3": self.date[:80],
            "id4": id_line_4(self.channel, self.reference_channel) if self.channel else "",
            "id5": "",
            "func_type": self.func_type,
            "ver_num": 0,
            "load_case_id": 0,
            "rsp_ent_name": self.response[0][:10],
            "rsp_node": self.response[1],
            "rsp_dir": int(self.response_direction),
            "ref_ent_name": self.reference[0][:10],
            "ref_node": self.reference[1],
            "ref_dir": int(self.reference_direction),
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
    notes: list[str] | None = None,
) -> list[UffFunction]:
    """The UFF functions of an open recording.

    Parameters
    ----------
    recording
        An open :class:`rigtools.recording.reader.Recording`.
    what
        Any of ``"frf"`` (H1 of every response over the force with its coherence: the very
        estimate ``rig analyze`` reports, :func:`rigtools.recording_analysis.frf_estimate.point_frf_estimate`, for the
        points it treats as broadband), ``"time"`` (every channel of every point) and
        ``"spectra"`` (auto spectra, RMS² per bin: half the square of the flattop
        peak-amplitude spectrum of :func:`rigtools.analysis.spectra.amplitude_spectrum`, so a
        sine of amplitude A reads A²/2). FRFs come first in the file, so a reader that takes
        the FRF kind from the first record (sdypy-EMA) reads them right.
    frf_options
        :class:`rigtools.recording_analysis.frf_estimate.FRFOptions` (estimate overrides), as ``rig analyze`` takes them.
    reference
        The excitation channel of the FRFs (default: the recording's force channel).
    complete_only
        Leave out points that did not end (a run cut off mid-point) or that a stop cut short
        (``point_complete`` false): never exported as data.
    notes
        Where given, the lines to print are appended: a response-only point (no force channel)
        gets time records and spectra but no FRF (:func:`no_frf_line`); channels of an imported
        recording without node and direction (:func:`rigtools.interop.uff_places.unplaced_line`).

    Returns
    -------
    list of UffFunction
        FRFs and their coherence first, then time records and spectra.

    Notes
    -----
    Time records and spectra carry reference node 0, direction 0 (they have no reference). Each
    record carries its channel's place (:func:`rigtools.interop.uff_places.channel_place`): node,
    direction, entity name and ID line 1 as imported, else the rig's numbering. ID line 3 holds
    the recording's date (``DD-MMM-YY HH:MM:SS``, UTC).
    """

    procedure = str((recording.experiment or {}).get("procedure", ""))
    if frf_options is not None and "frf" not in what:
        frf_options.refuse_unused(f"--what {','.join(what)} writes no FRF")
    date = uff_date(getattr(recording, "created", ""))
    estimated = False
    tap = is_hit_per_point_tap_test(procedure, recording.points)
    frfs: list[UffFunction] = []
    others: list[UffFunction] = []
    unplaced: list[int] = []  # nodes given here to an imported recording's unplaced channels
    response_only: list[int] = []
    for point in recording.points:
        if complete_only and not point.whole:
            continue
        n = point.n_samples
        if n < 2:
            continue
        label = f"point {point.index:04d}"
        places = {
            name: channel_place(name, order, point.channels[name], foreign=procedure == "import")
            for order, name in enumerate(point.channels)
        }
        unplaced += [p.node for p in places.values() if not p.kept and p.direction == 0]
        for name, place in places.items():
            ch = point.channels[name]
            where = (place.entity, place.node)
            if bad := non_finite_reason(rows_reader(np.asarray(ch[:n])[None, :]), n):
                raise UserError(
                    f"{recording.path}: point {point.index} {name}: {bad.split(':')[0]}: UFF cannot carry them"
                )
            if "time" in what:
                others.append(
                    UffFunction(
                        FUNC_TIME,
                        place.description or f"{label} {name} time record",
                        where,
                        ("", 0),
                        ch.quantity,
                        "",
                        ch.t0 + np.arange(n) / ch.sample_rate,
                        ch[:n],
                        ch.units,
                        date,
                        response_direction=place.direction,
                        reference_direction=0,
                        channel=name,
                    )
                )
            if "spectra" in what:
                f, amp = amplitude_spectrum(ch[:n], ch.sample_rate)
                others.append(
                    UffFunction(
                        FUNC_AUTO_SPECTRUM,
                        (f"{place.description}: " if place.description else f"{label} {name} ")
                        + "auto spectrum, RMS^2 per bin (flattop)",
                        where,
                        ("", 0),
                        ch.quantity,
                        "",
                        f,
                        amp**2 / 2,
                        f"({ch.units})^2",
                        date,
                        response_direction=place.direction,
                        reference_direction=0,
                        channel=name,
                    )
                )
        broadband = point.sample_rate is not None and ("fe" not in point.params or procedure in PROCEDURE_FRF)
        if "frf" in what and tap and not estimated:  # one FRF of all its hits, once
            frfs += _point_frfs(point, "tap test", places, date, frf_options, tap=recording)
            estimated = True
        elif "frf" in what and broadband and not tap:
            if reference is not None:
                if reference not in point.channels:
                    raise UserError(
                        f"--reference {reference}: point {point.index} has no such channel "
                        f"(channels: {', '.join(point.channels)})"
                    )
                point = _with_force(point, reference)
            elif _response_only(point):
                response_only.append(point.index)
                continue
            frfs += _point_frfs(point, label, places, date, frf_options)
            estimated = True
    if frf_options is not None and "frf" in what and not estimated:
        held = "no point with a force channel" if response_only else "no broadband point"
        frf_options.refuse_unused(f"{recording.path} holds {held} to estimate an FRF of")
    if notes is not None:
        if response_only:
            notes.append(no_frf_line(response_only, len(recording.points)))
        if unplaced:
            notes.append(unplaced_line(unplaced))
    return frfs + others


def _response_only(point) -> bool:
    """True for a point with no excitation: no ``reference_channel``, no channel of quantity force
    (one with two force channels is not: ``--reference`` names its excitation)."""

    return force_channel(point) is None and not any(c.quantity == "force" for c in point.channels.values())


def no_frf_line(points: list[int], total: int) -> str:
    """The one line ``rig export uff`` says when response-only points get no FRF."""
    which = (
        "the recording holds"
        if len(points) == total
        else f"point{'s' if len(points) > 1 else ''} {', '.join(map(str, points))} "
        + ("hold" if len(points) > 1 else "holds")
    )
    return f"no FRF written: {which} no force channel (response-only); an FRF needs the measured excitation"


def _point_frfs(point, label: str, places: dict, date: str, frf_options, tap=None) -> list[UffFunction]:
    """H1 and coherence of every response of a broadband point over its force (the estimate of
    :func:`~rigtools.recording_analysis.frf_estimate.point_frf_estimate`; of :func:`~rigtools.recording_analysis.tap_test.analyze_tap_test` for ``tap``)."""

    if tap is not None:
        try:
            res = analyze_tap_test(tap.points, dict(tap.experiment or {}), method="peak").frf
            measured = frf_kind_of_units(point.channels[res.responses[0]].units) if res else None
            if res is not None and measured not in (None, res.kind):  # in the response's own units
                res = analyze_tap_test(
                    tap.points, dict(tap.experiment or {}), kind=measured, method="peak"
                ).frf
        except UserError as exc:
            raise UserError(f"{tap.path}: {exc}; --what time,spectra writes its records") from None
        assert res is not None and res.frf_method is not None
        est, resp, method = res.estimate, res.responses, res.frf_method
        force = str((tap.experiment or {}).get("hammer_channel") or "hammer")
    else:
        est, resp, force, method, _ = point_frf_estimate(point, options=frf_options)
    ref, ref_place = point.channels[force], places[force]
    out = []
    for i, name in enumerate(resp):
        ch, place = point.channels[name], places[name]
        common = {
            "response_direction": place.direction,
            "reference_direction": ref_place.direction,
            "channel": name,
            "reference_channel": force,
        }
        where, ref_where = (place.entity, place.node), (ref_place.entity, ref_place.node)
        text = method.describe(float(point.sample_rate))
        out.append(
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
                **common,
            )
        )
        if est.n_averages > 1:
            out.append(
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
                    **common,
                )
            )
    return out


def frf_set_functions(frf_set, what: tuple[str, ...] = WHAT, *, source: str = "") -> list[UffFunction]:
    """The UFF functions of an FRF set (:class:`rigtools.frf_set.FRFSet`): one FRF (type 4) per
    response, followed by its coherence (type 6) where the set has one.

    Each record carries the response's and the reference's UFF entity name, node and direction
    code as the set holds them (an import of UFF 58 keeps them, :func:`import_uff`); a set
    without them gets reference node 1 and response nodes 101, 102, ... in +Y, as
    :func:`recording_functions` numbers channels. Values are the set's, in SI; the quantity of
    the response follows the set's kind (accelerance: acceleration, ...). ID line 3 holds the
    set's date.

    Parameters
    ----------
    frf_set
        The set, as :func:`rigtools.frf_set.read_frf_set` returns it.
    what
        Must name ``"frf"``: an FRF set holds no time records or spectra.
    source
        The set's file name, for the one-line refusal.

    Raises
    ------
    UserError
        ``what`` lacks ``"frf"``.
    """

    if "frf" not in what:
        raise UserError(f"{source}: an FRF set holds FRFs only (no {', '.join(what)}): use --what frf")
    quantity = {kind: q for q, kind in _KIND_OF.items()}[frf_set.kind]
    units = f"{RESPONSE_UNITS[frf_set.kind]}/N"
    date = uff_date(frf_set.created)
    points = frf_set.points if len(frf_set.points) == len(frf_set.responses) else []
    out: list[UffFunction] = []
    for i, name in enumerate(frf_set.responses):
        rsp = points[i].get("response", {}) if points else {"node": 101 + i, "direction": DIRECTION_Y}
        ref = points[i].get("reference", {}) if points else {"node": 1, "direction": DIRECTION_Y}
        records = [(FUNC_FRF, "FRF, " + frf_set.kind, quantity, "force", frf_set.frf[i], units)]
        if np.all(np.isfinite(frf_set.coherence[i])):
            records.append((FUNC_COHERENCE, "coherence", "coherence", "", frf_set.coherence[i], "-"))
        for func_type, what_it_is, numerator, denominator, data, label in records:
            out.append(
                UffFunction(
                    func_type,
                    f"{name}/{frf_set.reference} {what_it_is}",
                    (str(rsp.get("entity") or name), int(rsp.get("node", 0))),
                    (str(ref.get("entity") or frf_set.reference), int(ref.get("node", 0))),
                    numerator,
                    denominator,
                    frf_set.frequency_hz,
                    data,
                    label,
                    date,
                    response_direction=int(rsp.get("direction", 0)),
                    reference_direction=int(ref.get("direction", 0)),
                    channel=name,
                    reference_channel=frf_set.reference,
                )
            )
    return out


def file_functions(
    path: str | Path,
    what: tuple[str, ...] = WHAT,
    *,
    frf_options=None,
    reference: str | None = None,
    notes: list[str] | None = None,
    left_out: list[str] | None = None,
) -> tuple[list[UffFunction], list[int]]:
    """``(functions, points left out)`` of what ``rig export uff`` writes of ``path``: a recording's
    (:func:`recording_functions`, whole points only; the indices of the points cut off or
    stopped inside returned, the lines naming them appended to ``left_out``
    (:func:`rigtools.recording.summary.left_out_lines`), the lines to print appended to ``notes``) or an FRF set's (:func:`frf_set_functions`: its
    FRFs are estimated already, so FRF options and ``reference`` are refused in one line).

    Raises
    ------
    UserError
        An unreadable file, a recording without a complete point, options the file does not use.
    """

    if Path(path).is_file() and is_frf_set(path):
        given = ([] if frf_options is None else frf_options.estimate_options()) + (
            ["--reference"] if reference is not None else []
        )
        if given:
            raise UserError(
                f"{' and '.join(given)}: {path} is an FRF set, its FRFs estimated already "
                f"(each over its reference), so {'it' if len(given) == 1 else 'they'} would be ignored"
            )
        return frf_set_functions(read_frf_set(path), what, source=str(path)), []
    with open_recording(path) as rec:
        if notes is not None:
            notes.extend(rec.notes)  # what --skip-damaged left out of a damaged file
        # cut off or stopped inside: never passed on as data
        skipped = [p.index for p in rec.points if not p.whole]
        if left_out is not None:
            left_out.extend(left_out_lines(rec.points))
        if len(skipped) == len(rec.points):
            raise UserError(f"{path}: the recording has no complete points to export")
        functions = recording_functions(
            rec, what, frf_options=frf_options, reference=reference, complete_only=True, notes=notes
        )
    return functions, skipped


# ------------------------------------------------------------------------------------ import

# specific data type (records 8-10) -> quantity
_QUANTITY_OF_CODE = {
    DATA_DISPLACEMENT: "displacement",
    DATA_VELOCITY: "velocity",
    DATA_ACCELERATION: "acceleration",
    DATA_FORCE: "force",
}
_KIND_OF = {"displacement": "receptance", "velocity": "mobility", "acceleration": "accelerance"}
_KIND_WORDS = {
    "receptance": "receptance",
    "compliance": "receptance",
    "dynamic compliance": "receptance",
    "mobility": "mobility",
    "admittance": "mobility",
    "accelerance": "accelerance",
    "inertance": "accelerance",
}
_NONE = ("", "none", "unknown")


def read_uff_sets(source: str | Path, notes: list[str] | None = None) -> list[dict]:
    """The datasets 58 of a UFF file (pyuff), each cut to its stated ``num_pts``; a record holding
    more values than a padded last line explains is said in ``notes``."""
    import pyuff

    source = source_file(source)
    sets = parsed(source, "UFF", lambda: pyuff.UFF(str(source)).read_sets())
    sets = sets if isinstance(sets, list) else [sets]
    cut = cut_record(source, len(sets))
    out: list[dict] = []
    for s in sets:
        if s.get("type") != 58:
            continue
        n = int(s.get("num_pts", len(s["data"])))
        if len(s["data"]) > n:  # writers pad the last line; pyuff reads the padding as values
            if len(s["data"]) - n >= 6 and notes is not None:  # more than one line of padding
                notes.append(
                    f"record {len(out) + 1}: declares {n} values, holds {len(s['data'])}: imported {n}"
                )
            s = {**s, "data": s["data"][:n], "x": s["x"][:n]}
        out.append(s)
    if not out:
        raise UserError(cut or f"{source}: no UFF 58 record (function records) in the file")
    if cut:
        (notes if notes is not None else []).append(cut)
    return out


def record_name(s: dict) -> str:
    """The name of a record's response: the channel name ID line 4 holds in a file ``rig export
    uff`` wrote (:func:`exported_names`), else its entity name, then ``:<node><direction>`` when
    the node is not 0 (``acc:2+Z``, ``node:2+Z`` without entity name, ``acc:5-RX`` for a
    rotation: :func:`direction_text`), unless the entity name says just that (``1+Z``)."""
    names = exported_names(s)
    if names is not None:
        return names[0]
    name = str(s.get("rsp_ent_name", "")).strip()
    if name.lower() in _NONE:
        name = "node"
    node, direction = int(s.get("rsp_node", 0)), int(s.get("rsp_dir", 0))
    if node:
        where = f"{node}" + (direction_text(direction) or (f"dir{direction}" if direction else ""))
        name += "" if name == where else f":{where}"
    return name


def _quantity_word(s: dict) -> str:
    code = int(s.get("ordinate_spec_data_type", 0))
    return _QUANTITY_OF_CODE.get(code) or f"data{code}"


def record_names(sets: list[dict]) -> list[str]:
    """The names of ``sets`` (:func:`record_name`); records of one function type that would share
    a name but differ in what they measure (their ordinate's specific data type: the
    acceleration, velocity and displacement of one node) get ``:<quantity>`` appended
    (``acc:2+Y:acceleration``, ``acc:2+Y:displacement``); records that still share a name are
    told apart by their ID lines (:func:`rigtools.interop.uff_places.told_apart`: ``1+Z:Dof1``
    and ``1+Z:Dof4`` for the two records of one DOF in the MPSTD file)."""
    names = [record_name(s) for s in sets]
    groups: dict[tuple[int, str], set[str]] = {}
    for s, name in zip(sets, names, strict=True):
        groups.setdefault((int(s["func_type"]), name), set()).add(_quantity_word(s))
    return told_apart(
        sets,
        [
            name + f":{_quantity_word(s)}" if len(groups[(int(s["func_type"]), name)]) > 1 else name
            for s, name in zip(sets, names, strict=True)
        ],
    )


def record_key(number: int) -> str:
    """How ``--map``, ``--units`` and ``--channel`` name record ``number`` (1 = the file's first
    record 58) when names do not tell records apart: ``record7``."""
    return f"record{number}"


def _check_keys(option: str, given, names: set[str], n_records: int) -> None:
    """Refuse ``option`` entries naming no record: neither a record's name nor ``recordN``."""

    numbers = {record_key(i) for i in range(1, n_records + 1)}
    bad = [k for k in given if k.startswith("record") and k[6:].isdigit() and k not in numbers]
    if bad:
        raise UserError(
            f"{option}: no {', '.join(bad)} in the file (its records 58: record1..record{n_records})"
        )
    check_known(option, [k for k in given if k not in numbers], names)


def _label(s: dict, key: str) -> str:
    text = str(s.get(key, "")).strip()
    return "" if text.lower() in _NONE else text


def _time_units(s: dict) -> str:
    """The declared units of a time record: its units label, else what its data-type code says."""
    label = _label(s, "ordinate_axis_units_lab")
    if label:
        return label
    quantity = _QUANTITY_OF_CODE.get(int(s.get("ordinate_spec_data_type", 0)))
    return {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2", "force": "N"}.get(
        quantity or "", ""
    )


def _frf_kind(s: dict, given: str | None) -> tuple[str | None, float, str]:
    """``(kind, factor to SI, how it was found)`` of an FRF record: ``given`` (``--units`` of the
    response) first, else the labels checked against the data."""

    if given is not None:
        si = si_units(given)
        if si is None or si.quantity not in _KIND_OF:
            raise UserError(f"--units {record_name(s)}={given}: give the response's units (m/s^2, g, m/s, m)")
        return _KIND_OF[si.quantity], si.factor, f"response units {given} from --units"
    claims: dict[str, tuple[str, float]] = {}
    code = _QUANTITY_OF_CODE.get(int(s.get("ordinate_spec_data_type", 0)))
    if code in _KIND_OF:
        claims["data-type code"] = (_KIND_OF[code], 1.0)
    units = _label(s, "ordinate_axis_units_lab")
    num = units[: units.rindex("/")].strip("() ") if "/" in units else ""  # "(m/s)/N" -> "m/s"
    si = si_units(num) if num else None
    if si is not None and si.quantity in _KIND_OF:
        claims[f"units {units!r}"] = (_KIND_OF[si.quantity], si.factor)
    word = _KIND_WORDS.get(_label(s, "ordinate_axis_lab").lower())
    if word:
        claims[f"axis label {_label(s, 'ordinate_axis_lab')!r}"] = (word, 1.0)
    data = frf_kind_from_data(np.asarray(s["x"], float), np.asarray(s["data"], complex))
    kinds = {k for k, _ in claims.values()}
    said = ", ".join(f"{w} says {k}" for w, (k, _) in claims.items())

    def scale(kind: str) -> tuple[float, str]:
        # only the units label carries a scale (g/N is 9.80665 (m/s^2)/N); the data-type code and
        # the axis label name the kind alone
        unit_claims = [(w, f) for w, (k, f) in claims.items() if w.startswith("units") and k == kind]
        if unit_claims and unit_claims[0][1] != 1.0:
            return unit_claims[0][1], f", x {unit_claims[0][1]:g} from its {unit_claims[0][0]}"
        return 1.0, ""

    if len(kinds) == 1 and (data is None or data in kinds):
        (where, (kind, _)) = next(iter(claims.items()))
        factor, how = scale(kind)
        return kind, factor, f"{kind} from its {where}" + (", as the data show" if data else "") + how
    if data is not None:
        factor, how = scale(data)
        return data, factor, f"{data} from the data ({FRF_DATA_RULE}){'; ' + said if said else ''}{how}"
    if len(kinds) == 1:
        (where, (kind, _)) = next(iter(claims.items()))
        factor, how = scale(kind)
        return kind, factor, f"{kind} from its {where}{how}"
    return (
        None,
        1.0,
        f"kind not known ({said or 'no label'}); give --units {record_name(s)}=m/s^2 (or m/s, m)",
    )


@in_script_words
@importer
def import_uff(source: str | Path, out: str | Path, **options: Unpack[ImportKeywords]) -> dict:
    """Import a UFF file's datasets 58: FRFs (with their coherence) to an FRF set
    (:mod:`rigtools.frf_set`), else time records to a recording (backend ``"uff"``).

    Time records: one channel each (named by :func:`record_name`), units from the ordinate
    label or data-type code, rate ``1 / abscissa_inc``; records of one length and rate share a
    point. FRFs: the kind from the labels, checked against the data (:func:`frf_kind_from_data`;
    ``--units RESPONSE=UNIT`` overrides); one FRF set of the FRFs of the first grid.

    Parameters
    ----------
    source
        The UFF file.
    out
        The recording (or FRF set) to write (``.h5``).
    %(shared)s

    Returns
    -------
    dict
        ``{"channels": [...], "points": [...], "lines": [...]}`` as every import (FRFs: one
        entry and line per record).
    """
    request = import_request(source, options)
    source, mapping, units, chosen = request.source, request.mapping, request.units, request.channels
    reference, overwrite, notes = request.reference, request.overwrite, request.notes
    sets = read_uff_sets(source, notes)
    names = record_names(sets)
    for option, given in (("--channel", chosen), ("--map", mapping), ("--units", units)):
        _check_keys(option, given, set(names), len(sets))
    records = [
        (number, name, s)
        for number, (name, s) in enumerate(zip(names, sets, strict=True), start=1)
        if not chosen or name in chosen or record_key(number) in chosen
    ]
    if any(int(s["func_type"]) == FUNC_FRF for _, _, s in records):
        if reference is not None:  # never ignored silently
            raise UserError(
                f"--reference: {source} holds FRFs, each over the reference its record names; "
                "--reference chooses the excitation among time records"
            )
        return _import_frfs(source, out, records, mapping=mapping, units=units, overwrite=overwrite)
    every: list[ForeignChannel] = []
    kept: list[tuple[ForeignChannel, int, float]] = []
    data: list[tuple[np.ndarray, float]] = []
    for number, name, s in records:
        where = f"record {number} ({name})"
        if int(s["func_type"]) != FUNC_TIME:
            every.append(
                ForeignChannel(where, reason=f"function type {s['func_type']}: neither time record nor FRF")
            )
            continue
        fc = resolve(where, name, _time_units(s), mapping=mapping, units=units, path=record_key(number))
        fc.extra["file_name"], fc.extra["key"] = name, record_key(number)
        fc.extra["place"] = record_place(s)
        every.append(fc)
        inc = float(s.get("abscissa_inc", 0.0))
        fc.samples = len(s["data"])
        units_given = name in units or record_key(number) in units
        if fc.kept and not units_given and (conflict := code_against_label(s, _QUANTITY_OF_CODE)):
            fc.si, fc.name, fc.reason = None, "", f"{conflict}: give --units {name}=UNIT to say which"
        if fc.kept and not inc > 0:
            fc.si, fc.name, fc.reason = None, "", f"abscissa increment {inc!r} is not a positive time step"
        if fc.kept and np.iscomplexobj(s["data"]):
            fc.si, fc.name, fc.reason = None, "", "complex values in a time record"
        if fc.kept and (bad := non_finite_reason(rows_reader(np.asarray(s["data"])[None, :]), fc.samples)):
            fc.si, fc.name, fc.reason = None, "", bad
        if not fc.kept:
            continue
        if fc.samples < (declared := int(s.get("num_pts", fc.samples))):
            notes.append(
                f"{where}: declares {declared} values, holds {fc.samples}: imported {fc.samples} (a cut file?)"
            )
        fc.sample_rate = rate_of_increment(inc)
        if fc.sample_rate != 1.0 / inc:
            fc.reason = "; ".join(
                [
                    *filter(None, [fc.reason]),
                    f"rate {fc.sample_rate:g} Hz: 1/increment within its 6 written digits",
                ]
            )
        kept.append((fc, fc.samples, fc.sample_rate))
        data.append((np.asarray(s["data"], dtype=float), float(s.get("abscissa_min", 0.0))))
    points = []
    for part in split_by_timing(kept):
        fcs = [kept[i][0] for i in part]
        check_names(fcs, str(source))
        block = np.vstack([data[i][0] for i in part])
        points.append(
            ForeignPoint(
                params={"source_records": ",".join(str(i + 1) for i in part)},
                channels=fcs,
                samples=kept[part[0]][1],
                sample_rate=kept[part[0]][2],
                read=rows_reader(block),
                t0=[data[i][1] for i in part],
            )
        )
    experiment = {"procedure": "import", "source_format": "uff", "source": source.name}
    return request.write(out, "uff", experiment, points, every)


def _point_of(s: dict, side: str) -> dict:
    """``{"entity", "node", "direction"}`` of a record's response or reference (UFF codes)."""
    key = "rsp" if side == "response" else "ref"
    entity = str(s.get(f"{key}_ent_name", "")).strip()
    return {
        "entity": "" if entity.lower() in _NONE else entity,
        "node": int(s.get(f"{key}_node", 0)),
        "direction": int(s.get(f"{key}_dir", 0)),
    }


def _reference_name(s: dict) -> str:
    """The reference channel of an FRF record: ID line 4's in a file ``rig export uff`` wrote,
    else the reference entity name."""
    names = exported_names(s)
    return (names[1] if names and names[1] else "") or str(s.get("ref_ent_name", "")).strip()


def _import_frfs(
    source: Path, out: str | Path, records: list[tuple[int, str, dict]], *, mapping, units, overwrite
) -> dict:

    lines, entries = [], []
    frfs, grid, kinds = [], None, set()
    points: list[dict] = []
    taken: dict[str, str] = {}
    coherence = {
        (name, _reference_name(s), int(s.get("ref_node", 0))): s
        for _, name, s in records
        if int(s["func_type"]) == FUNC_COHERENCE
    }
    for number, name, s in records:
        where = f"record {number} ({name})"
        keys = (record_key(number), name)
        ftype = int(s["func_type"])
        if ftype == FUNC_COHERENCE:
            continue
        if ftype != FUNC_FRF:
            lines.append(f"skipped {where}: function type {ftype}; this file's FRFs are imported")
            entries.append({"source": where, "action": "skipped"})
            continue
        kind, factor, how = _frf_kind(s, next((units[k] for k in keys if k in units), None))
        x = np.asarray(s["x"], dtype=float)
        if kind is None or (grid is not None and (x.size != grid.size or not np.allclose(x, grid))):
            why = how if kind is None else "another frequency grid than the first FRF's"
            lines.append(f"skipped {where}: {why}")
            entries.append({"source": where, "action": "skipped", "reason": why})
            continue
        grid = x
        coh = coherence.get((name, _reference_name(s), int(s.get("ref_node", 0))))
        said_coherence = coherence_text(coh, x)
        c = (
            np.asarray(coh["data"], dtype=float)
            if coh is not None and said_coherence == "with its coherence"
            else np.full(x.size, np.nan)
        )
        stored = next((mapping[k] for k in keys if k in mapping), storable_name(name))
        if stored in taken:
            raise UserError(
                f"{source}: {taken[stored]} and {where} both become FRF {stored!r}; "
                f"name one by its record number: --map {record_key(number)}=NEW_NAME"
            )
        taken[stored] = where
        frfs.append((stored, np.asarray(s["data"], complex) * factor, c, kind))
        points.append({side: _point_of(s, side) for side in ("response", "reference")})
        kinds.add(kind)
        text = (
            f"kept    {where} -> {stored}: FRF, {how}, {x.size} lines {x[0]:g}-{x[-1]:g} Hz, {said_coherence}"
        )
        lines.append(text)
        entries.append(
            {"source": where, "action": "kept", "name": stored, "kind": kind, "how": how, "text": text}
        )
    if not frfs:
        raise UserError(f"{source}: no FRF to import: " + "; ".join(lines))
    if len(kinds) > 1:
        raise UserError(
            f"{source}: FRFs of different kinds ({', '.join(sorted(kinds))}); import them separately (--channel)"
        )
    ref = next((_reference_name(s) for _, _, s in records if int(s["func_type"]) == FUNC_FRF), "") or "force"
    assert grid is not None
    frf_set = FRFSet(
        frequency_hz=grid,
        frf=np.vstack([h for _, h, _, _ in frfs]),
        coherence=np.vstack([c for _, _, c, _ in frfs]),
        responses=[n for n, _, _, _ in frfs],
        reference=ref,
        kind=kinds.pop(),
        source={"file": source.name, "format": "uff", "records": entries},
        points=points,
    )
    write_frf_set(out, frf_set, overwrite=overwrite)
    lines.append(
        f"FRF set: {len(frfs)} FRF(s) over {ref}, {frf_set.kind}; rig analyze identifies their modes"
    )
    return {
        "channels": entries,
        "points": [],
        "frf_set": {"responses": frf_set.responses, "kind": frf_set.kind},
        "lines": lines,
    }
