"""What the analysis of a recording returns: :class:`PointAnalysis` per point,
:class:`RecordingAnalysis` for the recording (its tables, response curves and JSON document), and
the FRF kinds it reports."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rigtools.analysis.frf import FRFKind, convert_frf
from rigtools.errors import UserError
from rigtools.sim.channel_names import FORCE

TABLE_HARMONICS = (6, 8, 22)  # the paper's super-harmonics of interest
KINDS: tuple[FRFKind, ...] = ("accelerance", "mobility", "receptance")
_FRF_KIND_OF_UNITS: dict[str, FRFKind] = {"m/s^2": "accelerance", "m/s": "mobility", "m": "receptance"}


def frf_kind_of_units(units: str) -> FRFKind | None:
    """The FRF kind a response in ``units`` gives over a force (``"m/s^2"``: accelerance, ``"m/s"``:
    mobility, ``"m"``: receptance); None for any other quantity."""
    return _FRF_KIND_OF_UNITS.get(units)


def frf_kind(kind: str) -> FRFKind:
    """``kind`` checked against :data:`KINDS`; a :class:`UserError` naming them otherwise."""
    for k in KINDS:
        if k == kind:
            return k
    raise UserError(f"--kind {kind!r}: use one of {', '.join(KINDS)}")


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

    @classmethod
    def of_point(
        cls, point, kind: str, names: Sequence[str], window: tuple[int, int], **parts: Any
    ) -> PointAnalysis:
        """The analysis of a recorded point (its index, parameters, sample rate and the units of
        ``names``) holding ``parts`` (``dwell=``, ``spectra=``, ``notes=``, ...)."""
        units = {c: point.channels[c].units for c in names}
        return cls(point.index, kind, dict(point.params), units, float(point.sample_rate), window, **parts)

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
    """A whole recording analysed (:func:`rigtools.recording_analysis.dispatch.analyze_recording`)."""

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
            f1 = np.array(
                [
                    p.dwell.harmonics[FORCE].amplitude[0] * np.exp(1j * p.dwell.harmonics[FORCE].phase[0])
                    for p in pts
                ]
            )
            for c in channels:
                measured = frf_kind_of_units(pts[0].units.get(c, ""))
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
