"""Experiment (EM) versus model (FEM, AM) side by side: tables, one agreement score, and the
natural-frequency offset that explains a large harmonic difference.

Conventions:

- Differences in percent are ``100 (X - reference) / reference``. In natural-frequency tables the
  reference is EM when it is given (the paper's Tables 2 and 3: how far each model is from the
  test), else FEM. In harmonic tables it is EM (``100 (FEM - EM) / EM``).
- Amplitudes are peak values (:func:`rigtools.analysis.harmonics.harmonic_amplitudes`).
- Tables are :class:`pandas.DataFrame` objects (``.to_dict("records")`` for JSON,
  ``.to_html()`` for the report).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike
from scipy import optimize

from rigtools.analysis.harmonics import without_round_off
from rigtools.sim.channel_names import ACTIVE_SHROUD_ACCEL, FORCE, PASSIVE_SHROUD_ACCEL, SHROUD_ACCELS

BLADES = ("active", "passive")


def _zero_if_round_off(value: float, kept: float) -> float:
    """``0.0`` for a finite value :func:`without_round_off` dropped (round-off), else the value."""
    return 0.0 if np.isfinite(value) and np.isnan(kept) else float(value)


def _pct(x, ref):
    x, ref = np.asarray(x, dtype=float), np.asarray(ref, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return 100.0 * (x - ref) / ref


def natural_frequency_table(
    fem: Mapping[str, Sequence[float]],
    em: Mapping[str, Sequence[float]] | None = None,
    am: Mapping[str, Sequence[float]] | None = None,
    *,
    n_modes: int = 3,
) -> pd.DataFrame:
    """Natural frequencies paired by blade and mode order, as the paper's Tables 2 and 3.

    Parameters
    ----------
    fem, em, am
        ``{blade: natural frequencies in Hz}`` (e.g. the flexural modes of ``"active"`` with the
        force sensor and ``"passive"`` without). Each blade's list is sorted ascending and the
        ``n``-th entries of the sources are paired (mode order ``n = 1..n_modes``); a missing
        entry reads NaN.
    n_modes
        Modes per blade.

    Returns
    -------
    pandas.DataFrame
        One row per blade and mode: ``blade``, ``mode``, ``fem_hz``, ``am_hz``, ``em_hz`` and the
        differences ``fem_vs_em_pct``, ``am_vs_em_pct`` (``100 (model - EM) / EM``) when EM is
        given, otherwise ``am_vs_fem_pct`` (``100 (AM - FEM) / FEM``).

    Examples
    --------
    >>> from rigtools.analysis.correlation import natural_frequency_table
    >>> table = natural_frequency_table({"active": [62.0, 380.0]}, em={"active": [60.0, 370.0]}, n_modes=2)
    >>> print(table[["blade", "mode", "fem_hz", "em_hz", "fem_vs_em_pct"]].round(2).to_string(index=False))
     blade  mode  fem_hz  em_hz  fem_vs_em_pct
    active     1    62.0   60.0           3.33
    active     2   380.0  370.0           2.70
    """

    def get(src, blade, i):
        if src is None or blade not in src:
            return np.nan
        vals = np.sort(np.asarray(src[blade], dtype=float))
        return float(vals[i]) if i < vals.size else np.nan

    blades = [b for b in BLADES if b in fem] + [b for b in fem if b not in BLADES]
    rows = []
    for blade in blades:
        for i in range(int(n_modes)):
            row = {
                "blade": blade,
                "mode": i + 1,
                "fem_hz": get(fem, blade, i),
                "am_hz": get(am, blade, i),
                "em_hz": get(em, blade, i),
            }
            if em is not None:
                row["fem_vs_em_pct"] = float(_pct(row["fem_hz"], row["em_hz"]))
                row["am_vs_em_pct"] = float(_pct(row["am_hz"], row["em_hz"]))
            else:
                row["am_vs_fem_pct"] = float(_pct(row["am_hz"], row["fem_hz"]))
            rows.append(row)
    return pd.DataFrame(rows)


def harmonic_table(
    em: Mapping[str, np.ndarray],
    fem: Mapping[str, np.ndarray],
    fe: float,
    *,
    k_max: int | None = None,
) -> pd.DataFrame:
    """Per channel, harmonic amplitudes of EM and FEM side by side with differences in percent.

    Parameters
    ----------
    em, fem
        ``{channel: (K,) peak amplitudes of k = 1..K}`` (e.g. ``HarmonicFit.amplitude``); channels
        present in both are compared, in EM's order.
    fe
        Excitation frequency, Hz.
    k_max
        Compare k = 1..k_max (default all that both have).

    Returns
    -------
    pandas.DataFrame
        Rows ``channel``, ``k``, ``frequency_hz``, ``em``, ``fem``, ``diff_pct``
        (``100 (FEM - EM) / EM``), ``ratio`` (FEM / EM). A harmonic that is zero but for round-off
        (:func:`without_round_off`) is shown as 0 and has no ``diff_pct`` nor ``ratio`` (NaN): a
        model's exactly-zero force harmonic is not "-100 %".

    Examples
    --------
    >>> import numpy as np
    >>> from rigtools.analysis.correlation import harmonic_table
    >>> em = {"active_shroud_accel": np.array([10.0, 2.0])}
    >>> fem = {"active_shroud_accel": np.array([11.0, 1.0])}
    >>> table = harmonic_table(em, fem, 60.0)
    >>> print(table[["k", "frequency_hz", "em", "fem", "diff_pct"]].to_string(index=False))
     k  frequency_hz   em  fem  diff_pct
     1          60.0 10.0 11.0      10.0
     2         120.0  2.0  1.0     -50.0
    """
    rows = []
    for ch in em:
        if ch not in fem:
            continue
        a, b = np.asarray(em[ch], dtype=float), np.asarray(fem[ch], dtype=float)
        a_cmp, b_cmp = without_round_off(a), without_round_off(b)
        n = min(a.size, b.size) if k_max is None else min(int(k_max), a.size, b.size)
        for k in range(1, n + 1):
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = b_cmp[k - 1] / a_cmp[k - 1]
            rows.append(
                {
                    "channel": ch,
                    "k": k,
                    "frequency_hz": k * float(fe),
                    "em": _zero_if_round_off(a[k - 1], a_cmp[k - 1]),
                    "fem": _zero_if_round_off(b[k - 1], b_cmp[k - 1]),
                    "diff_pct": float(_pct(b_cmp[k - 1], a_cmp[k - 1])),
                    "ratio": float(ratio),
                }
            )
    return pd.DataFrame(rows, columns=["channel", "k", "frequency_hz", "em", "fem", "diff_pct", "ratio"])


@dataclass(frozen=True)
class Agreement:
    """Result of :func:`agreement_score`.

    Attributes
    ----------
    score
        ``10 ** (-error)`` in (0, 1]: 1 for identical harmonics; ``1 / q`` when every harmonic of
        one side is ``q`` times the other's.
    error_decades
        Energy-weighted mean ``|log10(FEM / EM)|`` over harmonics, averaged over channels.
    per_channel
        ``{channel: its error_decades}``.
    """

    score: float
    error_decades: float
    per_channel: dict[str, float]


def agreement_score(
    em: Mapping[str, np.ndarray],
    fem: Mapping[str, np.ndarray],
    *,
    k_max: int | None = None,
    floor: float = 1e-3,
) -> Agreement:
    """One agreement number per point from the harmonic amplitudes of several channels.

    Definition: for each channel ``c`` (e.g. the force and both shroud accelerations) and
    harmonic ``k``, ``r_ck = log10(A_fem / A_em)``, with each amplitude raised to at least
    ``floor`` times the channel's largest harmonic (of either side) so that noise-level
    harmonics cannot dominate. Weights ``w_ck = (A_em**2 + A_fem**2) / sum_k (...)`` are each
    harmonic's share of the channel's energy (both sides), so strong harmonics count most and
    each channel counts equally whatever its units. The channel error is ``e_c = sum_k w_ck
    |r_ck|`` (decades), the point's error ``E`` the mean of ``e_c`` over channels, and

        ``score = 10 ** (-E)``

    Properties (tested): 1 for identical inputs; symmetric in EM and FEM; invariant to a common
    unit scale of a channel; every harmonic off by a factor ``q`` gives ``1 / q``; decreases
    monotonically as any one harmonic moves away; in (0, 1].

    Parameters
    ----------
    em, fem
        ``{channel: (K,) peak amplitudes}``; channels in both are used.
    k_max
        Use k = 1..k_max (default all).
    floor
        Relative amplitude floor.
    """
    per = {}
    for ch in em:
        if ch not in fem:
            continue
        a, b = np.abs(np.asarray(em[ch], dtype=float)), np.abs(np.asarray(fem[ch], dtype=float))
        n = min(a.size, b.size) if k_max is None else min(int(k_max), a.size, b.size)
        a, b = a[:n], b[:n]
        top = max(float(a.max(initial=0.0)), float(b.max(initial=0.0)))
        if top <= 0:
            continue
        lo = floor * top
        a, b = np.maximum(a, lo), np.maximum(b, lo)
        w = a**2 + b**2
        per[ch] = float(np.sum(w * np.abs(np.log10(b / a))) / np.sum(w))
    if not per:
        raise ValueError("no channel with harmonics on both sides")
    err = float(np.mean(list(per.values())))
    return Agreement(score=float(10.0 ** (-err)), error_decades=err, per_channel=per)


def single_mode_gain(
    frequency_hz: float | np.ndarray, natural_hz: float | np.ndarray, damping_ratio: float
) -> np.ndarray:
    """``|1 / (1 - r**2 + 2 i zeta r)|`` with ``r = f / fn``: the dynamic amplification of one mode
    at ``f``, the same for receptance, mobility and accelerance ratios at a fixed ``f``."""
    r = np.asarray(frequency_hz, dtype=float) / np.asarray(natural_hz, dtype=float)
    return 1.0 / np.abs(1.0 - r**2 + 2j * damping_ratio * r)


@dataclass(frozen=True)
class FrequencyOffsetExplanation:
    """How much of a harmonic's EM/FEM difference a natural-frequency offset explains.

    Attributes
    ----------
    k, frequency_hz
        The harmonic and ``k fe``.
    natural_hz
        The EM natural frequency of the mode nearest ``k fe``.
    observed_ratio
        FEM / EM amplitude of the harmonic.
    ratio_per_percent
        The single-mode gain ratio for the model's natural frequency 1 % higher and 1 % lower than
        EM's, ``(gain(fn (1.01)) / gain(fn), gain(fn 0.99) / gain(fn))`` at ``k fe``: how sensitive
        this harmonic is to a 1 % shift.
    ratio_from_model_frequency
        The gain ratio the model's own natural frequency predicts (NaN if not given).
    offset_pct_needed
        The natural-frequency offset of the model (percent of EM's) whose single-mode gain ratio
        equals ``observed_ratio``: the smallest in magnitude within +-20 % (NaN if none).
    """

    k: int
    frequency_hz: float
    natural_hz: float
    observed_ratio: float
    ratio_per_percent: tuple[float, float]
    ratio_from_model_frequency: float
    offset_pct_needed: float

    def sentence(self) -> str:
        """One line for a report."""
        text = (
            f"{self.k}·fe = {self.frequency_hz:.1f} Hz lies near the {self.natural_hz:.1f} Hz mode: a 1 % "
            f"higher/lower natural frequency changes it by x{self.ratio_per_percent[0]:.2f}/"
            f"x{self.ratio_per_percent[1]:.2f}"
        )
        if np.isfinite(self.ratio_from_model_frequency):
            text += f"; the model's own frequency predicts x{self.ratio_from_model_frequency:.2f}"
        if np.isfinite(self.offset_pct_needed):
            text += (
                f"; the observed x{self.observed_ratio:.2f} needs a {self.offset_pct_needed:+.2f} % "
                "natural-frequency offset"
            )
        return text


def explain_harmonic_difference(
    k: int,
    fe: float,
    observed_ratio: float,
    natural_hz_em: float,
    damping_ratio: float,
    natural_hz_model: float | None = None,
    *,
    search_pct: float = 20.0,
) -> FrequencyOffsetExplanation:
    """The natural-frequency offset that explains a harmonic's FEM/EM amplitude ratio.

    A super-harmonic ``k fe`` near a resonance ``fn`` is amplified by the single-mode gain
    :func:`single_mode_gain`; near ``fn`` a 1 % shift of ``fn`` changes it by a large factor. With
    the same forcing harmonic on both sides, the amplitude ratio FEM/EM is
    ``gain(k fe; fn_model) / gain(k fe; fn_em)``. This function solves that for the offset
    ``fn_model / fn_em - 1`` that gives ``observed_ratio`` (smallest magnitude within
    ``+-search_pct``) and reports the 1 % sensitivity and, if ``natural_hz_model`` is given, the
    ratio it predicts.
    """
    f = k * float(fe)
    g0 = float(single_mode_gain(f, natural_hz_em, damping_ratio))

    def ratio(offset_pct: float) -> float:
        return float(single_mode_gain(f, natural_hz_em * (1 + offset_pct / 100.0), damping_ratio)) / g0

    per = (ratio(1.0), ratio(-1.0))
    model_ratio = (
        ratio(100.0 * (natural_hz_model / natural_hz_em - 1.0)) if natural_hz_model else float("nan")
    )
    target = np.log(observed_ratio) if observed_ratio > 0 else np.nan
    best = np.nan
    if np.isfinite(target):
        grid = np.linspace(-search_pct, search_pct, 4001)
        vals = np.array([np.log(ratio(x)) for x in grid]) - target
        roots = []
        for i in np.flatnonzero(np.sign(vals[:-1]) * np.sign(vals[1:]) <= 0):
            if vals[i] == 0:
                roots.append(grid[i])
            else:
                roots.append(
                    optimize.brentq(lambda x: np.log(ratio(x)) - target, grid[i], grid[i + 1], xtol=1e-12)
                )
        if roots:
            best = float(min(roots, key=abs))
    return FrequencyOffsetExplanation(
        int(k), f, float(natural_hz_em), float(observed_ratio), per, model_ratio, best
    )


def explain_large_differences(
    table: pd.DataFrame,
    fe: float,
    natural_hz_em: Mapping[str, ArrayLike],
    damping_ratio: float | Mapping[str, ArrayLike],
    natural_hz_model: Mapping[str, ArrayLike] | None = None,
    *,
    channel_blade: Mapping[str, str] | None = None,
    threshold_pct: float = 30.0,
    within_pct: float = 10.0,
) -> list[tuple[str, FrequencyOffsetExplanation]]:
    """For every row of a :func:`harmonic_table` with ``|diff_pct| > threshold_pct`` whose ``k fe``
    lies within ``within_pct`` of a natural frequency of the channel's blade: the explanation.

    ``channel_blade`` maps channel names to blades (default: ``"active"`` if the name starts with
    ``active``, ``"passive"`` if with ``passive``; other channels are skipped).
    Returns ``[(channel, FrequencyOffsetExplanation), ...]``.
    """
    out = []
    for channel, k, f_k, ratio, diff_pct in zip(
        table["channel"].astype(str),
        table["k"].to_numpy(dtype=int),
        table["frequency_hz"].to_numpy(dtype=float),
        table["ratio"].to_numpy(dtype=float),
        table["diff_pct"].to_numpy(dtype=float),
        strict=True,
    ):
        if not np.isfinite(diff_pct) or abs(diff_pct) <= threshold_pct:
            continue
        blade = (channel_blade or {}).get(channel)
        if blade is None:
            blade = next((b for b in BLADES if channel.startswith(b)), None)
        if blade is None or blade not in natural_hz_em:
            continue
        fns = np.asarray(natural_hz_em[blade], dtype=float)
        if fns.size == 0:
            continue
        j = int(np.argmin(np.abs(fns - f_k)))
        if abs(fns[j] - f_k) > within_pct / 100.0 * fns[j]:
            continue
        if isinstance(damping_ratio, Mapping):
            zeta = float(np.asarray(damping_ratio[blade], dtype=float)[j])
        else:
            zeta = float(damping_ratio)
        model = None
        if natural_hz_model is not None and blade in natural_hz_model:
            m = np.sort(np.asarray(natural_hz_model[blade], dtype=float))
            model = float(m[j]) if j < m.size else None
        out.append(
            (
                channel,
                explain_harmonic_difference(int(k), fe, float(ratio), float(fns[j]), zeta, model),
            )
        )
    return out


def pair_points(
    em: Sequence[Mapping[str, float]],
    model: Sequence[Mapping[str, float]],
    *,
    keys: Sequence[str] = ("fe", "gap", "force_amplitude_target"),
    rtol: float = 0.02,
) -> list[tuple[int, int]]:
    """Pair EM and model points by their parameters (by meaning, not by index).

    Each EM point is paired with the model point whose ``keys`` all agree within ``rtol``
    (relative; absolute ``rtol`` for zeros) and whose summed relative distance is smallest; each
    model point is used once. Keys missing on either side are not compared. Returns
    ``[(em_index, model_index), ...]`` in EM order; unpaired EM points are left out.
    """
    used: set[int] = set()
    pairs = []
    for i, p in enumerate(em):
        best, best_d = None, np.inf
        for j, q in enumerate(model):
            if j in used:
                continue
            d, ok = 0.0, True
            for key in keys:
                if key not in p or key not in q:
                    continue
                a, b = float(p[key]), float(q[key])
                scale = max(abs(a), abs(b))
                rel = abs(a - b) / scale if scale > 0 else 0.0
                if rel > rtol:
                    ok = False
                    break
                d += rel
            if ok and d < best_d:
                best, best_d = j, d
        if best is not None:
            used.add(best)
            pairs.append((i, best))
    return pairs


TREND_HARMONICS = {ACTIVE_SHROUD_ACCEL: (6,), PASSIVE_SHROUD_ACCEL: (8, 22)}


def trend_series(
    points: Sequence,
    *,
    force: str = FORCE,
    shrouds: Sequence[str] = SHROUD_ACCELS,
    harmonics: Mapping[str, Sequence[int]] = TREND_HARMONICS,
) -> dict[str, np.ndarray]:
    """Trend quantities of a study, one value per point, from :class:`rigtools.analysis.point.DwellAnalysis`
    results (in the study's order): the peak force-sensor signal, the peak of each shroud
    acceleration, and the chosen harmonic amplitudes (peak; default 6·fe of the active shroud,
    8·fe and 22·fe of the passive, the paper's amplified harmonics). Keys are labels such as
    ``"peak force-sensor signal"``, ``"active shroud accel peak"``,
    ``"passive shroud accel 22·fe amplitude"``; missing channels or harmonics read NaN.
    Feed EM's and FEM's series to :func:`rigtools.analysis.plots.trend_figure`."""

    def label(ch):
        return ch.replace("_", " ")

    out: dict[str, list[float]] = {"peak force-sensor signal": []}
    for ch in shrouds:
        out[f"{label(ch)} peak"] = []
    for ch, ks in harmonics.items():
        for k in ks:
            out[f"{label(ch)} {k}·fe amplitude"] = []
    for p in points:
        out["peak force-sensor signal"].append(p.peak_levels.get(force, np.nan))
        for ch in shrouds:
            out[f"{label(ch)} peak"].append(p.peak_levels.get(ch, np.nan))
        for ch, ks in harmonics.items():
            fit = p.harmonics.get(ch)
            for k in ks:
                val = fit.at(k) if fit is not None and k <= fit.k[-1] else np.nan
                out[f"{label(ch)} {k}·fe amplitude"].append(val)
    return {key: np.asarray(v, dtype=float) for key, v in out.items()}


def point_agreement(
    em, model, *, channels: Sequence[str] | None = None, k_max: int | None = None
) -> Agreement:
    """:func:`agreement_score` of two :class:`rigtools.analysis.point.DwellAnalysis` results over the
    channels both have (or ``channels``), from their harmonic amplitudes."""
    names = [c for c in (channels or em.harmonics) if c in em.harmonics and c in model.harmonics]
    return agreement_score(
        {c: em.harmonics[c].amplitude for c in names},
        {c: model.harmonics[c].amplitude for c in names},
        k_max=k_max,
    )
