"""Which groups of stable SSI poles are modes, which are tones (step 4 of
:mod:`rigtools.analysis.oma`).

Each candidate (a group of poles stable over the converged orders) is measured on its own modal
coordinate (the record projected on its shape): the kurtosis of that coordinate filtered around
the candidate (:func:`rigtools.analysis.tones.band_kurtosis`), and how far the coordinate's
averaged spectrum stands above its flanks. Then:

- a **harmonic** (a tone, never a mode): kurtosis below :data:`TONE_KURTOSIS` and below 3 by
  three standard errors, with damping below :data:`TONE_MAX_DAMPING` (a steady sine); or damping
  below :data:`TONE_MAX_DAMPING` on a multiple ``k f0`` (within half a line) of ``fe`` or, without
  ``fe``, of the tones found that way (a rotor's 3P, 6P, 9P: the higher ones wander and look
  Gaussian, but stay on the family);
- **dropped**: damping not positive; a harmonic inside its half-power band (a mode there cannot
  be told from the tone); a modal coordinate standing less than :data:`CONTRAST_DB` over its
  flanks at three damping ratios away (a pole of noise: its coordinate is as flat as the noise);
  with one channel (no shape), no peak of the averaged spectrum in its half-power band that a
  nearer pole does not explain;
- a **mode** otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from rigtools.analysis.tones import GAUSSIAN_KURTOSIS, band_kurtosis, harmonic_family

TONE_KURTOSIS = (
    2.5  # a sine of power P over noise s in the band: (1.5P² + 6Ps + 3s²)/(P + s)² < 2.5 for P > 1.3 s
)
TONE_MAX_DAMPING = 0.01  # a tone's pole is sharp; a resonance passing the kurtosis test by chance is not
CONTRAST_DB = 3.0  # a resonance stands 10 dB over its flanks at 3 damping ratios away (SDOF)


@dataclass(frozen=True)
class OMAMode:
    """A mode identified from a response-only record.

    Attributes
    ----------
    frequency_hz, damping_ratio
        Medians over the converged model orders.
    frequency_spread_hz, damping_spread
        The spread to compare estimates with: the model-order scatter (standard deviation over
        the orders) combined (root sum of squares) with the record's statistical spread,
        ``f sqrt(zeta / (f T))`` for the frequency and ``sqrt(zeta / (f T))`` for the damping
        ratio from ``T`` seconds (an upper bound measured by simulation: a 3 Hz, 2 % mode under
        white noise, 30 records each of 100 s and 400 s, scattered by 0.022 and 0.0077 Hz and
        by 0.0050 and 0.0028 in damping ratio; the bound gives 0.024, 0.012 Hz and 0.0082, 0.0041).
    order_scatter_hz
        The model-order scatter of the frequency alone.
    shape
        (channels,) complex shape at the sensors, in the channels' own units, unit norm, the
        largest component real and positive.
    mpc
        Modal phase collinearity (1: real shape).
    orders_stable, orders_judged
        Converged orders holding a stable pole of the mode / converged orders.
    kurtosis, kurtosis_error
        Kurtosis of the band-filtered modal coordinate and its standard error (3 for a mode
        under random load).
    contrast_db
        How far the modal coordinate's averaged spectrum stands over its flanks.
    """

    frequency_hz: float
    damping_ratio: float
    frequency_spread_hz: float
    damping_spread: float
    order_scatter_hz: float
    shape: np.ndarray
    mpc: float
    orders_stable: int
    orders_judged: int
    kurtosis: float
    kurtosis_error: float
    contrast_db: float

    def to_dict(self, channels: list[str] | None = None) -> dict:
        """Plain-Python fields; the shape as magnitudes signed by the real part's sign."""
        shape = [float(abs(v) * (1 if np.real(v) >= 0 else -1)) for v in self.shape]
        return {
            "frequency_hz": self.frequency_hz,
            "damping_ratio": self.damping_ratio,
            "frequency_spread_hz": self.frequency_spread_hz,
            "damping_spread": self.damping_spread,
            "order_scatter_hz": self.order_scatter_hz,
            "mpc": self.mpc,
            "orders_stable": self.orders_stable,
            "orders_judged": self.orders_judged,
            "kurtosis": self.kurtosis,
            "kurtosis_error": self.kurtosis_error,
            "contrast_db": self.contrast_db,
            "shape": dict(zip(channels, shape, strict=True)) if channels else shape,
        }


@dataclass(frozen=True)
class Harmonic:
    """A sharp line that the identification explained with a pole, flagged as a tone.

    Attributes
    ----------
    frequency_hz, damping_ratio
        Of its pole (medians over the converged orders).
    reason
        Why it is a tone and not a mode (one sentence).
    multiple
        ``k`` when it sits on ``k f0`` of the family (``fe`` or the tones found), else None.
    kurtosis, kurtosis_error
        Of the band-filtered coordinate (1.5 for a pure sine, 3 for a random resonance).
    rank_db
        First over second singular value of the averaged cross-spectral matrix at the line
        (a rank-one line: high).
    """

    frequency_hz: float
    damping_ratio: float
    reason: str
    multiple: int | None
    kurtosis: float
    kurtosis_error: float
    rank_db: float

    def to_dict(self) -> dict:
        return {
            "frequency_hz": self.frequency_hz,
            "damping_ratio": self.damping_ratio,
            "reason": self.reason,
            "multiple": self.multiple,
            "kurtosis": self.kurtosis,
            "kurtosis_error": self.kurtosis_error,
            "rank_db": self.rank_db,
        }


@dataclass(frozen=True)
class Candidate:
    """A group of poles stable over the converged orders, measured on its modal coordinate.

    ``poles`` index the caller's chart; ``frequencies`` and ``dampings`` are the group's poles
    (one per order); ``shape`` is in the channels' own units."""

    poles: np.ndarray
    frequencies: np.ndarray
    dampings: np.ndarray
    shape: np.ndarray
    mpc: float
    kurtosis: float
    kurtosis_error: float
    rank_db: float
    contrast_db: float
    orders_judged: int

    @property
    def frequency_hz(self) -> float:
        return float(np.median(self.frequencies))

    @property
    def damping_ratio(self) -> float:
        return float(np.median(self.dampings))

    @property
    def pdf_tone(self) -> bool:
        """Not Gaussian, as a sine: kurtosis below :data:`TONE_KURTOSIS` and below 3 by three
        standard errors, with damping below :data:`TONE_MAX_DAMPING`."""
        k, e = self.kurtosis, self.kurtosis_error
        return bool(
            np.isfinite(k)
            and k < TONE_KURTOSIS
            and k + 3 * e < GAUSSIAN_KURTOSIS
            and self.damping_ratio < TONE_MAX_DAMPING
        )


def coordinate(y: np.ndarray, shape: np.ndarray) -> np.ndarray:
    """The modal coordinate by a spatial filter: ``y`` (channels as identified) projected on
    the real part of ``shape`` (its magnitude when the real part vanishes)."""
    w = np.real(shape)
    if not np.any(w):
        w = np.abs(shape)
    return w @ y / float(w @ w)


def tone_band(f0: float, zeta: float, df: float, seconds: float, nyq: float) -> tuple[float, float]:
    """Band for the kurtosis test: six lines of the averaged spectrum, or twice the mode's
    half-power band, or enough for ``B T`` of 30 after the filter's settling (40 / T), whichever
    is widest; at most ``f0`` wide, inside (0, nyq)."""
    width = max(6 * df, 4 * abs(zeta) * f0, 40.0 / seconds)
    width = min(width, f0, 1.8 * (nyq - f0))
    return f0 - width / 2, f0 + width / 2


def contrast_db(x: np.ndarray, fs: float, nperseg: int, fm: float, zm: float) -> float:
    """How far (dB) the averaged PSD of ``x`` at ``fm`` stands above its higher value at
    ``fm (1 +- 3 zeta)`` (at least three lines away; one side near 0 Hz or Nyquist): 10 dB
    for a lone resonance, about 0 for noise."""
    f, psd = signal.welch(x, fs=fs, nperseg=nperseg)
    smooth = np.convolve(psd, np.ones(3) / 3, mode="same")
    away = max(3 * abs(zm) * fm, 3 * f[1])
    at = np.interp([fm - away, fm, fm + away], f, smooth)
    if fm - away <= 0 or fm + away >= f[-1]:
        side = at[2] if fm - away <= 0 else at[0]
    else:
        side = max(at[0], at[2])
    return float(10 * np.log10(at[1] / side)) if side > 0 and at[1] > 0 else float("nan")


def measure(
    poles: np.ndarray,
    frequencies: np.ndarray,
    dampings: np.ndarray,
    shape_scaled: np.ndarray,
    shape: np.ndarray,
    mpc: float,
    y: np.ndarray,
    fs: float,
    nperseg: int,
    rank_db: float,
    orders_judged: int,
) -> Candidate:
    """A :class:`Candidate` from its poles and the record ``y`` (channels scaled as identified,
    ``shape_scaled`` the shape in those units)."""
    fm, zm = float(np.median(frequencies)), float(np.median(dampings))
    x = coordinate(y, shape_scaled)
    lo, hi = tone_band(fm, zm, fs / nperseg, y.shape[1] / fs, fs / 2)
    kurt, err = band_kurtosis(x, fs, lo, hi) if lo > 0 else (float("nan"), float("nan"))
    return Candidate(
        poles,
        frequencies,
        dampings,
        shape,
        mpc,
        kurt,
        err,
        rank_db,
        contrast_db(x, fs, nperseg, fm, zm),
        orders_judged,
    )


def _tone_reason(c: Candidate, multiple: int | None, f0: float | None, fe: float | None) -> str:
    why = []
    if c.pdf_tone:
        why.append(
            f"a tone: kurtosis {c.kurtosis:.2f} +- {c.kurtosis_error:.2f} of its band-filtered response "
            f"(a sine 1.5, a resonance under random load 3), damping {100 * c.damping_ratio:.3g} %"
        )
    if multiple is not None and f0 is not None and not (c.pdf_tone and multiple == 1 and fe is None):
        of = "fe" if fe is not None else "the tone found"
        why.append(
            f"on {multiple} x {f0:.5g} Hz ({of}) with damping {100 * c.damping_ratio:.3g} % "
            f"(below {100 * TONE_MAX_DAMPING:g} %)"
        )
    if np.isfinite(c.rank_db):
        why.append(f"first singular value {c.rank_db:.0f} dB over the second")
    return "; ".join(why)


def _drop(c: Candidate, reason: str) -> dict:
    return {"frequency_hz": c.frequency_hz, "damping_ratio": c.damping_ratio, "reason": reason}


def _spread(c: Candidate, seconds: float) -> tuple[float, float, float]:
    fm, zm = c.frequency_hz, c.damping_ratio
    n = c.frequencies.size
    f_std = float(np.std(c.frequencies, ddof=1)) if n > 1 else 0.0
    z_std = float(np.std(c.dampings, ddof=1)) if n > 1 else 0.0
    stat = float(np.sqrt(max(zm, 0.0) / (fm * seconds)))
    return float(np.hypot(f_std, fm * stat)), float(np.hypot(z_std, stat)), f_std


def select(
    candidates: list[Candidate],
    *,
    frequency_hz: np.ndarray,
    level: np.ndarray,
    peak_idx: np.ndarray,
    fe: float | None,
    seconds: float,
    channels: int,
) -> tuple[list[OMAMode], list[Harmonic], float | None, list[int], list[dict]]:
    """Modes, harmonics, the family's fundamental (``fe`` or the tones', None without
    harmonics), for each candidate the index of its mode (-1 for none) and the dropped ones
    with their reasons (module docstring).

    ``frequency_hz``, ``level`` and ``peak_idx`` are the averaged spectrum (first singular
    value) and its peaks; ``seconds`` the record's length; ``channels`` its number of channels.
    """
    f = frequency_hz
    df = float(f[1])
    order = sorted(range(len(candidates)), key=lambda i: candidates[i].frequency_hz)
    cands = [candidates[i] for i in order]
    anchors = [c.frequency_hz for c in cands if c.pdf_tone]
    f0 = fe
    if f0 is None and anchors:
        f0 = harmonic_family(anchors, df / 2, min_members=1)[0]
    ks: list[int | None] = [None] * len(cands)
    if f0 is not None:  # without fe or a tone, no family (2, 5, 7.5 Hz are 4, 10, 15 x 0.5 Hz)
        ks = harmonic_family([c.frequency_hz for c in cands], df / 2, fundamental_hz=f0)[1]
    harmonics: list[Harmonic] = []
    kept: list[tuple[int, Candidate]] = []
    for i, c, k in zip(order, cands, ks, strict=True):
        on_family = k is not None and c.damping_ratio < TONE_MAX_DAMPING
        if c.pdf_tone or on_family:
            m = k if k is not None else None
            harmonics.append(
                Harmonic(
                    c.frequency_hz,
                    c.damping_ratio,
                    _tone_reason(c, m, f0, fe),
                    m,
                    c.kurtosis,
                    c.kurtosis_error,
                    c.rank_db,
                )
            )
        else:
            kept.append((i, c))
    # one channel: each peak of the averaged spectrum makes one mode, the nearest candidate's
    owner: dict[int, int] = {}
    for p in peak_idx:
        holding = [(abs(f[p] - c.frequency_hz), i) for i, c in kept if _holds(c, f[p], df)]
        if holding:
            owner[int(p)] = min(holding)[1]
    modes: list[OMAMode] = []
    dropped: list[dict] = []
    mode_of = [-1] * len(candidates)
    for i, c in kept:
        on = [
            h for h in harmonics if abs(h.frequency_hz - c.frequency_hz) <= c.damping_ratio * c.frequency_hz
        ]
        if c.damping_ratio <= 0:
            dropped.append(_drop(c, "damping ratio not positive and not a tone: no physical mode"))
        elif on:
            dropped.append(
                _drop(
                    c,
                    f"the harmonic at {on[0].frequency_hz:.5g} Hz lies in its half-power band: a mode "
                    "there cannot be told from the tone",
                )
            )
        elif channels == 1 and not any(owner.get(int(p)) == i for p in peak_idx):
            dropped.append(
                _drop(
                    c,
                    "no peak of the averaged spectrum in its half-power band that a nearer pole does "
                    "not explain (one channel: no shape to tell a mode from a noise pole)",
                )
            )
        elif not c.contrast_db >= CONTRAST_DB:
            dropped.append(
                _drop(
                    c,
                    f"its modal coordinate's averaged spectrum stands {c.contrast_db:.1f} dB over its "
                    f"flanks at 3 damping ratios away ({CONTRAST_DB:g} dB needed): a noise pole",
                )
            )
        else:
            f_spread, z_spread, scatter = _spread(c, seconds)
            mode_of[i] = len(modes)
            modes.append(
                OMAMode(
                    c.frequency_hz,
                    c.damping_ratio,
                    f_spread,
                    z_spread,
                    scatter,
                    c.shape,
                    c.mpc,
                    int(c.frequencies.size),
                    c.orders_judged,
                    c.kurtosis,
                    c.kurtosis_error,
                    c.contrast_db,
                )
            )
    return modes, harmonics, f0 if harmonics else fe, mode_of, dropped


def _holds(c: Candidate, fp: float, df: float) -> bool:
    return abs(fp - c.frequency_hz) <= max(c.damping_ratio * c.frequency_hz, df)


def label_peaks(
    f: np.ndarray, level: np.ndarray, idx: np.ndarray, modes: list[OMAMode], harmonics: list[Harmonic]
) -> list[dict]:
    """Each peak of the averaged spectrum with what explains it: a harmonic within two lines,
    a mode whose half-power band (at least one line either side) holds it, or none."""
    df = float(f[1])
    out = []
    for i in idx:
        fp = float(f[i])
        by = "none"
        if any(abs(fp - h.frequency_hz) <= 2 * df for h in harmonics):
            by = "harmonic"
        elif any(abs(fp - m.frequency_hz) <= max(m.damping_ratio * m.frequency_hz, df) for m in modes):
            by = "mode"
        out.append({"frequency_hz": fp, "level": float(level[i]), "explained_by": by})
    return out
