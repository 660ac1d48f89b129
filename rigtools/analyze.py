"""Recording-level analysis: what ``rig analyze`` and ``rig report`` show of a recording.

:func:`analyze_recording` reads a recording point by point and dispatches on what each point is:

- a **periodic point** (a sine dwell, a step of a stepped sine, a point of a study, a model run
  of ``rig simulate``/``rig study``; it has ``fe``): harmonics k = 1..30 of every channel (peak
  amplitude and phase, also relative to the force fundamental), peak levels and impacts
  (:func:`rigtools.analysis.point.analyze_dwell`). No modes: a sine excites one frequency at a time.
- a **broadband point** (an FRF test with burst random or periodic chirp: ``frame_samples`` and
  ``signal``; or any record without ``fe`` holding a force, such as a tap test or free decay):
  H1, H2, Hv and coherence of every response over the force as receptance, mobility or
  accelerance, and the modes the data support (:func:`rigtools.analysis.point.analyze_frf_test`: LSCF with
  a stabilisation check, or peak picking).

A series of periodic points at different ``fe`` (a stepped sine) also gives the response curves
over frequency: the first-harmonic FRF ``X1 / F1`` of every response and every harmonic's
amplitude against ``fe`` (:meth:`RecordingAnalysis.response_curves`).

Samples are read in blocks (:data:`BLOCK_SAMPLES`): harmonics and FRFs accumulate block by block
(bounded memory for any record length); impacts and waveform figures use the last
:data:`WINDOW_SAMPLES` samples of a periodic record.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rigtools.errors import UserError, in_script_words
from rigtools.recording.schema import SINE_PROCEDURES
from rigtools.vocabulary import excitation_frequency

if TYPE_CHECKING:
    from rigtools.analysis.frf import FRFKind

BLOCK_SAMPLES = 1 << 18  # samples per channel read at a time
WINDOW_SAMPLES = 1 << 21  # at most this many samples per channel held for impacts and plots
K_MAX = 30
TABLE_HARMONICS = (6, 8, 22)  # the paper's super-harmonics of interest
KINDS: tuple[FRFKind, ...] = ("accelerance", "mobility", "receptance")
METHODS = ("lscf", "peak")
from rigtools.sim.channel_names import ACTIVE_SHROUD_ACCEL, FORCE, PASSIVE_SHROUD_ACCEL
from rigtools.sim.channel_names import BLADE_OF as _BLADE_OF

NO_MODES_PERIODIC = (
    "no modes from a sine record: a sine excites one frequency at a time, so the "
    "force has no broadband content to identify poles from (use rig acquire frf)"
)
PROCEDURE_FRF = ("frf test",)
PASSIVE_NOT_EXCITED = (
    "the passive blade was not excited: the shaker drives the active blade, and with the gap open "
    "no force reaches the passive one, so it shows no modes here (identify them with a tap test: "
    "rig acquire tap --blade passive)"
)
TAP_DEFAULT_PULSE_S = 0.5e-3  # hammer pulse when the recording does not say
TAP_F_MIN_HZ = 5.0


@dataclass
class PointAnalysis:
    """One analysed point.

    Attributes
    ----------
    index
        Point number in the recording.
    kind
        ``"periodic"`` or ``"broadband"``.
    params
        The point's parameters (vocabulary names).
    units
        ``{channel: units}``.
    window
        ``(first sample, samples)`` analysed.
    dwell
        :class:`rigtools.analysis.point.DwellAnalysis` (periodic points).
    frf
        :class:`rigtools.analysis.point.FRFTestAnalysis` (broadband points).
    excitation
        The FRF estimate of a broadband point (``"burst"``, ``"periodic"``, ``"impact"``,
        ``"random"``; ``"measured FRF"`` for an FRF set).
    notes
        Sentences on what was not done and why.
    spectra
        Per channel :class:`rigtools.analysis.spectra.ResponseSpectra` (points without a force).
    oma
        :class:`rigtools.analysis.oma.OMAResult` of the motion channels of a point without a
        force (modes and harmonic tones), None when it has none.
    """

    index: int
    kind: str
    params: dict[str, Any]
    units: dict[str, str]
    sample_rate: float
    window: tuple[int, int]
    dwell: Any = None
    frf: Any = None
    excitation: str = ""
    notes: list[str] = field(default_factory=list)
    spectra: dict[str, Any] | None = None
    oma: Any = None

    @property
    def fe(self) -> float | None:
        return self.params.get("fe")

    def harmonic(self, channel: str, k: int) -> float | None:
        """Peak amplitude of harmonic ``k`` of ``channel`` (None if not analysed)."""
        if self.dwell is None or channel not in self.dwell.harmonics:
            return None
        fit = self.dwell.harmonics[channel]
        return float(fit.amplitude[k - 1]) if k <= fit.amplitude.size else None

    def to_dict(self) -> dict:
        out = {
            "point": self.index,
            "kind": self.kind,
            "sample_rate": self.sample_rate,
            "window": {"start_sample": self.window[0], "samples": self.window[1]},
            "params": _plain(self.params),
            "units": dict(self.units),
            "notes": list(self.notes),
        }
        if self.dwell is not None:
            out["dwell"] = _plain(self.dwell.to_dict())
            out["modes"] = None
        if self.spectra is not None:
            out["spectra"] = _plain({c: s.to_dict() for c, s in self.spectra.items()})
        if self.kind == "operational":
            out["oma"] = None if self.oma is None else _plain(self.oma.to_dict())
        if self.frf is not None:
            out["frf"] = self.frf_dict()
        return out

    def frf_dict(self) -> dict:
        """The ``"frf"`` part of :meth:`to_dict` (broadband points): the estimate's method, mean
        coherence in the band, and per response the modes, each with its coherence and the FRF
        at its peak (``frf_at_peak``: ``re``, ``im`` of H1 in the reported kind at the bin of
        the peak it explains). ``rig compare --json`` shows the same for its EM modes."""
        d = self.frf.to_dict()
        d["excitation"] = self.excitation
        if self.frf.frf_method is not None:
            d["frf_method"] = self.frf.frf_method.to_dict(self.sample_rate)
        d["mean_coherence"] = {
            r: float(np.mean(self.frf.estimate.coherence[i][self._band()]))
            for i, r in enumerate(self.frf.responses)
        }
        for r, m in d["modes"].items():
            i = self.frf.responses.index(r)
            for mode in m["modes"]:
                mode["coherence"] = self.coherence_at(i, mode["frequency_hz"])
                peak = mode["evidence"].get("peak_hz")
                h = self.frf_at(i, peak if peak is not None and np.isfinite(peak) else mode["frequency_hz"])
                mode["frf_at_peak"] = {"re": h.real, "im": h.imag}
        return _plain(d)

    def _band(self) -> np.ndarray:
        f = self.frf.estimate.frequency_hz
        lo, hi = self.params.get("band_low", f[1] if f.size > 1 else 0.0), self.params.get("band_high", f[-1])
        band = (f >= lo) & (f <= hi)
        return band if band.any() else np.ones_like(f, bool)

    def frf_at(self, row: int, frequency_hz: float) -> complex:
        """H1 of response ``row`` (the reported kind) at the bin nearest ``frequency_hz``."""
        f = self.frf.estimate.frequency_hz
        return complex(self.frf.estimate.h1[row][int(np.argmin(np.abs(f - frequency_hz)))])

    def coherence_at(self, row: int, frequency_hz: float) -> float:
        """Coherence of response ``row`` at the bin nearest ``frequency_hz``."""
        f = self.frf.estimate.frequency_hz
        return float(self.frf.estimate.coherence[row][int(np.argmin(np.abs(f - frequency_hz)))])


@dataclass
class RecordingAnalysis:
    """A whole recording analysed (:func:`analyze_recording`)."""

    path: str
    procedure: str
    backend: str
    source: str
    status: str
    frf_kind: FRFKind
    points: list[PointAnalysis]
    skipped: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    frequency_table: list[dict] | None = None

    @property
    def periodic(self) -> list[PointAnalysis]:
        return [p for p in self.points if p.kind == "periodic"]

    @property
    def broadband(self) -> list[PointAnalysis]:
        return [p for p in self.points if p.kind == "broadband"]

    @property
    def operational(self) -> list[PointAnalysis]:
        return [p for p in self.points if p.kind == "operational"]

    def response_curves(self) -> dict | None:
        """Response curves of a stepped sine or study (None unless there are two or more periodic
        points; ``frf`` is a curve over frequency only when their ``fe`` differ): ``{"fe": (n,), "direction": [...], "frf": {response: (n,) complex
        X1/F1 in the recording's FRF kind}, "harmonics": {channel: (n, K) peak amplitudes}}``."""
        pts = [p for p in self.periodic if p.fe]
        if len(pts) < 2:
            return None
        fe = np.array([p.params["fe"] for p in pts], dtype=float)
        channels = [c for c in pts[0].dwell.harmonics if all(c in p.dwell.harmonics for p in pts)]
        k = min(p.dwell.harmonics[c].amplitude.size for p in pts for c in channels)
        harm = {c: np.array([p.dwell.harmonics[c].amplitude[:k] for p in pts]) for c in channels}
        frf = {}
        if FORCE in channels:
            from rigtools.analysis.frf import convert_frf

            f1 = np.array(
                [
                    p.dwell.harmonics[FORCE].amplitude[0] * np.exp(1j * p.dwell.harmonics[FORCE].phase[0])
                    for p in pts
                ]
            )
            for c in channels:
                measured = _frf_kind_of(pts[0].units.get(c, ""))
                if c == FORCE or measured is None:
                    continue
                x1 = np.array(
                    [
                        p.dwell.harmonics[c].amplitude[0] * np.exp(1j * p.dwell.harmonics[c].phase[0])
                        for p in pts
                    ]
                )
                frf[c] = convert_frf(x1 / f1, fe, measured, self.frf_kind)
        return {
            "fe": fe,
            "direction": [p.params.get("direction", "") for p in pts],
            "frf": frf,
            "harmonics": harm,
            "units": dict(pts[0].units),
        }

    def point_rows(self) -> list[dict]:
        """One row per periodic point: fe, force, the 6/8/22 fe harmonics, impacts per period."""
        rows = []
        for p in self.periodic:
            row = {
                "point": p.index,
                "fe (Hz)": p.fe,
                "F0 target, peak (N)": p.params.get("force_amplitude"),
                "F1 measured, peak (N)": p.dwell.force_amplitude,
            }
            if "gap" in p.params:
                row["gap (mm)"] = float(p.params["gap"]) * 1e3
            for ch, short in (("active_shroud_accel", "active"), ("passive_shroud_accel", "passive")):
                if ch in p.dwell.harmonics:
                    for k in TABLE_HARMONICS:
                        row[f"{short} {k}·fe, peak (m/s²)"] = p.harmonic(ch, k)
            imp = p.dwell.impacts
            row["impacts/period"] = None if imp is None else float(imp.impacts_per_period)
            row["settled"] = p.params.get("settled")
            rows.append(row)
        return rows

    def mode_rows(self) -> list[dict]:
        """One row per identified mode of every broadband point and response."""
        rows = []
        for p in self.broadband:
            for i, r in enumerate(p.frf.responses):
                m = p.frf.modes[r]
                for j, mode in enumerate(m.modes):
                    rows.append(
                        {
                            "point": p.index,
                            "response": r,
                            "mode": j + 1,
                            "natural frequency (Hz)": mode.frequency_hz,
                            "damping ratio (%)": 100 * mode.damping_ratio,
                            "coherence": p.coherence_at(i, mode.frequency_hz),
                            "method": m.method,
                        }
                    )
        return rows

    def to_dict(self) -> dict:
        out = {
            "file": self.path,
            "procedure": self.procedure,
            "backend": self.backend,
            "source": self.source,
            "status": self.status,
            "frf_kind": self.frf_kind,
            "amplitude": "peak",
            "points": [p.to_dict() for p in self.points],
            "skipped": list(self.skipped),
            "notes": list(self.notes),
            "natural_frequencies": _plain(self.frequency_table),
        }
        curves = self.response_curves()
        if curves is not None:
            out["response_curves"] = {
                "fe": curves["fe"].tolist(),
                "direction": curves["direction"],
                "frf": {
                    c: {"magnitude": np.abs(h).tolist(), "phase": np.angle(h).tolist()}
                    for c, h in curves["frf"].items()
                },
                "harmonics": {c: a.tolist() for c, a in curves["harmonics"].items()},
            }
        return out


def _plain(obj: Any) -> Any:
    """numpy scalars/arrays to plain Python for JSON; non-finite floats to None."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    return obj


_FRF_KIND_OF_UNITS: dict[str, FRFKind] = {"m/s^2": "accelerance", "m/s": "mobility", "m": "receptance"}


def _frf_kind_of(units: str) -> FRFKind | None:
    return _FRF_KIND_OF_UNITS.get(units)


def frf_kind(kind: str) -> FRFKind:
    """``kind`` checked against :data:`KINDS`; a :class:`UserError` naming them otherwise."""
    for k in KINDS:
        if k == kind:
            return k
    raise UserError(f"--kind {kind!r}: use one of {', '.join(KINDS)}")


def _blocks(
    point, names: Sequence[str], start: int, n: int, size: int = BLOCK_SAMPLES
) -> Iterator[np.ndarray]:
    """``(len(names), m)`` blocks of samples ``start .. start + n`` in time order."""
    for a in range(start, start + n, size):
        b = min(start + n, a + size)
        yield np.vstack([np.asarray(point.channels[c][a:b], dtype=float) for c in names])


def record_window(point) -> tuple[int, int]:
    """``(first sample, samples)`` of the point's record window (``record_start`` s and
    ``record_samples``), else the whole point: :attr:`rigtools.recording.reader.Point.record_window`."""
    return point.record_window


def force_channel(point) -> str | None:
    """The force channel: the point's ``reference_channel`` (an import's excitation, found from
    its quantity or named with ``--reference``), ``force`` (vocabulary), else the only channel
    of quantity force."""
    named = point.params.get("reference_channel")
    if isinstance(named, str) and named in point.channels:
        return named
    if FORCE in point.channels:
        return FORCE
    forces = [n for n, c in point.channels.items() if c.quantity == "force" and n != "contact_force"]
    return forces[0] if len(forces) == 1 else None


def response_channels(point, force: str | None) -> list[str]:
    """Channels analysed as responses of a broadband point: the shroud accelerations (or any
    acceleration, velocity or displacement channel), not the force, drive or contact force."""
    out = [
        n
        for n, c in point.channels.items()
        if n != force and _frf_kind_of(c.units) is not None and c.quantity != "force"
    ]
    vocab = [n for n in out if n in ("active_shroud_accel", "passive_shroud_accel")]
    return vocab or out


def analyze_periodic(point, *, channels: Sequence[str] | None = None, k_max: int = K_MAX) -> PointAnalysis:
    """Harmonics (whole record window, in blocks), peak levels and impacts (last
    :data:`WINDOW_SAMPLES`) of a point with ``fe``."""
    from rigtools.analysis.harmonics import harmonics_from_blocks, relative_phases
    from rigtools.analysis.point import analyze_dwell

    fe = float(point.params["fe"])
    rate = float(point.sample_rate)
    names = list(channels or point.channels)
    start, n = record_window(point)
    notes = []
    k = max(1, min(int(k_max), int(np.floor(rate / 2 / fe - 1e-9))))
    if k < k_max:
        notes.append(f"harmonics up to k = {k}: {k + 1}·fe is above the Nyquist frequency {rate / 2:g} Hz")
    if n < 2 * k + 1:
        raise UserError(f"point {point.index}: {n} samples in the record window, too few for {k} harmonics")
    # impacts and peaks from the last whole periods that fit in WINDOW_SAMPLES
    per = rate / fe
    m = n if n <= WINDOW_SAMPLES else int(np.floor(WINDOW_SAMPLES / per) * per)
    a = start + n - m
    arrays = {c: np.asarray(point.channels[c][a : a + m], dtype=float) for c in names}
    dwell = analyze_dwell(arrays, rate, fe, k_max=k, force=FORCE)
    if m < n:  # harmonics over the whole window, block by block
        fits = dict(
            zip(names, harmonics_from_blocks(_blocks(point, names, start, n), rate, fe, k), strict=True)
        )
        rel = {c: relative_phases(f, fits[FORCE]) for c, f in fits.items()} if FORCE in fits else {}
        dwell = replace(
            dwell,
            harmonics=fits,
            phases_to_force=rel,
            force_amplitude=float(fits[FORCE].amplitude[0]) if FORCE in fits else None,
        )
        notes.append(f"impacts and peak levels from the last {m} of {n} samples; harmonics over all")
    notes.append(NO_MODES_PERIODIC)
    return PointAnalysis(
        point.index,
        "periodic",
        dict(point.params),
        {c: point.channels[c].units for c in names},
        rate,
        (start, n),
        dwell=dwell,
        notes=notes,
    )


EXCITATIONS = ("burst", "impact", "periodic", "random")
FOREIGN_PROCEDURES = ("import",)
#: the estimate of a recorded broadband test (``frame_samples`` and ``signal``) by its drive
#: signal; any other signal with recorded frames (a tap test's ``tap``) is taken frame by frame
#: as a burst
SIGNAL_EXCITATION = {"chirp": "periodic", "periodic": "periodic", "burst": "burst", "random": "random"}


def is_foreign(experiment: dict) -> bool:
    """True for a recording written elsewhere and imported (``rig import``): it does not describe
    this rig, so it is compared with the rig's FEM only when asked."""
    return str((experiment or {}).get("procedure", "")) in FOREIGN_PROCEDURES


def frf_method_of(
    point,
    force: str,
    start: int,
    n: int,
    *,
    excitation: str | None = None,
    frame_samples: int | None = None,
    force_window: float | None = None,
    exponential: float | None = None,
):
    """The FRF estimate of a broadband point (:class:`rigtools.analysis.frf.FRFMethod`): the one
    choice ``rig analyze``, ``rig report``, ``rig export uff``, ``rig compare``, ``rig update``,
    the procedures' checks and the front door share.

    - ``rig acquire frf`` points (``frame_samples`` and ``signal``): burst random, one frame per
      burst period, or periodic chirp over whole periods (:data:`SIGNAL_EXCITATION`);
      rectangular window.
    - other records (a tap record, a recording imported from elsewhere): from the force's content,
      hits of a hammer (one frame per hit) or continuous random (Hann, 50 % overlap), see
      :func:`rigtools.analysis.frf.method_from_content`.
    - ``excitation`` (and ``frame_samples``) override the choice; ``force_window`` and
      ``exponential`` apply to impacts.

    An override that would not change the estimate is refused in one line, never ignored:
    ``frame_samples`` without ``excitation`` on a recorded test or with an impact estimate (its
    frames follow the hits), windows with an estimate other than impact.
    """
    from rigtools.analysis.frf import FRFMethod, impact_method, method_from_content, random_frame_samples

    if excitation is not None and excitation not in EXCITATIONS:
        raise UserError(f"--excitation {excitation!r}: use one of {', '.join(EXCITATIONS)}")
    windows = [
        o for o, v in (("--force-window", force_window), ("--exponential", exponential)) if v is not None
    ]
    if windows and excitation not in (None, "impact"):
        raise UserError(f"{' and '.join(windows)} apply to impact tests, not to --excitation {excitation}")
    rate = float(point.sample_rate)
    recorded = "frame_samples" in point.params
    if excitation is None and recorded:
        signal = str(point.params.get("signal", "")).lower()
        kind = SIGNAL_EXCITATION.get(signal, "burst")
        given = (["--frame-samples"] if frame_samples is not None else []) + windows
        if given:
            raise UserError(
                f"point {point.index}: {' and '.join(given)} would be ignored: its FRF is the recorded "
                f"{signal or 'burst'} test's ({kind}, {point.params['frame_samples']}-sample frames); "
                "give --excitation to estimate it otherwise"
            )
        return FRFMethod(
            kind, int(point.params["frame_samples"]), reason=f"recorded {signal or 'burst'} test"
        )
    if excitation in ("burst", "periodic"):
        seg = frame_samples or (int(point.params["frame_samples"]) if recorded else None)
        if seg is None:
            raise UserError(f"--excitation {excitation} needs the frame length (--frame-samples)")
        return FRFMethod(excitation, int(seg), reason="asked for")
    if n > WINDOW_SAMPLES:
        raise UserError(
            f"point {point.index}: {n} samples without a recorded frame length; records up to "
            f"{WINDOW_SAMPLES} samples are read whole to find the excitation (give --excitation "
            "and --frame-samples)"
        )
    x = np.asarray(point.channels[force][start : start + n], dtype=float)
    try:
        if excitation == "random":
            return FRFMethod("random", int(frame_samples or random_frame_samples(n)), reason="asked for")
        if excitation == "impact" or windows:
            method = impact_method(
                x, rate, force_window=force_window, exponential=exponential, reason="asked for"
            )
        else:
            method = method_from_content(x, rate, frame_samples=frame_samples)
    except ValueError as exc:
        raise UserError(f"point {point.index}: {exc}") from None
    if method.excitation == "impact" and frame_samples is not None:
        raise UserError(
            f"--frame-samples {frame_samples}: point {point.index} is an impact test, one frame per "
            f"hit as long as the hits' spacing ({method.frame_samples} samples); leave it out"
        )
    return method


def frf_blocks(point, names: Sequence[str], start: int, n: int, method) -> Iterator[dict]:
    """``{channel: samples}`` blocks of a point for :func:`rigtools.analysis.point.analyze_frf_test`:
    one block per frame for an impact method, else the record window in blocks."""
    if method.excitation == "impact":
        for s in method.frame_starts:
            a = start + int(s)
            yield {c: np.asarray(point.channels[c][a : a + method.frame_samples], dtype=float) for c in names}
        return
    for b in _blocks(point, names, start, n):
        yield dict(zip(names, b, strict=True))


def analyze_operational(
    point,
    *,
    fe: float | None = None,
    channels: Sequence[str] | None = None,
    band: tuple[float, float] | None = None,
) -> PointAnalysis:
    """A point without a force channel (an operational log): per channel the PSD, the
    peak-amplitude spectrum, the peaks of the PSD and, with ``fe``, the harmonics k·fe
    (:func:`rigtools.analysis.spectra.response_spectra`); the modes of its motion channels
    together, harmonic tones flagged, in ``band`` (:func:`rigtools.operational.point_modes`)."""
    from rigtools.analysis.spectra import response_spectra
    from rigtools.operational import point_modes

    rate = float(point.sample_rate)
    start, n = record_window(point)
    if n > WINDOW_SAMPLES:
        start, n = start + n - WINDOW_SAMPLES, WINDOW_SAMPLES
    names = list(channels or point.channels)
    spectra = {
        c: response_spectra(np.asarray(point.channels[c][start : start + n], dtype=float), rate, fe=fe)
        for c in names
    }
    spectra_note = (
        "no force channel: PSD in units²/Hz (Welch, Hann; its peaks are the spectral peaks), "
        "amplitudes are peak (flattop)"
    )
    notes = [spectra_note]
    oma, oma_notes = point_modes(point, (start, n), names, band=band, fe=fe)
    notes += oma_notes
    if fe is None:
        notes.append("give --fe to read the harmonics of an excitation frequency")
    return PointAnalysis(
        point.index,
        "operational",
        dict(point.params),
        {c: point.channels[c].units for c in names},
        rate,
        (start, n),
        spectra=spectra,
        notes=notes,
        oma=oma,
    )


@dataclass(frozen=True)
class FRFOptions:
    """How ``rig analyze`` (and every reader of the same FRF) treats a broadband point.

    Attributes
    ----------
    band
        ``(f_min, f_max)`` Hz for the modal identification; None: the procedure's band, else where
        the force has energy (:func:`rigtools.analysis.modal_id.excitation_band`).
    excitation, frame_samples, force_window, exponential
        Overrides of the FRF estimate (:func:`frf_method_of`); ``frame_samples`` at least
        :data:`rigtools.analysis.frf.MIN_FRAME_SAMPLES` (a shorter frame is one
        :class:`UserError` line naming the minimum).
    """

    band: tuple[float, float] | None = None
    excitation: str | None = None
    frame_samples: int | None = None
    force_window: float | None = None
    exponential: float | None = None

    def __post_init__(self) -> None:
        from rigtools.analysis.frf import MIN_FRAME_SAMPLES

        n = self.frame_samples
        if n is not None and n < MIN_FRAME_SAMPLES:
            raise UserError(
                f"--frame-samples = {n}: an FRF frame needs at least {MIN_FRAME_SAMPLES} samples "
                "(N samples give N/2 + 1 lines from 0 Hz to half the sample rate)"
            )

    def estimate_options(self) -> list[str]:
        """The command-line names of the estimate overrides given (``--excitation``, ...)."""
        return [
            option
            for option, value in (
                ("--excitation", self.excitation),
                ("--frame-samples", self.frame_samples),
                ("--force-window", self.force_window),
                ("--exponential", self.exponential),
            )
            if value is not None
        ]

    def refuse_unused(self, what: str, *, band: bool = True) -> None:
        """One :class:`UserError` line when options were given for FRFs that ``what`` (the
        reason, e.g. "run.h5 holds no broadband point") does not estimate: never ignored."""
        given = self.estimate_options() + (["--band"] if band and self.band is not None else [])
        if given:
            raise UserError(
                f"{' and '.join(given)}: {what}, so {'it' if len(given) == 1 else 'they'} would be ignored"
            )


def point_frf(point, *, responses: Sequence[str] | None = None, options: FRFOptions | None = None):
    """The FRF of a broadband point as every command reports it: ``(force, responses, measured
    kind, FRFMethod, (start, n), blocks)``; ``blocks`` feeds
    :func:`rigtools.analysis.point.analyze_frf_test` or the method's accumulator."""
    options = options or FRFOptions()
    force = force_channel(point)
    if force is None:
        raise UserError(
            f"point {point.index}: no force channel (channels: {', '.join(point.channels)}); "
            "an FRF needs the force (name one with --reference)"
        )
    resp = list(responses or response_channels(point, force))
    if not resp:
        raise UserError(
            f"point {point.index}: no response channel (acceleration, velocity or "
            f"displacement) beside {force}"
        )
    not_motion = [c for c in resp if _frf_kind_of(point.channels[c].units) is None]
    if not_motion:
        raise UserError(
            f"point {point.index}: {', '.join(not_motion)} is not an acceleration, velocity or "
            f"displacement ({', '.join(point.channels[c].units for c in not_motion)}): no FRF response"
        )
    measured = {k for c in resp if (k := _frf_kind_of(point.channels[c].units)) is not None}
    if len(measured) != 1:
        raise UserError(
            f"point {point.index}: responses {', '.join(resp)} measure different quantities; "
            "analyse them one at a time (--channels)"
        )
    start, n = record_window(point)
    method = frf_method_of(
        point,
        force,
        start,
        n,
        excitation=options.excitation,
        frame_samples=options.frame_samples,
        force_window=options.force_window,
        exponential=options.exponential,
    )
    if method.excitation != "impact" and n < method.frame_samples:
        raise UserError(
            f"point {point.index}: {n} samples recorded, fewer than one frame ({method.frame_samples})"
        )
    names = [force, *resp]
    return force, resp, measured.pop(), method, (start, n), frf_blocks(point, names, start, n, method)


def point_frf_estimate(point, *, responses: Sequence[str] | None = None, options: FRFOptions | None = None):
    """``(FRFEstimate in the responses' own kind, responses, force, FRFMethod, measured kind)`` of
    a broadband point: the same numbers ``rig analyze`` reports (``rig export uff`` and the
    procedures' checks use these)."""
    force, resp, measured, method, _, blocks = point_frf(point, responses=responses, options=options)
    try:
        est = method.estimate((np.vstack([b[c] for c in [force, *resp]]) for b in blocks), point.sample_rate)
    except ValueError as exc:
        raise UserError(f"point {point.index}: {exc}") from None
    return est, resp, force, method, measured


def analyze_broadband(
    point,
    procedure: str,
    *,
    kind: str = "accelerance",
    method: str = "lscf",
    responses: Sequence[str] | None = None,
    options: FRFOptions | None = None,
) -> PointAnalysis:
    """H1/H2/Hv, coherence and modes of a broadband point (FRF test, tap test, free decay,
    impact test or random test written elsewhere)."""
    from rigtools.analysis.point import analyze_frf_test

    options = options or FRFOptions()
    rate = float(point.sample_rate)
    force, resp, measured, frf_method, (start, n), blocks = point_frf(
        point, responses=responses, options=options
    )
    units = {c: point.channels[c].units for c in [force, *resp]}
    notes = [f"FRF: {frf_method.describe(rate)}"]
    if frf_method.excitation == "impact" and len(frf_method.frame_starts) < 2:
        notes.append("one hit: no coherence (it needs two or more averages)")
    lo, hi = options.band if options.band else (point.params.get("band_low"), point.params.get("band_high"))
    try:
        res = analyze_frf_test(
            blocks,
            rate,
            frf_method=frf_method,
            responses=resp,
            force=force,
            measured=measured,
            kind=frf_kind(kind),
            f_min=lo,
            f_max=hi,
            method=method,
        )
    except ValueError as exc:
        raise UserError(f"point {point.index}: {exc}") from None
    params = dict(point.params)
    first = next(iter(res.modes.values()), None)
    if first is not None and first.band is not None:
        params["band_low"], params["band_high"] = first.band
        if options.band is None and point.params.get("band_low") is None:
            notes.append(
                f"band {first.band[0]:.4g}-{first.band[1]:.4g} Hz: where the force spectrum has energy"
            )
    band = (res.estimate.frequency_hz >= params.get("band_low", 0.0)) & (
        res.estimate.frequency_hz <= params.get("band_high", np.inf)
    )
    for i, (r, m) in enumerate(res.modes.items()):
        coh = float(np.mean(res.estimate.coherence[i][band]))
        if coh < 0.5 and BLADE_OF.get(r) == "passive":
            notes.append(f"{r}: {PASSIVE_NOT_EXCITED} (mean coherence with the force {coh:.2f} in the band)")
        elif coh < 0.5:
            notes.append(
                f"{r}: mean coherence {coh:.2f} in the band: this response hardly follows the "
                "force (a blade the force does not reach needs its own tap/hammer test)"
            )
        notes.extend(f"{r}: {t}" for t in m.notes)
    out = PointAnalysis(
        point.index,
        "broadband",
        params,
        units,
        rate,
        (start, n),
        frf=res,
        excitation=frf_method.excitation,
        notes=notes,
    )
    return out


def _no_frequency_no_frames(point, procedure: str) -> bool:
    """A point with ``fe = 0`` (no single excitation frequency) in a recording not of an FRF test
    and without frames: there is no frequency to analyse it at, and a sine record is no
    broadband test."""
    return (
        "fe" in point.params
        and excitation_frequency(point.params) is None
        and "frame_samples" not in point.params
        and procedure not in PROCEDURE_FRF
    )


def is_hit_per_point_tap_test(procedure: str, points) -> bool:
    """True for a tap test written by ``rig acquire tap``: one frame per hit, each its own point
    (``frame_samples`` and ``accepted`` per point). A tap record holding several hits in one point
    goes through :func:`analyze_broadband` instead."""
    return procedure == "tap test" and any(
        "frame_samples" in p.params and "accepted" in p.params for p in points
    )


def analyze_tap_test(
    points,
    experiment: dict,
    *,
    kind: str = "accelerance",
    method: str = "lscf",
    band: tuple[float | None, float | None] | None = None,
    response: str | None = None,
    n_modes: int | None = None,
) -> PointAnalysis:
    """H1/H2/Hv, coherence and modes of a tap (impact-hammer) test: one frame per accepted hit,
    each its own point (``rig acquire tap``), averaged together with the hammer as the force
    (rectangular window; the impact estimate of :class:`rigtools.analysis.frf.FRFMethod`).

    ``band`` is ``(f_min, f_max)`` of the identification, either None for its default: from
    :data:`TAP_F_MIN_HZ` to the hammer pulse's reach ``1 / pulse``. ``response`` defaults to the
    recording's ``response``, else the hit blade's shroud accelerometer.
    """
    from rigtools.analysis.frf import FRFMethod
    from rigtools.analysis.point import analyze_frf_test

    hammer = str(experiment.get("hammer_channel") or "hammer")
    accepted = [
        p
        for p in points
        if p.complete
        and p.params.get("accepted", False)
        and hammer in p.channels
        and p.n_samples >= int(p.params.get("frame_samples", 0))
    ]
    if len(accepted) < 2:
        raise UserError(
            f"a tap test needs at least two accepted hits to average; this one has {len(accepted)}"
        )
    first = accepted[0]
    response = (
        response
        or experiment.get("response")
        or next(
            (
                c
                for c in ("passive_shroud_accel", "active_shroud_accel")
                if c in first.channels and c.startswith(str(first.params.get("blade", "")))
            ),
            None,
        )
    )
    if response is None or response not in first.channels:
        raise UserError(
            f"tap test: no response channel {response or ''} beside {hammer} "
            f"(channels: {', '.join(first.channels)})"
        )
    measured = _frf_kind_of(first.channels[response].units)
    if measured is None:
        raise UserError(
            f"tap test: the response {response} is not an acceleration, velocity or displacement "
            f"({first.channels[response].units})"
        )
    if first.sample_rate is None:
        raise UserError(f"tap test: point {first.index} has channels at different sample rates")
    rate = float(first.sample_rate)
    frame = int(first.params["frame_samples"])
    units = {hammer: first.channels[hammer].units, response: first.channels[response].units}
    blocks = (
        {
            "force": np.asarray(p.channels[hammer][:frame], dtype=float),
            response: np.asarray(p.channels[response][:frame], dtype=float),
        }
        for p in accepted
    )
    # a hammer pulse of duration T excites up to about 1/T: identify within that band (2 kHz for
    # the 0.5 ms default pulse, the same band `rig acquire tap` uses)
    pulse = float((experiment.get("parameters") or {}).get("pulse") or TAP_DEFAULT_PULSE_S)
    f_min, f_max = band or (None, None)
    f_min = TAP_F_MIN_HZ if f_min is None else f_min
    f_max = min(1.0 / pulse, 0.45 * rate) if f_max is None else f_max
    frf_method = FRFMethod(
        "impact",
        frame,
        tuple(0 for _ in accepted),
        reason="rig acquire tap: one recorded frame per accepted hit",
    )
    try:
        res = analyze_frf_test(
            blocks,
            rate,
            frf_method=frf_method,
            responses=(response,),
            force="force",
            measured=measured,
            kind=frf_kind(kind),
            method=method,
            f_min=f_min,
            f_max=f_max,
            n_modes=n_modes,
        )
    except ValueError as exc:  # a band the FRF cannot be identified over
        raise UserError(f"tap test: {exc}") from None
    notes = [
        (
            f"tap test: {len(accepted)} accepted hits of {len(points)} averaged (H1 of {response} over "
            f"{hammer}, rectangular window of {frame} samples per hit)"
        )
    ]
    for r, m in res.modes.items():
        notes.extend(f"{r}: {t}" for t in m.notes)
    return PointAnalysis(
        first.index,
        "broadband",
        dict(first.params),
        units,
        rate,
        (0, frame),
        frf=res,
        excitation="impact",
        notes=notes,
    )


@in_script_words
def analyze_recording(
    path: str | Path,
    *,
    kind: str = "accelerance",
    method: str = "lscf",
    channels: Sequence[str] | None = None,
    progress: Callable[[int, int], None] | None = None,
    options: FRFOptions | None = None,
    fe: float | None = None,
    compare_fem: bool | None = None,
    skip_damaged: bool | None = None,
) -> RecordingAnalysis:
    """Analyse every complete point of a recording (see the module docstring).

    Parameters
    ----------
    path
        The recording (HDF5, schema v1).
    kind
        FRF kind of the results: ``"accelerance"``, ``"mobility"`` or ``"receptance"``.
    method
        Modal identification of broadband points: ``"lscf"`` or ``"peak"``.
    channels
        Only these channels (the force is always kept); unknown names are a :class:`UserError`.
    progress
        ``progress(done, total)`` after each point.
    options
        Band and FRF-estimate overrides of broadband points (:class:`FRFOptions`).
    fe
        Excitation frequency whose harmonics are marked in the spectra of a point without a
        force channel (an operational recording).
    compare_fem
        Add the table of this rig's FEM/AM natural frequencies beside the identified ones;
        default: yes for the rig's own recordings, no for imported ones (they do not describe
        this rig).
    skip_damaged
        Read a recording ``rig check`` rejects, leaving its damaged points and channels out
        (one note each); by default such a file is refused in one line.

    Returns
    -------
    RecordingAnalysis
        ``points`` (:class:`PointAnalysis`: harmonics of periodic points, FRFs and modes of
        broadband ones), ``notes``, ``skipped``, ``to_dict()``.

    Raises
    ------
    UserError
        One line: unreadable file, unknown channel, a point that cannot be analysed.

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "frf.h5"
    >>> run = rigtools.frf_test(("20 Hz", "500 Hz"), "1 V", out, frame="0.5 s", averages=2, gap="5 mm", backend="sim")
    >>> run.status
    'finished'
    >>> analysis = rigtools.analyze_recording(run.file)
    >>> point = analysis.points[0]
    >>> point.kind, point.frf.responses[0]
    ('broadband', 'active_shroud_accel')
    """
    from rigtools.frf_set import is_frf_set
    from rigtools.recording import RecordingError, open_recording
    from rigtools.vocabulary import source_of

    checked_kind = frf_kind(kind)
    if fe is not None:
        from rigtools.options import quantity

        fe = quantity(fe, "frequency", "fe")
        if not fe > 0:
            raise UserError(f"fe = {fe!r}: the excitation frequency must be > 0 Hz")
    if method not in METHODS:
        raise UserError(f"--method {method!r}: use one of {', '.join(METHODS)}")
    if Path(path).is_file() and is_frf_set(path):
        return analyze_frf_set(path, kind=kind, method=method, channels=channels, options=options)
    try:
        rec = open_recording(path, skip_damaged=skip_damaged)
    except RecordingError as exc:
        raise UserError(str(exc)) from None
    with rec:
        procedure = str(rec.experiment.get("procedure", ""))
        out = RecordingAnalysis(
            str(path), procedure, rec.backend, source_of(rec.backend), rec.status, checked_kind, []
        )
        out.notes.extend(rec.notes)
        if rec.incomplete:
            out.notes.append(
                f"recording status {rec.status}"
                + (f" ({rec.abort_reason})" if rec.abort_reason else "")
                + ": only points its writer ended are analysed"
            )
        points = rec.points
        if channels:
            known = set().union(*(p.channels for p in points)) if points else set()
            unknown = [c for c in channels if c not in known]
            if unknown:
                raise UserError(
                    f"{path}: no channel {', '.join(unknown)} (channels: {', '.join(sorted(known))})"
                )
        try:
            if is_hit_per_point_tap_test(procedure, points):
                (options or FRFOptions()).refuse_unused(
                    "a tap test's FRF is one recorded frame per accepted hit", band=False
                )
                out.points.append(
                    analyze_tap_test(
                        points, rec.experiment, kind=kind, method=method, band=(options or FRFOptions()).band
                    )
                )
                points = []
            for i, point in enumerate(points):
                if not point.complete:
                    out.skipped.append(f"point {point.index}: not ended by its writer (cut off)")
                elif point.n_samples == 0:
                    out.skipped.append(f"point {point.index}: no samples")
                elif point.sample_rate is None:
                    out.skipped.append(f"point {point.index}: channels at different sample rates")
                elif procedure in SINE_PROCEDURES and "fe" not in point.params:
                    out.skipped.append(
                        f"point {point.index}: a sine point without fe (its excitation frequency)"
                    )
                elif _no_frequency_no_frames(point, procedure):
                    out.skipped.append(
                        f"point {point.index}: fe = 0 (no single excitation frequency) and no frames: "
                        "neither a periodic nor a broadband point"
                    )
                elif excitation_frequency(point.params) and procedure not in PROCEDURE_FRF:
                    names = None
                    if channels:
                        names = (
                            list(dict.fromkeys([FORCE, *channels]))
                            if FORCE in point.channels
                            else list(channels)
                        )
                    out.points.append(analyze_periodic(point, channels=names))
                elif force_channel(point) is None:
                    band = (options or FRFOptions()).band
                    out.points.append(analyze_operational(point, fe=fe, channels=channels, band=band))
                else:
                    resp = [c for c in channels if c != force_channel(point)] if channels else None
                    out.points.append(
                        analyze_broadband(
                            point, procedure, kind=kind, method=method, responses=resp, options=options
                        )
                    )
                if progress is not None:
                    progress(i + 1, len(points))
        except RecordingError as exc:
            raise UserError(str(exc)) from None
    if not out.broadband:  # --band also sets the band of the modes of points without a force
        (options or FRFOptions()).refuse_unused(
            f"{path} holds no broadband point (FRF, tap or impact test)", band=not out.operational
        )
        if (options or FRFOptions()).band and all(p.oma is None for p in out.operational):
            why = next((n for n in out.operational[0].notes if n.startswith(("no modes", "no motion"))), "")
            raise UserError(f"--band: no point of {path} could be identified in it ({why})")
    foreign = is_foreign(rec.experiment)
    if compare_fem is None:
        compare_fem = not foreign
    if out.broadband and compare_fem:
        out.frequency_table = frequency_table(out, path)
    elif out.broadband and foreign:
        out.notes.append("imported recording: not compared with this rig's FEM (ask with --compare-fem)")
    if not out.points and not out.skipped:
        out.notes.append("the recording holds no points")
    return out


def analyze_frf_set(
    path: str | Path,
    *,
    kind: str = "accelerance",
    method: str = "lscf",
    channels: Sequence[str] | None = None,
    options: FRFOptions | None = None,
) -> RecordingAnalysis:
    """Modes of the FRFs of an FRF set (:mod:`rigtools.frf_set`, e.g. ``rig import uff``), one
    broadband point: the identification :func:`analyze_broadband` runs, on the stored FRFs and
    coherence; the band is ``options.band`` or the whole grid above 0 Hz (an FRF set holds no
    force spectrum). Never compared with this rig's FEM (it does not describe this rig)."""
    from rigtools.analysis.frf import FRFEstimate
    from rigtools.analysis.modal_id import identify
    from rigtools.analysis.point import FRFTestAnalysis
    from rigtools.frf_set import read_frf_set

    (options or FRFOptions()).refuse_unused(
        f"{path} is an FRF set: its FRFs were estimated elsewhere", band=False
    )
    fs = read_frf_set(path)
    kind_out = frf_kind(kind)
    rows = list(range(len(fs.responses)))
    if channels:
        unknown = [c for c in channels if c not in fs.responses and c != fs.reference]
        if unknown:
            raise UserError(f"{path}: no FRF of {', '.join(unknown)} (responses: {', '.join(fs.responses)})")
        rows = [i for i, r in enumerate(fs.responses) if r in channels]
    f = fs.frequency_hz
    h = fs.frf[rows]
    coh = fs.coherence[rows]
    with_coherence = bool(np.all(np.isfinite(coh)))
    est = FRFEstimate(
        f, h, h, coh, 2 if with_coherence else 1, np.full(f.size, np.nan), np.abs(h) * np.nan, h * np.nan
    ).as_kind(frf_kind(fs.kind), kind_out)
    band = (options or FRFOptions()).band
    responses = [fs.responses[i] for i in rows]
    modes = {}
    together = method == "lscf" and len(responses) > 1
    try:
        if together:
            # one reference, several responses: one LSCF over all of them (common poles, the
            # shapes checked between orders); each response keeps its own residues
            both = identify(
                f,
                est.h1,
                kind=kind_out,
                coherence=est.coherence if with_coherence else None,
                f_min=band[0] if band else None,
                f_max=band[1] if band else None,
                method=method,
            )
            for i, r in enumerate(responses):
                modes[r] = replace(both, modes=[replace(m, residue=m.shape[i]) for m in both.modes])
        else:
            for i, r in enumerate(responses):
                modes[r] = identify(
                    f,
                    est.h1[i],
                    kind=kind_out,
                    coherence=est.coherence[i] if with_coherence else None,
                    f_min=band[0] if band else None,
                    f_max=band[1] if band else None,
                    method=method,
                )
    except ValueError as exc:
        raise UserError(f"{path}: {exc}") from None
    first = next(iter(modes.values()), None)
    params: dict[str, Any] = {"reference_channel": fs.reference}
    if first is not None and first.band is not None:
        params["band_low"], params["band_high"] = first.band
    notes = [
        f"FRF set from {fs.source.get('file', '?')} ({fs.kind} as imported); no force spectrum: band "
        + ("as asked" if band else "the whole grid above 0 Hz (--band narrows it)")
    ]
    if not with_coherence:
        notes.append("no coherence in the FRF set: peaks are not checked against it")
    if together:
        notes.append(
            f"the {len(responses)} FRFs identified together (common poles; shapes stable between orders)"
        )
        notes.extend(next(iter(modes.values())).notes)
    else:
        for r, m in modes.items():
            notes.extend(f"{r}: {t}" for t in m.notes)
    units = {r: {"accelerance": "m/s^2", "mobility": "m/s", "receptance": "m"}[fs.kind] for r in responses}
    point = PointAnalysis(
        0,
        "broadband",
        params,
        {fs.reference: "N", **units},
        2.0 * float(f[-1]),
        (0, 0),
        frf=FRFTestAnalysis(responses, est, kind_out, modes, None),
        excitation="measured FRF",
        notes=notes,
    )
    out = RecordingAnalysis(str(path), "frf set", "frf set", "em", "complete", kind_out, [point])
    out.notes.append("FRF set: not compared with this rig's FEM")
    return out


BLADE_OF = {c: _BLADE_OF[c] for c in (ACTIVE_SHROUD_ACCEL, PASSIVE_SHROUD_ACCEL)}


def identified_frequencies(analysis: RecordingAnalysis) -> dict[str, list[float]]:
    """``{blade: natural frequencies}`` identified from the shroud responses of the broadband
    points (the first point with modes for each blade)."""
    em: dict[str, list[float]] = {}
    for p in analysis.broadband:
        for r in p.frf.responses:
            blade = BLADE_OF.get(r)
            modes = p.frf.modes[r].modes
            if blade and modes and blade not in em:
                em[blade] = sorted(m.frequency_hz for m in modes)
    return em


def model_frequencies(rig_config, n_modes: int = 3) -> dict[str, dict[str, list[float]]]:
    """Flexural natural frequencies of both blades of a rig: ``{"fem": ..., "am": ...,
    "article": ...}`` with ``{blade: [Hz, ...]}`` each. ``fem``: the reduced FE model
    (:mod:`rigtools.sim.natural_frequencies`); ``am``: the exact Euler-Bernoulli solution; ``article``: the simulated rig's test
    article (``[test_article]`` applied to the nominal rig as :class:`rigtools.drivers.simulated.SimulatedRig`
    does, reduced as its vibro-impact physics does)."""
    from rigtools.sim.natural_frequencies import analytical_natural_frequencies
    from rigtools.sim.natural_frequencies import reduced_natural_frequencies as natural_frequencies
    from rigtools.sim.reduction import reduce_rig_model, reduced_system
    from rigtools.sim.rig_model import build_rig_model

    params = rig_config.to_params()
    fem = natural_frequencies(reduced_system(params, "fem"))
    am = analytical_natural_frequencies(params, n_modes)
    out = {
        "fem": {b: [float(x) for x in fem[b][:n_modes]] for b in fem},
        "am": {b: [float(x) for x in am[b]] for b in am},
    }
    article = getattr(rig_config, "test_article", None)
    if article is not None:
        art = natural_frequencies(reduce_rig_model(build_rig_model(article.to_params().apply(params))))
        out["article"] = {b: [float(x) for x in art[b][:n_modes]] for b in art}
    return out


def frequency_table(analysis: RecordingAnalysis, path, n_modes: int = 3) -> list[dict] | None:
    """The paper's Table 2 for a broadband recording: per blade and mode FEM, AM, EM (identified)
    and their differences in % (:func:`rigtools.analysis.correlation.natural_frequency_table`), with the
    simulated test article's own frequency and EM's difference from it when the recording was
    made on the simulated rig. None if nothing was identified or the rig cannot be read."""
    from rigtools.analysis.correlation import natural_frequency_table
    from rigtools.recording import RecordingError, open_recording

    em = identified_frequencies(analysis)
    if not em:
        return None
    try:
        with open_recording(path) as rec:
            cfg = rec.rig_config()
    except (RecordingError, UserError) as exc:
        analysis.notes.append(f"no FEM/AM natural-frequency table: the recording's rig is unreadable ({exc})")
        return None
    models = model_frequencies(cfg, n_modes)
    em_full = {b: em.get(b, []) for b in models["fem"]}
    table = natural_frequency_table(models["fem"], em_full, models["am"], n_modes=n_modes)
    rows = table.to_dict("records")
    if analysis.backend == "simulated" and "article" in models:
        for r in rows:
            vals = models["article"].get(r["blade"], [])
            ref = vals[r["mode"] - 1] if r["mode"] <= len(vals) else float("nan")
            r["article_hz"] = ref
            r["em_vs_article_pct"] = 100 * (r["em_hz"] - ref) / ref if not math.isnan(ref) else float("nan")
    shaker_driven = analysis.procedure in PROCEDURE_FRF
    for blade in models["fem"]:
        if blade == "passive" and blade not in em and shaker_driven:
            analysis.notes.append(f"passive blade: {PASSIVE_NOT_EXCITED}; its EM column is empty")
        elif blade not in em:
            analysis.notes.append(
                f"{blade} blade: no modes identified in this recording (its shroud "
                "response did not follow the force); its EM column is empty"
            )
    return [{k: (float(v) if isinstance(v, (np.floating, float)) else v) for k, v in r.items()} for r in rows]


def point_window(path: str | Path, index: int, periods: float = 5.0) -> tuple[dict, float, float, dict]:
    """The last ``periods`` periods (periodic) or the first frame (broadband) of a point, for
    waveform figures: ``({channel: samples}, sample_rate, t0 s, units)``."""
    from rigtools.recording import open_recording

    with open_recording(path) as rec:
        point = next(p for p in rec.points if p.index == index)
        rate = point.sample_rate
        if rate is None:
            raise UserError(f"{path}: point {index} has channels at different sample rates")
        start, n = record_window(point)
        fe = excitation_frequency(point.params)
        if fe:
            m = min(n, round(max(periods, 1.0) * 40 * rate / fe), WINDOW_SAMPLES)
        else:
            m = min(n, int(point.params.get("frame_samples", n)), WINDOW_SAMPLES)
        a = start + n - m if fe else start
        data = {c: np.asarray(ch[a : a + m], dtype=float) for c, ch in point.channels.items()}
        units = {c: ch.units for c, ch in point.channels.items()}
        t0 = point.channels[next(iter(point.channels))].t0 + a / rate
    return data, rate, t0, units
