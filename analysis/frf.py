"""Frequency response functions from measured (or simulated) excitation and response records.

Conventions (the same as :func:`scipy.signal.csd`):

- ``csd(x, y)`` is the averaged ``conj(X) * Y`` (one-sided), so with ``x`` the excitation (force)
  and ``y`` the response,

  - ``H1 = Sxy / Sxx``  (least squares for noise on the response; biased LOW by input noise),
  - ``H2 = Syy / Syx``  with ``Syx = conj(Sxy)`` (biased HIGH by output noise),
  - ``coherence = |Sxy|**2 / (Sxx * Syy) = H1 / H2`` (real, between 0 and 1).

- Time convention ``exp(+i w t)``: a response lagging the force has a negative phase.
- FRF kinds: receptance ``X/F`` (m/N), mobility ``V/F = i w X/F`` (m/s/N),
  accelerance ``A/F = -w**2 X/F`` (m/s^2/N).

- ``Hv = H1 / sqrt(coherence)``: for one input, the geometric mean ``sqrt(|H1| |H2|)`` with the
  phase of H1 (H1 and H2 share their phase); the total-least-squares estimate, unbiased when the
  input and output noise-to-signal ratios are equal, and always between H1 and H2.

One FRF estimate per test (:class:`FRFMethod`, the one place that decides it): the estimator
and window follow from the excitation.

- ``"random"`` (continuous random): Hann window, 50 % overlap, many averages.
- ``"burst"`` (burst random): one frame per burst period, rectangular window, no overlap. The
  response must have decayed before the period ends, then a frame holds the whole transient
  and there is no leakage.
- ``"periodic"`` (periodic chirp, periodic random, pseudo-random): one frame per excitation
  period (whole periods), no window, no overlap, averages over periods; the response must be in
  its periodic steady state. Leakage-free at the bins ``k / period``.
- ``"impact"``: one frame per hammer hit, rectangular or force/exponential windows.

The coherence of a single average is identically 1 and meaningless, so
:meth:`FRFMethod.estimate` refuses fewer than two (an impact test takes one hit, without
coherence). Periodic (stepped-sine) excitation is best fitted at its exact frequency, see
:func:`sine_frf`.

Long records: :class:`SpectraAccumulator` takes the record block by block (any block sizes, any
number of channels) and accumulates the auto and cross spectra segment by segment, so memory is
bounded by one block plus one segment. It gives the same numbers as :func:`scipy.signal.csd` /
:func:`scipy.signal.welch` with the same settings (test: 1e-10).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
from scipy import signal

FRFKind = Literal["receptance", "mobility", "accelerance"]
_KINDS = ("receptance", "mobility", "accelerance")

#: Fewest samples in a frame of a measured FRF (``rig acquire frf``/``tap`` ``--frame``, ``rig analyze``
#: and ``rig export uff`` ``--frame-samples``). A frame of N samples gives N/2 + 1 lines from 0 Hz
#: to half the sample rate, of which the anti-alias margin (0.45 of the rate) leaves 0.9 N/2: 64
#: samples give 28 usable lines, room for a band of the 5 lines a modal fit needs on either side of
#: a resonance; fewer give an FRF of a handful of lines (3 samples: 2, at 0 Hz and half the rate)
#: that shows no resonance at all.
MIN_FRAME_SAMPLES = 64


@dataclass(frozen=True)
class FRFEstimate:
    """An averaged FRF estimate on a one-sided frequency grid.

    Attributes
    ----------
    frequency_hz
        (n_freq,) frequencies, Hz (0 .. sample_rate / 2).
    h1, h2
        (n_responses, n_freq) complex FRF estimates, response units per excitation unit, the
        responses in channel order.
    coherence
        Ordinary coherence, 0..1, shaped like ``h1``.
    n_averages
        Number of (overlapping) segments averaged.
    sxx, syy, sxy
        Auto spectra of excitation and response and the cross spectrum csd(x, y), as
        densities (units**2 / Hz); ``sxx`` is (n_freq,), ``syy`` and ``sxy`` shaped like ``h1``.
    """

    frequency_hz: np.ndarray
    h1: np.ndarray
    h2: np.ndarray
    coherence: np.ndarray
    n_averages: int
    sxx: np.ndarray
    syy: np.ndarray
    sxy: np.ndarray

    @property
    def resolution_hz(self) -> float:
        """Spacing of the frequency grid, Hz."""
        return float(self.frequency_hz[1] - self.frequency_hz[0])

    @property
    def hv(self) -> np.ndarray:
        """Hv = H1 / sqrt(coherence): geometric mean of ``|H1|`` and ``|H2|``, phase of H1 (NaN where the
        coherence is 0)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.h1 / np.sqrt(self.coherence)

    def estimator(self, name: str) -> np.ndarray:
        """``"h1"``, ``"h2"`` or ``"hv"`` by name."""
        if name not in ("h1", "h2", "hv"):
            raise ValueError(f"FRF estimator must be h1, h2 or hv, got {name!r}")
        return getattr(self, name)

    def as_kind(self, measured: FRFKind, target: FRFKind) -> FRFEstimate:
        """The same estimate with H1 and H2 converted from ``measured`` to ``target`` (e.g. an
        acceleration response, ``"accelerance"``, shown as ``"receptance"``); spectra and coherence
        unchanged."""
        f = self.frequency_hz
        return FRFEstimate(
            f,
            convert_frf(self.h1, f, measured, target),
            convert_frf(self.h2, f, measured, target),
            self.coherence,
            self.n_averages,
            self.sxx,
            self.syy,
            self.sxy,
        )


def n_welch_segments(n_samples: int, nperseg: int, noverlap: int) -> int:
    """Number of segments scipy's Welch averaging uses for a record of ``n_samples``."""
    if n_samples < nperseg:
        return 0
    return 1 + (n_samples - nperseg) // (nperseg - noverlap)


def sine_frf(
    excitation: np.ndarray, response: np.ndarray, sample_rate: float, frequency_hz: float
) -> complex:
    """Complex ratio response/excitation at one frequency (stepped-sine point).

    Each record is fitted by least squares with ``c + a cos(w t) + b sin(w t)``; the ratio of the
    fitted complex amplitudes ``a - i b`` is exact for any record length (no leakage), provided the
    response has settled.

    Examples
    --------
    >>> import numpy as np
    >>> from rigtools.analysis.frf import sine_frf
    >>> fs, f0 = 2000.0, 60.0
    >>> t = np.arange(1000) / fs
    >>> force = 2.0 * np.sin(2 * np.pi * f0 * t)
    >>> acceleration = 10.0 * np.sin(2 * np.pi * f0 * t - np.pi / 4)
    >>> h = sine_frf(force, acceleration, fs, f0)
    >>> round(abs(h), 6), round(float(np.degrees(np.angle(h))), 3)
    (5.0, -45.0)
    """
    x = np.asarray(excitation, dtype=float)
    y = np.asarray(response, dtype=float)
    t = np.arange(x.size) / sample_rate
    w = 2.0 * np.pi * frequency_hz
    basis = np.column_stack([np.ones_like(t), np.cos(w * t), np.sin(w * t)])
    coef, *_ = np.linalg.lstsq(basis, np.column_stack([x, y]), rcond=None)
    amp = coef[1] - 1j * coef[2]
    return complex(amp[1] / amp[0])


def convert_frf(h: np.ndarray, frequency_hz: np.ndarray, source: FRFKind, target: FRFKind) -> np.ndarray:
    """Convert between receptance, mobility and accelerance (``exp(+i w t)`` convention).

    mobility = i w * receptance; accelerance = i w * mobility = -w**2 * receptance. Converting
    towards receptance divides by ``(i w)**k`` and gives ``nan`` at 0 Hz.
    """
    if source not in _KINDS or target not in _KINDS:
        raise ValueError(f"FRF kind must be one of {_KINDS}, got {source!r} -> {target!r}")
    order = _KINDS.index(target) - _KINDS.index(source)
    iw = 2j * np.pi * np.asarray(frequency_hz, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.asarray(h) * iw**order


def sdof_frf(
    frequency_hz: np.ndarray,
    natural_hz: float,
    damping_ratio: float,
    modal_mass: float = 1.0,
    kind: FRFKind = "receptance",
) -> np.ndarray:
    """Exact FRF of a viscously damped single-degree-of-freedom oscillator.

    receptance = 1 / (m (wn**2 - w**2 + 2 i zeta wn w)), converted to ``kind``.
    """
    w = 2.0 * np.pi * np.asarray(frequency_hz, dtype=float)
    wn = 2.0 * np.pi * natural_hz
    receptance = 1.0 / (modal_mass * (wn**2 - w**2 + 2j * damping_ratio * wn * w))
    return convert_frf(receptance, frequency_hz, "receptance", kind)


class SpectraAccumulator:
    """Welch auto and cross spectra of a multichannel record fed block by block.

    Feed ``(n_channels, n)`` blocks of any length with :meth:`add`; every complete segment is
    windowed, detrended, transformed once per channel and added to the running sums
    ``sum |X_c|**2`` (every channel) and ``sum conj(X_ref) X_c`` (reference against every channel).
    Samples that do not yet fill a segment are carried to the next block, so the segmentation is
    that of one record whatever the block sizes. Memory: one block, one carried partial segment,
    and ``2 n_channels`` spectra.

    The scaling is :func:`scipy.signal.csd`'s ``scaling="density"``, one-sided (units**2 / Hz),
    ``average="mean"``.

    Parameters
    ----------
    sample_rate
        Samples per second, Hz.
    nperseg, noverlap, window, detrend
        Segment length in samples, overlap in samples (default half a segment), any
        :func:`scipy.signal.get_window` name, and ``"constant"`` (remove each segment's mean)
        or ``False``.
    reference
        Index of the reference (excitation) channel.
    segments_per_batch
        Segments transformed at once (bounds the work memory to about
        ``segments_per_batch * nperseg * n_channels * 16`` bytes).
    channel_windows
        Optional ``(n_channels, nperseg)`` windows applied to each channel's segment on top of
        ``window`` (impact tests: a force window on the force, an exponential window on the
        responses, as :class:`FRFMethod` states them).
    """

    def __init__(
        self,
        sample_rate: float,
        *,
        nperseg: int,
        noverlap: int | None = None,
        window: str = "hann",
        detrend: str | bool = "constant",
        reference: int = 0,
        segments_per_batch: int = 64,
        channel_windows: np.ndarray | None = None,
    ) -> None:
        if not sample_rate > 0:
            raise ValueError("sample_rate must be positive")
        self.sample_rate = float(sample_rate)
        self.nperseg = int(nperseg)
        self.noverlap = self.nperseg // 2 if noverlap is None else int(noverlap)
        if self.nperseg < 2 or not 0 <= self.noverlap < self.nperseg:
            raise ValueError(f"need nperseg >= 2 and 0 <= noverlap < nperseg, got {nperseg}, {noverlap}")
        if detrend not in ("constant", False):
            raise ValueError(f"detrend must be 'constant' or False, got {detrend!r}")
        self.detrend = detrend
        self.reference = int(reference)
        self.window = signal.get_window(window, self.nperseg)
        self.channel_windows = None if channel_windows is None else np.asarray(channel_windows, dtype=float)
        self.step = self.nperseg - self.noverlap
        self.batch = max(1, int(segments_per_batch))
        self._tail: np.ndarray | None = None
        self._auto: np.ndarray | None = None
        self._cross: np.ndarray | None = None
        self.n_segments = 0

    def add(self, block: np.ndarray) -> None:
        """Add the next ``(n_channels, n)`` samples (1-D for one channel) of the record."""
        block = np.atleast_2d(np.asarray(block, dtype=float))
        if self._tail is None:
            self._tail = np.empty((block.shape[0], 0))
        elif block.shape[0] != self._tail.shape[0]:
            raise ValueError(f"block has {block.shape[0]} channels, earlier blocks had {self._tail.shape[0]}")
        buf = np.concatenate([self._tail, block], axis=1) if self._tail.shape[1] else block
        n_seg = n_welch_segments(buf.shape[1], self.nperseg, self.noverlap)
        for first in range(0, n_seg, self.batch):
            count = min(self.batch, n_seg - first)
            start = first * self.step
            stop = start + (count - 1) * self.step + self.nperseg
            segs = np.lib.stride_tricks.sliding_window_view(buf[:, start:stop], self.nperseg, axis=1)[
                :, :: self.step
            ]
            self._accumulate(segs)
        self._tail = buf[:, n_seg * self.step :].copy()

    def _accumulate(self, segs: np.ndarray) -> None:
        # segs: (n_channels, n_segments, nperseg)
        if self.detrend == "constant":
            segs = segs - segs.mean(axis=-1, keepdims=True)
        if self.channel_windows is not None:
            segs = segs * self.channel_windows[:, None, :]
        spec = np.fft.rfft(segs * self.window, axis=-1)
        auto = np.einsum("csf,csf->cf", spec.real, spec.real) + np.einsum("csf,csf->cf", spec.imag, spec.imag)
        cross = np.einsum("sf,csf->cf", np.conj(spec[self.reference]), spec)
        if self._auto is None:
            self._auto, self._cross = auto, cross
        else:
            self._auto += auto
            self._cross += cross
        self.n_segments += segs.shape[1]

    def spectra(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(frequency_hz, auto, cross)``: ``auto`` (n_channels, n_freq) real densities,
        ``cross`` (n_channels, n_freq) = csd(reference, channel), as scipy scales them."""
        if self.n_segments == 0:
            raise ValueError(f"no complete segment of {self.nperseg} samples yet")
        scale = 1.0 / (self.sample_rate * np.sum(self.window**2) * self.n_segments)
        one_sided = np.full(self.nperseg // 2 + 1, 2.0)
        one_sided[0] = 1.0
        if self.nperseg % 2 == 0:
            one_sided[-1] = 1.0
        f = np.fft.rfftfreq(self.nperseg, 1.0 / self.sample_rate)
        return f, self._auto * scale * one_sided, self._cross * scale * one_sided

    def frf(self, min_averages: int = 2) -> FRFEstimate:
        """H1, H2 and coherence of every other channel over the reference channel.

        ``h1`` etc. are (n_responses, n_freq) in channel order without the reference. With
        ``min_averages=1`` (one impact) a single frame is accepted; its coherence is NaN (one
        average has coherence 1 by construction, which says nothing)."""
        if self.n_segments < max(1, min_averages):
            raise ValueError(
                f"{self.n_segments} segment(s) of {self.nperseg}: need at least {max(1, min_averages)} "
                "averages (a single average has coherence 1 by construction)"
            )
        f, auto, cross = self.spectra()
        resp = [c for c in range(auto.shape[0]) if c != self.reference]
        sxx, syy, sxy = auto[self.reference].real, auto[resp].real, cross[resp]
        est = _frf_from_spectra(f, sxx, syy, sxy, self.n_segments)
        if self.n_segments < 2:
            est = replace(est, coherence=np.full_like(est.coherence, np.nan))
        return est


def _frf_from_spectra(f, sxx, syy, sxy, n_avg) -> FRFEstimate:
    with np.errstate(divide="ignore", invalid="ignore"):
        h1 = sxy / sxx
        h2 = syy / np.conj(sxy)
        coh = np.abs(sxy) ** 2 / (sxx * syy)
    return FRFEstimate(f, h1, h2, np.clip(np.nan_to_num(coh), 0.0, 1.0), n_avg, sxx, syy, sxy)


# ---------------------------------------------------------------------------------------------
# One FRF estimate per test: the method follows from the excitation
# ---------------------------------------------------------------------------------------------

METHOD_EXCITATIONS = ("burst", "impact", "periodic", "random")


@dataclass(frozen=True)
class FRFMethod:
    """How the FRF of a test is estimated; the one place that decides it for every reader.

    ============  ==========================================  =================================
    excitation    frames                                      window
    ============  ==========================================  =================================
    ``burst``     one burst period each, contiguous           rectangular (none), no overlap
    ``impact``    one per hit, starting just before it        rectangular, or a force window on
                                                              the force and an exponential
                                                              window on the responses (pyFRF's
                                                              ``force:x`` / ``exponential:x``)
    ``periodic``  whole excitation periods, contiguous        rectangular (none), no overlap
    ``random``    continuous record, ``frame_samples`` each   Hann, 50 % overlap
    ============  ==========================================  =================================

    Attributes
    ----------
    excitation
        One of :data:`METHOD_EXCITATIONS`.
    frame_samples
        Samples per frame (segment); the resolution is ``sample_rate / frame_samples``.
    frame_starts
        ``impact``: first sample of each frame, relative to the analysed record; empty otherwise
        (contiguous frames from the record's start).
    force_window
        ``impact``: fraction of the frame kept of the force (the rest set to zero), or None.
    exponential
        ``impact``: value the exponential response window reaches at the frame's end, or None.
        It adds ``-ln(exponential) / (2 pi f T)`` to the damping ratio a fit reads at ``f``.
    reason
        Why this method was chosen (the recording's procedure, the force's content, the user).
    """

    excitation: str
    frame_samples: int
    frame_starts: tuple[int, ...] = ()
    force_window: float | None = None
    exponential: float | None = None
    reason: str = ""

    def __post_init__(self) -> None:
        if self.excitation not in METHOD_EXCITATIONS:
            raise ValueError(
                f"excitation must be one of {', '.join(METHOD_EXCITATIONS)}, got {self.excitation!r}"
            )
        if self.frame_samples < 2:
            raise ValueError(f"frame_samples must be at least 2, got {self.frame_samples}")

    @property
    def window(self) -> str:
        """The segment window of every channel: ``"hann"`` (random) or ``"boxcar"``."""
        return "hann" if self.excitation == "random" else "boxcar"

    @property
    def overlap(self) -> int:
        """Overlap of successive frames in samples (half a frame for random, else 0)."""
        return self.frame_samples // 2 if self.excitation == "random" else 0

    @property
    def min_averages(self) -> int:
        """1 for an impact test (one hit gives an FRF, without coherence), else 2."""
        return 1 if self.excitation == "impact" else 2

    def channel_windows(self, n_channels: int) -> np.ndarray | None:
        """``(n_channels, frame_samples)`` windows (force first), or None when there are none."""
        if self.force_window is None and self.exponential is None:
            return None
        n = self.frame_samples
        w = np.ones((n_channels, n))
        if self.force_window is not None:
            w[0, int(self.force_window * n) :] = 0.0
        if self.exponential is not None:
            w[1:] *= np.exp(np.log(self.exponential) * np.arange(n) / (n - 1))
        return w

    def describe(self, sample_rate: float) -> str:
        """One line: excitation, frames, window, resolution (for notes and the record)."""
        df = sample_rate / self.frame_samples
        if self.excitation == "random":
            text = f"continuous random: Hann window, {self.frame_samples}-sample frames, 50 % overlap"
        elif self.excitation == "impact":
            wins = []
            if self.force_window is not None:
                wins.append(f"force window {self.force_window:g} of the frame on the force")
            if self.exponential is not None:
                wins.append(f"exponential window to {self.exponential:g} on the responses")
            text = (
                f"impact: {len(self.frame_starts)} hit(s), one {self.frame_samples}-sample frame per hit, "
                + (", ".join(wins) if wins else "rectangular window")
            )
        elif self.excitation == "burst":
            text = f"burst: one {self.frame_samples}-sample frame per burst period, rectangular window"
        else:
            text = f"periodic: whole periods of {self.frame_samples} samples, no window"
        return f"{text}, {df:.4g} Hz resolution" + (f" ({self.reason})" if self.reason else "")

    def to_dict(self, sample_rate: float) -> dict:
        """Plain-Python form for ``--json`` and recordings."""
        return {
            "excitation": self.excitation,
            "frame_samples": self.frame_samples,
            "frames": len(self.frame_starts) if self.frame_starts else None,
            "window": self.window,
            "overlap": self.overlap,
            "force_window": self.force_window,
            "exponential": self.exponential,
            "resolution_hz": sample_rate / self.frame_samples,
            "reason": self.reason,
            "text": self.describe(sample_rate),
        }

    def estimate(self, blocks: Iterable[np.ndarray], sample_rate: float) -> FRFEstimate:
        """H1, H2 and coherence of every response over the force by this method.

        Parameters
        ----------
        blocks
            ``(n_channels, n)`` arrays in time order, the force in row 0 (one array holds the
            whole record); for ``impact``, one block per frame of exactly ``frame_samples``.
        sample_rate
            Samples per second, Hz.

        Returns
        -------
        FRFEstimate
            ``h1``, ``h2``, ``coherence``, ``syy``, ``sxy`` of shape (n_responses, n_freq).

        Raises
        ------
        ValueError
            Fewer averages than :attr:`min_averages`.
        """
        acc: SpectraAccumulator | None = None
        for block in blocks:
            block = np.atleast_2d(np.asarray(block, dtype=float))
            if acc is None:
                acc = self.accumulator(sample_rate, block.shape[0])
            acc.add(block)
        if acc is None:
            raise ValueError("no samples to estimate an FRF from")
        return acc.frf(self.min_averages)

    def accumulator(self, sample_rate: float, n_channels: int) -> SpectraAccumulator:
        """A :class:`SpectraAccumulator` with this method's settings (channel 0 the force). For
        ``impact``, add each frame as its own block of exactly ``frame_samples``."""
        return SpectraAccumulator(
            sample_rate,
            nperseg=self.frame_samples,
            noverlap=self.overlap,
            window=self.window,
            detrend="constant" if self.excitation == "random" else False,
            reference=0,
            channel_windows=self.channel_windows(n_channels),
        )


def find_hits(
    force: np.ndarray, sample_rate: float, *, threshold: float = 0.2, min_spacing_s: float = 0.05
) -> np.ndarray:
    """Sample indices of the hits of an impact hammer: peaks of ``|force|`` above ``threshold``
    of the largest, at least ``min_spacing_s`` apart."""
    from scipy.signal import find_peaks

    f = np.abs(np.asarray(force, dtype=float))
    if f.size == 0 or not np.any(f > 0):
        return np.array([], dtype=int)
    peaks, _ = find_peaks(
        f, height=threshold * float(f.max()), distance=max(1, int(min_spacing_s * sample_rate))
    )
    # a peak at sample 0 is not found by find_peaks; a triggered frame may start on the hit
    if f[0] >= threshold * float(f.max()) and (peaks.size == 0 or peaks[0] > min_spacing_s * sample_rate):
        peaks = np.concatenate([[0], peaks])
    return peaks.astype(int)


def is_impact(force: np.ndarray, sample_rate: float, hits: np.ndarray | None = None) -> bool:
    """True when the force is a series of short pulses: 90 % of its energy (about its median)
    lies within 5 ms after the hits and the hits cover under 20 % of the record."""
    x = np.asarray(force, dtype=float)
    x = x - np.median(x)
    hits = find_hits(x, sample_rate) if hits is None else hits
    if hits.size == 0:
        return False
    width = max(1, round(0.005 * sample_rate))
    pre = max(1, width // 5)
    near = np.zeros(x.size, bool)
    for h in hits:
        near[max(0, h - pre) : h + width] = True
    energy = float(np.sum(x**2))
    return bool(energy > 0 and np.sum(x[near] ** 2) >= 0.9 * energy and near.mean() < 0.2)


def impact_method(
    force: np.ndarray,
    sample_rate: float,
    *,
    pretrigger_s: float = 0.002,
    force_window: float | None = None,
    exponential: float | None = None,
    reason: str = "",
) -> FRFMethod:
    """Frames aligned to the hits of ``force``: each starts ``pretrigger_s`` before its hit (less
    if the record starts sooner) and is as long as the shortest spacing of hits (or the rest of
    the record after a single hit)."""
    x = np.asarray(force, dtype=float)
    hits = find_hits(x - np.median(x), sample_rate)
    if hits.size == 0:
        raise ValueError("no hit found in the force")
    pre = round(pretrigger_s * sample_rate)
    if hits.size > 1:
        pre = min(pre, int(np.min(np.diff(hits))) // 20)
    pre = min(pre, int(hits[0]))
    starts = hits - pre
    frame = int(np.min(np.diff(starts))) if starts.size > 1 else x.size - int(starts[0])
    if int(starts[-1]) + frame > x.size:  # the last hit's frame runs past the end
        if starts.size > 1:
            starts = starts[:-1]
        else:
            frame = x.size - int(starts[-1])
    return FRFMethod(
        "impact",
        int(frame),
        tuple(int(s) for s in starts),
        force_window=force_window,
        exponential=exponential,
        reason=reason,
    )


def method_from_content(
    force: np.ndarray, sample_rate: float, *, frame_samples: int | None = None, reason: str = ""
) -> FRFMethod:
    """The method for a record written elsewhere, from the force itself: hits of a hammer
    (:func:`is_impact`) give :func:`impact_method`; anything else is continuous random, Hann with
    overlap, ``frame_samples`` per frame (default: the power of two that gives about 16
    averages, at most 65536)."""
    x = np.asarray(force, dtype=float)
    if is_impact(x, sample_rate):
        return impact_method(x, sample_rate, reason=reason or "hits found in the force")
    return FRFMethod(
        "random",
        int(frame_samples or random_frame_samples(x.size)),
        reason=reason or "continuous force (no isolated hits)",
    )


def random_frame_samples(n_samples: int) -> int:
    """Frame length for continuous random excitation: the power of two that gives about 16
    averages with 50 % overlap, between 16 and 65536 samples."""
    return int(min(2 ** np.floor(np.log2(max(n_samples / 8.5, 16))), 1 << 16))
