"""Decimation for the live plots that never hides a spike: min/max envelopes.

A trace of ``n`` samples drawn on a few hundred pixels is cut into buckets; each bucket gives its
smallest and its largest sample, in time order, at their own sample times. Every sample lies
between the two points drawn for its bucket, and every bucket's extremes are drawn at their exact
value, so a one-sample impact spike stays in the picture at its full height (plain striding would
drop it). A spectrum keeps each bucket's largest bin (its peaks matter, not its troughs).
"""

from __future__ import annotations

import numpy as np

#: Points a trace is decimated to (two per bucket).
TRACE_POINTS = 2000
#: Points a spectrum is decimated to.
SPECTRUM_POINTS = 2000


def min_max_envelope(
    y: np.ndarray, t0: float, dt: float, max_points: int = TRACE_POINTS
) -> tuple[np.ndarray, np.ndarray]:
    """``(times, values)`` of ``y`` for a line plot of at most about ``max_points`` points.

    Parameters
    ----------
    y
        (n,) samples.
    t0, dt
        Time of ``y[0]`` and the sample interval, s.
    max_points
        Points wanted; ``y`` is returned whole when it has no more samples than that.

    Returns
    -------
    times, values
        Each bucket's minimum and maximum at their sample times, in time order.

    Examples
    --------
    >>> y = np.zeros(10_000); y[1234] = 50.0
    >>> t, v = min_max_envelope(y, 0.0, 1e-3, max_points=100)
    >>> len(v) <= 100, float(v.max()), float(t[v.argmax()])
    (True, 50.0, 1.234)
    """
    y = np.asarray(y, dtype=float)
    n = len(y)
    if n <= max_points:
        return t0 + np.arange(n) * dt, y
    buckets = max(1, max_points // 2)
    size = int(np.ceil(n / buckets))
    m = n // size
    idx_min = np.empty(m + (n % size > 0), dtype=np.int64)
    idx_max = np.empty_like(idx_min)
    body = y[: m * size].reshape(m, size)
    base = np.arange(m) * size
    idx_min[:m] = base + np.argmin(body, axis=1)
    idx_max[:m] = base + np.argmax(body, axis=1)
    if n % size:
        tail = y[m * size :]
        idx_min[m] = m * size + int(np.argmin(tail))
        idx_max[m] = m * size + int(np.argmax(tail))
    first = np.minimum(idx_min, idx_max)
    second = np.maximum(idx_min, idx_max)
    order = np.column_stack([first, second]).ravel()
    return t0 + order * dt, y[order]


def max_envelope(
    freqs: np.ndarray, amplitude: np.ndarray, max_points: int = SPECTRUM_POINTS
) -> tuple[np.ndarray, np.ndarray]:
    """``(frequencies, amplitudes)``: the largest bin of each bucket (peaks kept at their bin)."""
    n = len(amplitude)
    if n <= max_points:
        return np.asarray(freqs, dtype=float), np.asarray(amplitude, dtype=float)
    size = int(np.ceil(n / max_points))
    m = int(np.ceil(n / size))
    padded = np.full(m * size, -np.inf)
    padded[:n] = amplitude
    idx = np.arange(m) * size + np.argmax(padded.reshape(m, size), axis=1)
    return np.asarray(freqs, dtype=float)[idx], np.asarray(amplitude, dtype=float)[idx]
