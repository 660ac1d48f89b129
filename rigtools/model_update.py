"""``rig update`` behind the command line: recordings -> targets -> fits -> an updated rig file.

* :func:`identify_recording`: natural frequencies and damping ratios of every broadband point of
  a recording (an FRF test, ``rig acquire frf``; a tap/hammer test), per blade, from the
  accelerations over the force: the very FRF and modes ``rig analyze`` reports
  (:func:`rigtools.recording_analysis.broadband.analyze_broadband`, :func:`rigtools.recording_analysis.tap_test.analyze_tap_test`).
* :func:`mode_targets`: those modes paired with the model's flexural modes (blade, order), the
  same mode seen by several recordings merged (mean).
* :func:`fit_linear`: :func:`rigtools.sim.parameter_fit.update_model` with the user's errors as one line.
* :func:`read_dwell`, :func:`model_dwell`, :func:`fit_contact_to_dwells`: force-controlled dwells
  with impacts (``rig acquire dwell``) as harmonic targets, the model's harmonics at the measured
  force, and the contact fit (:func:`rigtools.sim.contact_fit.fit_contact`, vibro-impact integrator in the
  loop).
* :func:`agreement`: EM-versus-FEM score of a dwell (:func:`rigtools.analysis.correlation.point_agreement`).
* :func:`updated_rig_text`: the original rig-file text with the fitted keys replaced or added, each
  commented with its origin, checked to load and to hold exactly the fitted values.

Blades: a response channel whose name holds ``passive`` is the passive blade's, one holding
``active`` the active blade's. Modes come only from points that carry a broadband test: a
``frame_samples`` (one frame or burst period), the averaged window (``record_start`` in s,
``record_samples``) and a force channel; a sine dwell has none.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from rigtools.errors import UserError
from rigtools.sim.channel_names import ACTIVE_SHROUD_ACCEL as ACTIVE
from rigtools.sim.channel_names import FORCE
from rigtools.sim.channel_names import PASSIVE_SHROUD_ACCEL as PASSIVE

if TYPE_CHECKING:
    from rigtools.analysis.point import DwellAnalysis
    from rigtools.sim.parameter_fit import Blade

DWELL_CHANNELS = (FORCE, ACTIVE, PASSIVE)
ContactLaw = Literal["linear", "hertz"]
K_HARMONICS = 10  # harmonics fitted and scored (k = 1..10: most of each shroud's energy at 60 Hz)


# ------------------------------------------------------------------------- identified modes


@dataclass
class IdentifiedSet:
    """The modes one response of one recording shows.

    Attributes
    ----------
    recording
        File name of the recording.
    point
        Point index.
    blade
        ``"active"`` or ``"passive"``.
    response
        Response channel.
    frequencies_hz, damping_ratios
        Identified modes, ascending.
    notes
        Why fewer or none were identified (from :func:`rigtools.analysis.modal_id.identify`).
    """

    recording: str
    point: int
    blade: Blade
    response: str
    frequencies_hz: list[float]
    damping_ratios: list[float]
    notes: list[str] = field(default_factory=list)


@dataclass
class RecordingModes:
    """What :func:`identify_recording` found in one recording."""

    path: str
    procedure: str
    sets: list[IdentifiedSet]
    band: tuple[float, float] | None

    @property
    def n_modes(self) -> int:
        return sum(len(s.frequencies_hz) for s in self.sets)


def _blade_of(name: str) -> Blade | None:
    low = name.lower()
    if "passive" in low:
        return "passive"
    if "active" in low:
        return "active"
    return None


def _open(path: str | Path):
    from rigtools.recording import open_recording

    p = Path(path)
    if not p.exists():
        raise UserError(f"{p}: no such recording")
    if p.is_dir():
        raise UserError(f"{p} is a directory, not a recording")
    return open_recording(p)


def identify_recording(
    path: str | Path, *, f_min: float | None = None, f_max: float | None = None, method: str = "lscf"
) -> RecordingModes:
    """Natural frequencies and damping ratios in every broadband point of a recording.

    Parameters
    ----------
    path
        HDF5 recording (schema v1).
    f_min, f_max
        Band searched, Hz (default: the test's band from the point, else the whole grid).
    method
        :func:`rigtools.analysis.modal_id.identify` method.

    Raises
    ------
    UserError
        Unreadable file, or no point holding a broadband test (a dwell, a sweep).
    """
    from rigtools.recording_analysis.broadband import analyze_broadband
    from rigtools.recording_analysis.frf_estimate import FRFOptions

    name = Path(path).name
    with _open(path) as rec:
        procedure = str(rec.experiment.get("procedure", "")) if isinstance(rec.experiment, dict) else ""
        status = rec.status
        sets: list[IdentifiedSet] = []
        band = None
        usable = 0
        from rigtools.recording_analysis.tap_test import analyze_tap_test, is_hit_per_point_tap_test

        tap_test = is_hit_per_point_tap_test(procedure, rec.points)
        if tap_test:  # one frame per accepted hit, each its own point
            tap = analyze_tap_test(rec.points, rec.experiment, method=method, band=(f_min, f_max))
            usable = 1
            for resp, ident in tap.frf.modes.items():
                # the response's name tells its blade; else the blade the hammer hit
                blade = _blade_of(resp) or _blade_of(str(tap.params.get("blade", "")))
                if blade is None:
                    raise UserError(
                        f"{name}: tap response {resp!r} names no blade (active/passive) and the "
                        "recording does not say which blade was hit"
                    )
                modes = sorted(ident.modes, key=lambda m: m.frequency_hz)
                sets.append(
                    IdentifiedSet(
                        name,
                        tap.index,
                        blade,
                        resp,
                        [float(m.frequency_hz) for m in modes],
                        [float(m.damping_ratio) for m in modes],
                        list(ident.notes),
                    )
                )
        for point in [] if tap_test else rec.complete_points:
            prm = point.params
            if not {"frame_samples", "record_start", "record_samples"} <= set(prm):
                continue
            forces = [n for n, c in point.channels.items() if c.quantity == "force"]
            blade_of = {
                n: blade
                for n, c in point.channels.items()
                if c.quantity == "acceleration" and (blade := _blade_of(n)) is not None
            }
            responses = list(blade_of)
            if not forces or not responses or point.sample_rate is None:
                continue
            rate = float(point.sample_rate)
            start, n = round(float(prm["record_start"]) * rate), int(prm["record_samples"])
            frame = int(prm["frame_samples"])
            if n < frame or frame < 8 or start + n > point.n_samples:
                continue
            lo = f_min if f_min is not None else prm.get("band_low")
            hi = f_max if f_max is not None else prm.get("band_high")
            lo = None if lo is None else float(lo)
            hi = None if hi is None else min(float(hi), 0.45 * rate)
            band = (lo, hi) if lo is not None and hi is not None else band
            usable += 1
            # the recording's one FRF estimate, as rig analyze reports it
            result = analyze_broadband(
                point,
                procedure,
                method=method,
                responses=responses,
                options=FRFOptions(band=(lo, hi)) if lo is not None and hi is not None else None,
            ).frf
            for resp in responses:
                ident = result.modes[resp]
                modes = sorted(ident.modes, key=lambda m: m.frequency_hz)
                sets.append(
                    IdentifiedSet(
                        name,
                        point.index,
                        blade_of[resp],
                        resp,
                        [float(m.frequency_hz) for m in modes],
                        [float(m.damping_ratio) for m in modes],
                        list(ident.notes),
                    )
                )
    if usable == 0:
        what = f" (a {procedure} recording)" if procedure else ""
        if status != "complete":
            what = f" ({procedure + ', ' if procedure else ''}status {status})"
        raise UserError(
            f"{name}{what} holds no complete broadband test (FRF or tap test) to identify modes "
            "from; record one with 'rig acquire frf'"
        )
    out = RecordingModes(str(path), procedure, sets, band)
    if out.n_modes == 0:
        why = "; ".join(dict.fromkeys(n for s in sets for n in s.notes)) or "no stable poles"
        raise UserError(f"{name}: no usable modes identified ({why})")
    return out


@dataclass
class PairedMode:
    """One target and where it came from."""

    blade: str
    order: int
    frequency_hz: float
    damping_ratio: float | None
    model_hz: float
    sources: list[str]


def mode_targets(
    params,
    recordings: Sequence[RecordingModes],
    *,
    max_modes: int = 3,
    frequency_sigma: float = 1e-3,
    damping_sigma: float = 0.1,
    damping: bool = True,
) -> tuple[list, list[PairedMode], list[str]]:
    """Pair identified modes with the model's flexural modes of each blade.

    Each identified set is paired on its own (:func:`rigtools.sim.parameter_fit.pair_modes`); a (blade, order)
    seen by several sets is their mean. Orders above ``max_modes`` are left out.

    Returns
    -------
    targets, paired, notes
        :class:`rigtools.sim.parameter_fit.ModeTarget` list, the same with their sources, and lines about
        what was left out (unpaired peaks, blades without modes).
    """
    from rigtools.sim.parameter_fit import ModeTarget, pair_modes

    seen: dict[tuple[Blade, int], list] = {}
    model_hz: dict[tuple[Blade, int], float] = {}
    notes: list[str] = []
    for rec in recordings:
        for s in rec.sets:
            if not s.frequencies_hz:
                continue
            pairing = pair_modes(params, s.blade, s.frequencies_hz, s.damping_ratios)
            for t, fm in zip(pairing.targets, pairing.model_hz, strict=True):
                if t.order > max_modes:
                    continue
                seen.setdefault((t.blade, t.order), []).append(
                    (t.frequency_hz, t.damping_ratio, f"{s.recording}:{s.response}")
                )
                model_hz[(t.blade, t.order)] = fm
            for f in pairing.unpaired:
                notes.append(
                    f"{s.recording} {s.response}: {f:.2f} Hz matches no {s.blade} flexural mode "
                    "(within 15 %): left out"
                )
    targets, paired = [], []
    for blade, order in sorted(seen):
        vals = seen[(blade, order)]
        f = float(np.mean([v[0] for v in vals]))
        zs = [v[1] for v in vals if v[1] is not None]
        z = float(np.mean(zs)) if zs and damping else None
        targets.append(ModeTarget(blade, order, f, z, frequency_sigma, damping_sigma))
        paired.append(PairedMode(blade, order, f, z, model_hz[(blade, order)], [v[2] for v in vals]))
    for blade in ("active", "passive"):
        if not any(p.blade == blade for p in paired):
            notes.append(
                f"no {blade}-blade modes in the recordings: "
                + (
                    "the fit sees the active blade only (add a tap test of the passive blade)"
                    if blade == "passive"
                    else "add an FRF test of the active blade"
                )
            )
    return targets, paired, notes


def fit_linear(params, targets, names: Sequence[str], **kwargs):
    """:func:`rigtools.sim.parameter_fit.update_model` within what a rig file can hold; bad names or targets
    become one-line :class:`UserError`.

    Root springs stay at or below the rig file's limits (:data:`rigtools.config.MAX_ROOT_ROTATIONAL_STIFFNESS`,
    ``MAX_ROOT_TRANSLATIONAL_STIFFNESS``): a clamped root whose springs are fitted becomes springs
    at those limits first (the clamped frequencies within 1e-4), so the spring that is not fitted
    can be written, and the fitted rig file loads with exactly the fitted model.
    """
    from dataclasses import replace

    from rigtools.config import MAX_ROOT_ROTATIONAL_STIFFNESS as KR_MAX
    from rigtools.config import MAX_ROOT_TRANSLATIONAL_STIFFNESS as KT_MAX
    from rigtools.sim.parameter_fit import (
        CLAMPED_START_ROTATIONAL,
        CLAMPED_START_TRANSLATIONAL,
        PARAMETERS,
        update_model,
    )
    from rigtools.sim.params import RootParams

    if not targets:
        raise UserError("no identified mode pairs with a model mode: nothing to fit")
    names = list(names)
    start = dict(kwargs.pop("start", None) or {})
    bounds = dict(kwargs.pop("bounds", None) or {})
    roots = {
        "root.rotational_stiffness": (KR_MAX, CLAMPED_START_ROTATIONAL),
        "root.translational_stiffness": (KT_MAX, CLAMPED_START_TRANSLATIONAL),
    }
    if any(n in roots for n in names):
        if params.root.kind != "springs":
            params = replace(params, root=RootParams("springs", KR_MAX, KT_MAX))
            for n in names:
                if n in roots:
                    start.setdefault(n, roots[n][1])
        for n in names:
            if n in roots:
                lo, hi = bounds.get(n, PARAMETERS[n].default_bounds(start.get(n, PARAMETERS[n].get(params))))
                bounds[n] = (lo, min(hi, roots[n][0]))
    try:
        return update_model(params, targets, names, start=start or None, bounds=bounds or None, **kwargs)
    except ValueError as exc:
        raise UserError(str(exc)) from None


def parse_names(text: str, known: Sequence[str], option: str = "--params") -> list[str]:
    """``"a,b"`` -> ``["a", "b"]``, each checked against ``known``."""
    names = [n.strip() for n in str(text).split(",") if n.strip()]
    if not names:
        raise UserError(f"{option}: give at least one parameter (known: {', '.join(known)})")
    for n in names:
        if n not in known:
            raise UserError(f"{option}: unknown parameter {n!r} (known: {', '.join(known)})")
    return list(dict.fromkeys(names))


# ------------------------------------------------------------------------------ dwells


@dataclass
class DwellData:
    """A settled force-controlled dwell: what the contact fit and the scores use."""

    name: str
    fe: float
    force_amplitude: float  # measured fundamental of the force, N (the model is driven at it)
    gap: float
    analysis: DwellAnalysis  # of the settled window

    def amplitudes(self, channel: str, k_max: int = K_HARMONICS) -> np.ndarray:
        return np.asarray(self.analysis.harmonics[channel].amplitude[:k_max], dtype=float)


def read_dwell(path: str | Path, *, k_max: int = 30) -> list[DwellData]:
    """The settled windows of the force-controlled dwell points of a recording (``rig acquire
    dwell`` / ``sweep`` / ``study``), analysed (harmonics k = 1..k_max).

    Raises
    ------
    UserError
        Unreadable file, or no settled dwell point with a force and a shroud channel.
    """
    from rigtools.analysis.point import analyze_dwell

    name = Path(path).name
    out = []
    with _open(path) as rec:
        for point in rec.complete_points:
            prm = point.params
            if not {"fe", "record_start", "record_samples", "gap"} <= set(prm) or "frame_samples" in prm:
                continue
            if not prm.get("settled", True) or point.sample_rate is None:
                continue
            if FORCE not in point.channels or ACTIVE not in point.channels:
                continue
            rate = float(point.sample_rate)
            start = round(float(prm["record_start"]) * rate)
            n = int(prm["record_samples"])
            chans = {c: point.channels[c][start : start + n] for c in DWELL_CHANNELS if c in point.channels}
            ana = analyze_dwell(chans, rate, float(prm["fe"]), k_max=k_max)
            f0 = prm.get("force_amplitude_measured") or ana.force_amplitude
            if f0 is None:  # no force fundamental to drive the model at
                continue
            out.append(
                DwellData(f"{name}:{point.index}", float(prm["fe"]), float(f0), float(prm["gap"]), ana)
            )
    if not out:
        raise UserError(
            f"{name} holds no settled force-controlled dwell point (record one with 'rig acquire dwell')"
        )
    return out


def model_dwell(params, dwell: DwellData, *, system=None, duration: float = 0.5):
    """The model's settled run at a dwell's frequency, measured force amplitude and gap, as a
    :class:`rigtools.analysis.point.DwellAnalysis` (shroud accelerations from the velocity, ``k w |V_k|``;
    the force as run)."""
    from dataclasses import replace

    from rigtools.analysis.harmonics import derivative_harmonics, harmonic_amplitudes
    from rigtools.analysis.point import DwellAnalysis
    from rigtools.sim.reduction import reduced_system
    from rigtools.simulation import RunSettings, simulate_point

    system = system if system is not None else reduced_system(params, "fem")
    system = replace(system, contact=params.contact).with_contact(gap=dwell.gap)
    run = simulate_point(system, dwell.fe, dwell.force_amplitude, RunSettings(duration=duration))
    k = 30
    fits = {
        FORCE: harmonic_amplitudes(run.outputs["excitation_force"], run.sample_rate, run.fe, k),
        ACTIVE: derivative_harmonics(
            harmonic_amplitudes(run.outputs["active_tip_velocity"], run.sample_rate, run.fe, k), 1
        ),
        PASSIVE: derivative_harmonics(
            harmonic_amplitudes(run.outputs["passive_tip_velocity"], run.sample_rate, run.fe, k), 1
        ),
    }
    return DwellAnalysis(run.fe, run.sample_rate, fits, force_amplitude=fits[FORCE].at(1))


def agreement(dwell: DwellData, model, *, k_max: int = K_HARMONICS):
    """EM-versus-FEM :class:`rigtools.analysis.correlation.Agreement` over the force and both shroud
    accelerations, harmonics 1..k_max."""
    from rigtools.analysis.correlation import point_agreement

    return point_agreement(dwell.analysis, model, channels=list(DWELL_CHANNELS), k_max=k_max)


def harmonic_targets(
    dwells: Sequence[DwellData], *, k_max: int = K_HARMONICS, sigma: float = 0.05, floor: float = 0.01
) -> list:
    """:class:`rigtools.sim.contact_fit.HarmonicTarget` of each dwell (both shroud accelerations)."""
    from rigtools.sim.contact_fit import HarmonicTarget

    return [
        HarmonicTarget(
            d.fe,
            d.force_amplitude,
            d.gap,
            {c: d.amplitudes(c, k_max) for c in (ACTIVE, PASSIVE) if c in d.analysis.harmonics},
            sigma=sigma,
            floor=floor,
        )
        for d in dwells
    ]


def fit_contact_to_dwells(
    params,
    dwells: Sequence[DwellData],
    *,
    law: ContactLaw | None = None,
    names: Sequence[str] = ("contact.stiffness", "contact.damping"),
    k_max: int = K_HARMONICS,
):
    """:func:`rigtools.sim.contact_fit.fit_contact` to the dwells' shroud harmonics; one-line errors."""
    from rigtools.sim.contact_fit import fit_contact
    from rigtools.sim.params import SimulationInputError

    try:
        return fit_contact(params, harmonic_targets(dwells, k_max=k_max), list(names), law=law)
    except (ValueError, SimulationInputError) as exc:
        raise UserError(f"contact fit: {exc}") from None


# ---------------------------------------------------------------------------- rig-file text


_HEADER = re.compile(r"^\s*\[\s*([A-Za-z0-9_.\-\"']+)\s*\]\s*(#.*)?$")
_KEY = re.compile(r"^(\s*)([A-Za-z0-9_\-]+)\s*=")


def _toml_value(value) -> str:
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    v = float(value)
    if not math.isfinite(v):
        raise UserError(f"cannot write a non-finite value ({v}) to a rig file")
    return repr(v)


def updated_rig_text(
    text: str,
    values: dict[str, float | str],
    comments: dict[str, str],
    *,
    remove: Sequence[str] = (),
    header: str = "",
) -> str:
    """The rig-file ``text`` with ``values`` (``"section.key"`` -> SI value or text) set.

    Each key is replaced in place (its old line kept as a comment) or added at the end of its
    section (the section appended if missing), followed by ``# comments[key]``. Keys in
    ``remove`` are commented out. ``header`` lines go on top, as comments. Only plain
    ``[section]`` tables are edited; the result is checked to parse (``tomllib``) and to hold
    every value given (a key written some other way, e.g. as an inline table, raises).
    """
    lines = text.splitlines()
    sections: dict[str, tuple[int, int]] = {}  # name -> (header line, last line of the section)
    current, start = "", -1
    for i, line in enumerate(lines):
        m = _HEADER.match(line)
        if m:
            sections.setdefault(current, (start, i - 1))
            current, start = m.group(1).strip().strip('"').strip("'"), i
    sections.setdefault(current, (start, len(lines) - 1))

    edits: dict[int, list[str]] = {}  # line index -> replacement lines
    appends: dict[str, list[str]] = {}  # section -> lines added at its end
    new_sections: dict[str, list[str]] = {}
    for full, value in values.items():
        section, key = full.rsplit(".", 1)
        line_text = f"{key} = {_toml_value(value)}"
        note = comments.get(full, "")
        line_text += f"   # {note}" if note else ""
        if section in sections:
            lo, hi = sections[section]
            hit, indent = None, ""
            for i in range(lo + 1, hi + 1):
                m = _KEY.match(lines[i])
                if m and m.group(2) == key:
                    hit = i, m.group(1)
                    break
            if hit is not None:
                i, indent = hit
                edits[i] = [f"{indent}# was: {lines[i].strip()}", indent + line_text]
            else:
                appends.setdefault(section, []).append(line_text)
        else:
            new_sections.setdefault(section, []).append(line_text)
    for full in remove:
        section, key = full.rsplit(".", 1)
        if section not in sections:
            continue
        lo, hi = sections[section]
        for i in range(lo + 1, hi + 1):
            m = _KEY.match(lines[i])
            if m and m.group(2) == key:
                edits[i] = [
                    (
                        f"{m.group(1)}# removed by rig update ({comments.get(full, 'replaced')}): "
                        f"{lines[i].strip()}"
                    )
                ]
    out: list[str] = [f"# {h}" for h in header.splitlines()] if header else []
    # added keys go after the last key line of their section (before trailing comments/blanks)
    after: dict[int, list[str]] = {}
    for section, added in appends.items():
        lo, hi = sections[section]
        keyed = [i for i in range(lo + 1, hi + 1) if _KEY.match(lines[i])]
        after.setdefault(keyed[-1] if keyed else max(lo, 0), []).extend(added)
    for i, line in enumerate(lines):
        out.extend(edits.get(i, [line]))
        out.extend(after.get(i, []))
    for section, added in new_sections.items():
        out += ["", f"[{section}]", *added]
    new = "\n".join(out) + "\n"
    try:
        data = tomllib.loads(new)
    except tomllib.TOMLDecodeError as exc:
        raise UserError(
            f"the updated rig file would not be valid TOML ({exc}): is a fitted section written as an "
            "inline table or dotted keys? edit the rig file by hand"
        ) from None
    for full, value in values.items():
        node: Any = data
        for part in full.split("."):
            node = node.get(part) if isinstance(node, dict) else None
        if node != value and not (
            isinstance(value, float) and isinstance(node, (int, float)) and float(node) == value
        ):
            raise UserError(
                f"could not write {full} into the rig file (is it given as an inline table "
                "or a dotted key?); edit the rig file by hand"
            )
    return new


def rig_file_update(
    text: str,
    linear=None,
    contact=None,
    *,
    sources: Sequence[str] = (),
    modes_used: str = "",
    contact_sources: Sequence[str] = (),
    when: str = "",
    notes: Sequence[str] = (),
) -> str:
    """The updated rig-file text from an :class:`rigtools.sim.parameter_fit.UpdateResult` and/or a
    :class:`rigtools.sim.contact_fit.ContactFitResult`, each key commented with recording, modes and residual;
    ``notes`` go into the header (what the fit moved that its data did not measure)."""
    values: dict[str, float | str] = {}
    comments: dict[str, str] = {}
    remove: list[str] = []
    if linear is not None:
        rms = math.sqrt(2 * linear.cost_after / max(1, linear.residuals_after.size))
        why = (
            f"rig update from {', '.join(sources)} ({modes_used}); max frequency error "
            f"{100 * linear.max_frequency_error_after:.3f} %, rms residual {rms:.3g} sigma"
        )
        fitted = linear.rig_file_values()
        for key, v in fitted.items():
            values[key] = v
            if key in linear.names:
                comments[key] = why
            elif key == "root.kind":
                comments[key] = "springs: root spring(s) fitted by rig update"
            elif key.startswith("root."):
                comments[key] = "not fitted: the stiffest spring a rig file accepts, standing for the clamp"
            else:
                comments[key] = f"follows the fitted {key.split('.')[0]}.mass (same ratio)"
        if "damping.alpha" in fitted and "damping.ratio" not in fitted:
            remove.append("damping.ratio")
            comments["damping.ratio"] = "Rayleigh damping fitted instead"
    if contact is not None:
        why = (
            f"rig update contact fit ({contact.law} law) to {', '.join(contact_sources)}; "
            f"rms harmonic error {100 * contact.rms_log_error_after:.2f} %"
        )
        for key, v in contact.rig_file_values().items():
            values[key] = v
            comments[key] = why
    first = (
        f"updated by rig update{(' on ' + when) if when else ''}: fitted keys are marked; "
        "the original lines follow them as '# was:'"
    )
    header = "\n".join([first, *notes])
    return updated_rig_text(text, values, comments, remove=remove, header=header)


def check_rig_text(text: str, path: str | Path | None = None):
    """Parse the updated text as a rig file (:func:`rigtools.config.parse_rig`); a
    :class:`rigtools.errors.ConfigError` names what the fit produced that the rig file refuses."""
    from rigtools.config import parse_rig

    return parse_rig(tomllib.loads(text), f"updated rig file {path}" if path else "updated rig file")


# ------------------------------------------------------------------------------ the workflow

#: Rig-file keys ``rig update`` may fit (SI), lowest-risk first.
PARAMETER_NAMES = (
    "root.rotational_stiffness",
    "root.translational_stiffness",
    "damping.ratio",
    "damping.alpha",
    "damping.beta",
    "shroud.mass",
    "force_sensor.mass",
    "blade.youngs_modulus",
)
DEFAULT_PARAMETERS = "root.rotational_stiffness,damping.ratio"
#: ``--law`` -> the contact laws fitted (``None``: the rig file's).
CONTACT_LAWS: dict[str, list[ContactLaw | None]] = {
    "rig": [None],
    "linear": ["linear"],
    "hertz": ["hertz"],
    "compare": ["linear", "hertz"],
}
MAX_TARGET_MODES = 10
RMS_WARNING = 2.0  # rms residual (in target uncertainties) above which the fit does not explain the modes


@dataclass
class UpdateOutcome:
    """What :func:`update_rig_file` did.

    Attributes
    ----------
    out
        The updated rig file written.
    text
        Its text.
    recordings
        The modes identified in each test recording.
    paired
        The identified modes used as targets, paired with the nominal model's modes.
    notes
        What the data could not give (a blade without modes, ...).
    fit
        The linear fit (:class:`rigtools.sim.parameter_fit.UpdateResult`).
    dwells
        The dwells the contact was fitted to (empty without ``contact``).
    contact_fit
        The kept contact fit (:class:`rigtools.sim.contact_fit.ContactFitResult`) or ``None``.
    other_laws
        The contact fits with the other laws tried (``law="compare"``).
    scores
        EM-versus-FEM agreement score (1 = identical harmonics) of each dwell: step name
        (``"nominal"``, ``"linear update"``, ``"contact fit"``) -> one score per dwell.
    warnings
        One line each: a fit that does not explain the modes, parameters the data do not
        determine, modes the fit moved that the data did not measure.
    unmeasured
        The modes the fit moved that no target measured
        (:class:`rigtools.sim.unmeasured_modes.UnmeasuredMode`: the other blade's, those outside
        the band, edgewise and torsional ones).
    """

    out: Path
    text: str
    recordings: list[RecordingModes]
    paired: list[PairedMode]
    notes: list[str]
    fit: Any
    dwells: list[DwellData] = field(default_factory=list)
    contact_fit: Any = None
    other_laws: list[Any] = field(default_factory=list)
    scores: dict[str, list[float]] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    unmeasured: list[Any] = field(default_factory=list)

    def to_dict(self) -> dict:
        """The ``rig update --json`` document (numbers in SI, frequencies in Hz)."""
        doc: dict[str, Any] = {
            "file": str(self.out),
            "warnings": self.warnings,
            "recordings": [
                {
                    "file": r.path,
                    "procedure": r.procedure,
                    "sets": [
                        {
                            "point": s.point,
                            "blade": s.blade,
                            "response": s.response,
                            "frequencies_hz": s.frequencies_hz,
                            "damping_ratios": s.damping_ratios,
                            "notes": s.notes,
                        }
                        for s in r.sets
                    ],
                }
                for r in self.recordings
            ],
            "targets": [
                {
                    "blade": p.blade,
                    "order": p.order,
                    "frequency_hz": p.frequency_hz,
                    "damping_ratio": p.damping_ratio,
                    "model_hz": p.model_hz,
                    "sources": p.sources,
                }
                for p in self.paired
            ],
            "notes": self.notes,
            "fit": self.fit.as_dict(),
            "moved_not_measured": [m.as_dict() for m in self.unmeasured],
        }
        if self.dwells:
            doc["contact_fit"] = self.contact_fit.as_dict()
            doc["contact_fit_other_laws"] = [r.as_dict() for r in self.other_laws]
            doc["agreement"] = {"dwells": [d.name for d in self.dwells], **self.scores}
        return doc


def _no_status(text: str) -> AbstractContextManager[None]:
    return nullcontext()


def update_rig_file(
    recordings: Sequence[str | Path],
    out: str | Path,
    *,
    rig: str | Path | None = None,
    parameters: str | Sequence[str] = DEFAULT_PARAMETERS,
    modes: int = 3,
    band: str | tuple[float, float] | None = None,
    damping: bool = True,
    contact: Sequence[str | Path] = (),
    law: str = "rig",
    overwrite: bool = False,
    status: Callable[[str], AbstractContextManager[Any]] | None = None,
    when: str | None = None,
) -> UpdateOutcome:
    """Fit a rig file's model to test recordings and write the updated rig file (``rig update``).

    Parameters
    ----------
    recordings
        FRF tests (``rig acquire frf``) and tap tests: modes are identified in each.
    out
        The updated rig file to write (``.toml``); never one of the inputs.
    rig
        Rig file to update; ``None``: the calibrated default rig.
    parameters
        Rig-file keys to fit (:data:`PARAMETER_NAMES`), a sequence or ``"a,b"`` text.
    modes
        Flexural modes per blade used as targets, lowest first, 1 to 10.
    band
        Band searched for modes, ``(low, high)`` in Hz or ``"20 Hz:2 kHz"``; ``None``: each test's.
    damping
        Fit the identified damping ratios too (``False``: frequencies only).
    contact
        Force-controlled dwells with impacts: fit the contact stiffness and damping to them.
    law
        Contact law to fit: ``"rig"`` (the rig file's), ``"linear"``, ``"hertz"`` or ``"compare"``
        (both, the better kept).
    overwrite
        Replace ``out`` if it exists.
    status
        ``status(text)`` returns a context manager shown around each long step (a spinner);
        ``None``: nothing shown.
    when
        Time stamp written into the file's header; default: now (UTC).

    Returns
    -------
    UpdateOutcome

    Raises
    ------
    UserError
        One line: unknown parameter, bad band or mode count, unreadable recording, a recording
        without usable modes, ``out`` existing or an input.
    """
    import datetime as _dt

    from rigtools.config import default_rig_text, load_rig, read_rig_text
    from rigtools.options import RIG_FILE_SUFFIXES, band_option, output_path

    show = status or _no_status
    names = parse_names(parameters if isinstance(parameters, str) else ",".join(parameters), PARAMETER_NAMES)
    if isinstance(modes, bool) or not isinstance(modes, int) or not 1 <= modes <= MAX_TARGET_MODES:
        raise UserError(f"--modes = {modes!r}: use 1..{MAX_TARGET_MODES}")
    f_min: float | None = None
    f_max: float | None = None
    if band is not None:
        f_min, f_max = band if isinstance(band, tuple) else band_option(band, "--band", allow_zero=False)
    if law not in CONTACT_LAWS:
        raise UserError(f"--law = {law!r}: use one of {', '.join(CONTACT_LAWS)}")
    tests = [str(p) for p in recordings]
    dwell_files = [str(p) for p in contact]
    inputs = [*tests, *dwell_files] + ([str(rig)] if rig else [])
    out_path = output_path(str(out), overwrite, "--out", suffixes=RIG_FILE_SUFFIXES, inputs=inputs)
    for path in inputs:
        if not Path(path).exists():
            raise UserError(f"{path}: no such file")

    cfg = load_rig(None if rig is None else str(rig))
    text = read_rig_text(str(rig)) if rig else default_rig_text()
    nominal = cfg.to_params()
    found = []
    for i, path in enumerate(tests):
        with show(f"identifying modes in {Path(path).name} ({i + 1}/{len(tests)})"):
            found.append(identify_recording(path, f_min=f_min, f_max=f_max))
    dwells: list[DwellData] = []
    for path in dwell_files:
        with show(f"reading dwell {Path(path).name}"):
            dwells.extend(read_dwell(path))
    targets, paired, notes = mode_targets(nominal, found, max_modes=modes, damping=damping)
    with show(f"fitting {', '.join(names)} to {len(targets)} modes"):
        res = fit_linear(nominal, targets, names)

    scores: dict[str, list[float]] = {}
    cres, others = None, []
    if dwells:
        from rigtools.sim.reduction import reduced_system

        with show("EM-versus-FEM score of the nominal model"):
            scores["nominal"] = [agreement(d, model_dwell(nominal, d)).score for d in dwells]
        linear_system = reduced_system(res.params, "fem")
        with show("EM-versus-FEM score after the linear update"):
            scores["linear update"] = [
                agreement(d, model_dwell(res.params, d, system=linear_system)).score for d in dwells
            ]
        fits = []
        for one_law in CONTACT_LAWS[law]:
            with show(
                f"fitting the contact ({one_law or res.params.contact.law} law) to {len(dwells)} dwell(s): "
                "vibro-impact runs"
            ):
                fits.append(fit_contact_to_dwells(res.params, dwells, law=one_law))
        cres = min(fits, key=lambda r: r.cost_after)
        others = [r for r in fits if r is not cres]
        with show("EM-versus-FEM score after the contact fit"):
            scores["contact fit"] = [
                agreement(d, model_dwell(cres.params, d, system=linear_system)).score for d in dwells
            ]

    from rigtools.sim.unmeasured_modes import header_lines, moved_not_measured, summary_line

    bands = [r.band for r in found if r.band is not None]
    fitted_band = (f_min, f_max) if f_min is not None and f_max is not None else None
    if fitted_band is None and bands:
        fitted_band = (min(b[0] for b in bands), max(b[1] for b in bands))
    with show("modes the fit moved that the data did not measure"):
        unmeasured = moved_not_measured(
            nominal, res.params, [(p.blade, p.order) for p in paired], fitted_band
        )
    new_text = rig_file_update(
        text,
        res,
        cres,
        notes=header_lines(unmeasured),
        sources=[Path(p).name for p in tests],
        modes_used=", ".join(f"{p.blade} f{p.order} {p.frequency_hz:.2f} Hz" for p in paired),
        contact_sources=[Path(p).name for p in dwell_files],
        when=when or _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC"),
    )
    check_rig_text(new_text, out_path)
    from rigtools.derived_files import atomic_write

    atomic_write(out_path, lambda tmp: tmp.write_text(new_text, encoding="utf-8"))

    warnings = []
    rms = (2 * res.cost_after / max(1, res.residuals_after.size)) ** 0.5
    if rms > RMS_WARNING:
        warnings.append(
            f"the fitted parameters do not explain the identified modes: rms residual {rms:.3g} x "
            f"their uncertainty (frequencies 0.1 %, damping 10 %), largest frequency error "
            f"{100 * res.max_frequency_error_after:.3f} %; the model lacks what differs on the rig "
            "(try the root springs or the masses)"
        )
    warnings += [f"not determined by the data: {line}" for line in res.identifiability.unresolved]
    if unmeasured:
        warnings.append(summary_line(unmeasured))
    return UpdateOutcome(
        out=out_path,
        text=new_text,
        recordings=found,
        paired=paired,
        notes=notes,
        fit=res,
        dwells=dwells,
        contact_fit=cres,
        other_laws=others,
        scores=scores,
        warnings=warnings,
        unmeasured=unmeasured,
    )
