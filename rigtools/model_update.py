"""``rig update`` behind the command line: recordings -> targets -> fits -> an updated rig file
(:func:`update_rig_file`, :class:`UpdateOutcome`), and the front door's :func:`update_model` (the
same from a lab script, quantity strings or SI floats).

The steps live in three modules:

* :mod:`rigtools.update_modes`: natural frequencies and damping ratios of every broadband point of
  a recording (an FRF test, ``rig acquire frf``; a tap/hammer test), per blade, the very FRF and
  modes ``rig analyze`` reports (:func:`~rigtools.update_modes.identify_recording`); those modes
  paired with the model's flexural modes, the same mode seen by several recordings merged
  (:func:`~rigtools.update_modes.mode_targets`); the linear fit
  (:func:`~rigtools.update_modes.fit_linear`).
* :mod:`rigtools.update_contact`: force-controlled dwells with impacts (``rig acquire dwell``) as
  harmonic targets, the model's harmonics at the measured force, the EM-versus-FEM score of a
  dwell and the contact fit (vibro-impact integrator in the loop).
* :mod:`rigtools.update_rig_text`: the original rig-file text with the fitted keys replaced or
  added, each commented with its origin, checked to load and to hold exactly the fitted values.

This module's head stays light: ``rig update --help`` imports it for the choices below
(:data:`PARAMETER_NAMES`, :data:`CONTACT_LAWS`); the fit's modules load when a fit runs (0.7 s
against 11 s on a loaded 2-core machine).
"""

from __future__ import annotations

import datetime
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from rigtools.errors import UserError
from rigtools.options import RIG_FILE_SUFFIXES, band_option, output_path, quantity, switch

if TYPE_CHECKING:
    from rigtools.update_contact import DwellData
    from rigtools.update_modes import PairedMode, RecordingModes

ContactLaw = Literal["linear", "hertz"]


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
    # the fit's modules, loaded when a fit runs (see the module docstring)
    from rigtools.config import default_rig_text, load_rig, read_rig_text
    from rigtools.derived_files import atomic_write
    from rigtools.sim.unmeasured_modes import header_lines
    from rigtools.update_contact import read_dwell
    from rigtools.update_modes import fit_linear, identify_recording, mode_targets
    from rigtools.update_rig_text import check_rig_text, rig_file_update

    show = status or _no_status
    names, f_min, f_max, out_path = _checked_arguments(
        recordings, out, rig, parameters, modes, band, contact, law, overwrite
    )
    tests = [str(p) for p in recordings]
    dwell_files = [str(p) for p in contact]
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
    cres, others, scores = _contact_update(nominal, res, dwells, law, show)
    unmeasured = _moved_not_measured(nominal, res, found, paired, f_min, f_max, show)
    new_text = rig_file_update(
        text,
        res,
        cres,
        notes=header_lines(unmeasured),
        sources=[Path(p).name for p in tests],
        modes_used=", ".join(f"{p.blade} f{p.order} {p.frequency_hz:.2f} Hz" for p in paired),
        contact_sources=[Path(p).name for p in dwell_files],
        when=when or datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC"),
    )
    check_rig_text(new_text, out_path)
    atomic_write(out_path, lambda tmp: tmp.write_text(new_text, encoding="utf-8"))
    warnings = _warnings(res, unmeasured)
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


def _checked_arguments(
    recordings: Sequence[str | Path],
    out: str | Path,
    rig: str | Path | None,
    parameters: str | Sequence[str],
    modes: int,
    band: str | tuple[float, float] | None,
    contact: Sequence[str | Path],
    law: str,
    overwrite: bool,
) -> tuple[list[str], float | None, float | None, Path]:
    """``(parameter names, f_min, f_max, out path)`` of :func:`update_rig_file`'s arguments, each
    refused in one line when wrong (before any work)."""
    names = parse_names(parameters if isinstance(parameters, str) else ",".join(parameters), PARAMETER_NAMES)
    if isinstance(modes, bool) or not isinstance(modes, int) or not 1 <= modes <= MAX_TARGET_MODES:
        raise UserError(f"--modes = {modes!r}: use 1..{MAX_TARGET_MODES}")
    f_min: float | None = None
    f_max: float | None = None
    if band is not None:
        f_min, f_max = band if isinstance(band, tuple) else band_option(band, "--band", allow_zero=False)
    if law not in CONTACT_LAWS:
        raise UserError(f"--law = {law!r}: use one of {', '.join(CONTACT_LAWS)}")
    inputs = [str(p) for p in recordings] + [str(p) for p in contact] + ([str(rig)] if rig else [])
    out_path = output_path(str(out), overwrite, "--out", suffixes=RIG_FILE_SUFFIXES, inputs=inputs)
    for path in inputs:
        if not Path(path).exists():
            raise UserError(f"{path}: no such file")
    return names, f_min, f_max, out_path


def _contact_update(nominal, res, dwells: list[DwellData], law: str, show) -> tuple[Any, list, dict]:
    """``(kept contact fit, other laws' fits, scores)``: the contact fitted to the dwells after the
    linear update, with the EM-versus-FEM score of each dwell before and after each step (nothing
    without dwells)."""
    from rigtools.sim.reduction import reduced_system
    from rigtools.update_contact import agreement, fit_contact_to_dwells, model_dwell

    scores: dict[str, list[float]] = {}
    if not dwells:
        return None, [], scores
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
    return cres, others, scores


def _moved_not_measured(nominal, res, found, paired, f_min: float | None, f_max: float | None, show) -> list:
    """The modes the fit moved that no target measured, in the band fitted (the one asked for,
    else the tests' bands together)."""
    from rigtools.sim.unmeasured_modes import moved_not_measured

    bands = [r.band for r in found if r.band is not None]
    fitted_band = (f_min, f_max) if f_min is not None and f_max is not None else None
    if fitted_band is None and bands:
        fitted_band = (min(b[0] for b in bands), max(b[1] for b in bands))
    with show("modes the fit moved that the data did not measure"):
        return moved_not_measured(nominal, res.params, [(p.blade, p.order) for p in paired], fitted_band)


def _warnings(res, unmeasured: list) -> list[str]:
    """One line each: a fit that does not explain the modes, parameters the data do not determine,
    modes the fit moved that the data did not measure."""
    from rigtools.sim.unmeasured_modes import summary_line

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
    return warnings


# ------------------------------------------------------------------------------ the front door


def update_model(
    recordings: str | Path | Sequence[str | Path],
    out: str | Path,
    *,
    rig: str | Path | None = None,
    parameters: str | Sequence[str] | None = None,
    modes: int = 3,
    band: tuple[float | str, float | str] | str | None = None,
    damping: bool = True,
    contact: Sequence[str | Path] = (),
    law: str = "rig",
    overwrite: bool = False,
) -> UpdateOutcome:
    """Fit the rig file's model to test recordings and write the updated rig file (``rig update``).

    Parameters
    ----------
    recordings
        FRF tests and tap tests: the modes identified in them are the targets.
    out
        The updated rig file to write (``.toml``).
    rig
        Rig file to update; ``None``: the calibrated default rig.
    parameters
        Rig-file keys fitted (:data:`rigtools.model_update.PARAMETER_NAMES`); ``None``: the default set.
    modes
        Flexural modes per blade used as targets, lowest first.
    band
        ``(low, high)`` searched for modes, e.g. ``("20 Hz", "2 kHz")`` or the CLI's
        ``"20 Hz:2 kHz"``; ``None``: each test's band.
    damping
        Fit the identified damping ratios too.
    contact
        Force-controlled dwells with impacts: fit the contact stiffness and damping to them.
    law
        Contact law fitted: ``"rig"``, ``"linear"``, ``"hertz"`` or ``"compare"``.
    overwrite
        Replace ``out`` if it exists.

    Returns
    -------
    UpdateOutcome
        ``out`` (the file written), ``paired`` (targets with the nominal model's modes), ``fit``.

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> tap = rigtools.tap_test("85 mm", folder / "tap.h5", hits=2, gap="5 mm", backend="sim", seed=1)
    >>> done = rigtools.update_model([tap.file], folder / "updated.toml", modes=2)
    >>> done.out.name, rigtools.load_rig(done.out).name != ""
    ('updated.toml', True)
    """
    files = [recordings] if isinstance(recordings, str | Path) else list(recordings)
    if not files:
        raise UserError("recordings = []: give at least one test recording (an FRF test or a dwell)")
    span = None
    if isinstance(band, str):
        span = band_option(band, "band")
    elif band is not None:
        span = (quantity(band[0], "frequency", "band"), quantity(band[1], "frequency", "band"))
    return update_rig_file(
        files,
        out,
        rig=rig,
        parameters=DEFAULT_PARAMETERS if parameters is None else parameters,
        modes=modes,
        band=span,
        damping=switch(damping, "damping"),
        contact=contact,
        law=law,
        overwrite=overwrite,
    )
