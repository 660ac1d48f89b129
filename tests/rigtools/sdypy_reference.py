"""The reference modes of a measured FRF: sdypy-EMA's LSCF poles and its own stability
classification, selected automatically by a stated procedure (issue 18). Nothing here comes from
rigtools: the test holds the toolkit's modes against this.

Procedure (every setting with its reason):

1. Poles: ``sdypy.EMA.Model(frf, freq, lower, upper, pol_order_high=P, frf_form=...)`` and
   ``get_poles(method="lscf")`` on the same FRF and band as the toolkit.
2. Stability: sdypy-EMA's own classification, ``stabilization._stabilization`` with its default
   tolerances (0.1 % in frequency, 5 % in damping against the previous order, damping > 0) - the
   function and values its stability chart and ``Model.select_closest_poles`` use.
3. Converged orders: the upper half of the orders run (order index P/2+1..P, polynomial orders
   P+2..2P); the lower orders have not settled (poles still appear and move).
4. Mode indicator: with one FRF, the peaks of ``|H|`` with a prominence of 3 dB (the peak has both
   half-power points: a resonance) - the single-reference CMIF.
5. A peak is a mode when, at half of the converged orders or more, a stable pole with physical
   damping (0 < zeta <= 10 %) has the peak inside its half-power band ``fn (1 +- zeta)`` (at
   least one bin): the nearest such pole at each order, taken by the peaks in decreasing
   prominence, each pole for one peak only. Its frequency and damping are the medians over those
   orders (a pole that jumps at a few orders does not move them).
6. The FRF is measured well there: coherence >= 0.9 over the mode's half-power band (a bump
   between two anti-resonances, where the response is weak, is not a resonance; 0.9 is the usual
   floor for a usable FRF).
7. Model order: P = 20, 40, 80, 120, 160 in turn; the first P whose set of modes (the peaks they
   explain) the next P repeats: the set no longer depends on the order.

Poles at one order do not depend on ``pol_order_high`` (sdypy builds order j from the first j+1
rows of the same Toeplitz matrices), so one run at the highest order needed serves every P.
"""

from __future__ import annotations

import contextlib
import io
import warnings
from dataclasses import dataclass

import numpy as np
from scipy import signal
from threadpoolctl import threadpool_limits

ORDERS = (20, 40, 80, 120, 160)
RUNS = (40, 80, 160)  # the lengths of sdypy runs made (a run costs about the cube of its order)
FREQ_TOL, DAMPING_TOL = 0.001, 0.05  # sdypy-EMA's defaults (select_closest_poles, stability chart)
MAX_DAMPING = 0.10
PEAK_DB = 3.0
MIN_COHERENCE = 0.9
MAJORITY = 0.5


@dataclass(frozen=True)
class ReferenceModes:
    """The reference's modes at its converged order and how it got there."""

    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    peak_hz: np.ndarray
    order: int  # sdypy-EMA pol_order_high taken
    converged: bool  # the next order repeated the set
    at_next: dict  # {peak_hz: (frequency_hz, damping_ratio)} at the next order, for its own spread


def _stability(f, h, band, order, kind):
    with (
        warnings.catch_warnings(),
        threadpool_limits(1, "blas"),  # small matrices: BLAS threads only contend
        contextlib.redirect_stderr(io.StringIO()),  # _stabilization draws a tqdm bar
    ):
        warnings.simplefilter("ignore")
        from sdypy import EMA
        from sdypy.EMA import stabilization

        model = EMA.Model(
            frf=h[None], freq=f, lower=band[0], upper=band[1], pol_order_high=order, frf_form=kind
        )
        model.get_poles(method="lscf", show_progress=False)
        fn, xi, test_fn, test_xi = stabilization._stabilization(
            model.all_poles, order, err_fn=FREQ_TOL, err_xi=DAMPING_TOL
        )
    return fn, xi, (test_fn > 0) & (test_xi > 0) & (xi > 0)


def lscf_poles(f, h, band, order, kind="accelerance") -> list[tuple[np.ndarray, np.ndarray]]:
    """sdypy-EMA's LSCF poles of one FRF, ``[(fn_hz, zeta), ...]`` for polynomial orders 2, 4, ...,
    2 * ``order`` (sdypy's ``all_poles`` in its own order), each the poles with a positive
    imaginary part: ``fn = |s| / 2 pi``, ``zeta = -Re(s) / |s|``."""
    with warnings.catch_warnings(), threadpool_limits(1, "blas"):
        warnings.simplefilter("ignore")
        from sdypy import EMA

        model = EMA.Model(
            frf=np.asarray(h, complex)[None],
            freq=np.asarray(f, float),
            lower=band[0],
            upper=band[1],
            pol_order_high=order,
            frf_form=kind,
        )
        model.get_poles(method="lscf", show_progress=False)
    out = []
    for poles in model.all_poles:
        s = np.asarray(poles, complex)
        s = s[s.imag > 0]
        out.append((np.abs(s) / (2 * np.pi), -s.real / np.abs(s)))
    return out


def _modes_at(f, h, coh, band, fn, xi, stable, order) -> dict:
    df = float(f[1] - f[0])
    lo, hi = band
    db = 20 * np.log10(np.abs(h))
    inside = np.flatnonzero((f >= lo) & (f <= hi))
    idx, props = signal.find_peaks(db[inside], prominence=PEAK_DB)
    peaks, prom = inside[idx], props["prominences"]
    # order index k (polynomial order 2k) is column k - 2 of sdypy's matrices (their first column
    # holds all_poles[1], the last all_poles[0]): the converged orders P/2+1..P
    cols = range(order // 2 - 1, order - 1)
    ok = stable & (fn >= lo) & (fn <= hi) & (xi > 0) & (xi <= MAX_DAMPING)
    used = np.zeros_like(ok)
    out = {}
    for p in peaks[np.argsort(prom)[::-1]]:
        fp = f[p]
        rows = []
        for j in cols:
            c = np.flatnonzero(
                ok[:, j] & ~used[:, j] & (np.abs(fn[:, j] - fp) <= np.maximum(xi[:, j] * fn[:, j], df))
            )
            if c.size:
                rows.append((c[np.argmin(np.abs(fn[c, j] - fp))], j))
        if len(rows) < MAJORITY * len(cols):
            continue
        fm = float(np.median([fn[i, j] for i, j in rows]))
        zm = float(np.median([xi[i, j] for i, j in rows]))
        near = (f >= fm * (1 - zm) - df) & (f <= fm * (1 + zm) + df)
        if np.min(coh[near]) < MIN_COHERENCE:
            continue
        for i, j in rows:
            used[i, j] = True
        out[float(fp)] = (fm, zm)
    return out


def reference_modes(f, h, coh, band, *, kind="accelerance") -> ReferenceModes:
    """sdypy-EMA's modes of one FRF ``h`` (with its ``coh``) in ``band`` by the procedure above."""
    f, h, coh = np.asarray(f, float), np.asarray(h, complex), np.asarray(coh, float)
    run_to, found = 0, []
    for i, order in enumerate(ORDERS):
        if run_to < order:
            run_to = next(r for r in RUNS if r >= order)
            poles = _stability(f, h, band, run_to, kind)
        found.append(_modes_at(f, h, coh, band, *poles, order))
        if i > 0 and set(found[-1]) == set(found[-2]):
            return _result(found[-2], ORDERS[i - 1], True, found[-1])
    return _result(found[-1], ORDERS[-1], False, {})


def _result(modes, order, converged, at_next) -> ReferenceModes:
    peaks = sorted(modes, key=lambda p: modes[p][0])
    return ReferenceModes(
        np.array([modes[p][0] for p in peaks]),
        np.array([modes[p][1] for p in peaks]),
        np.array(peaks),
        order,
        converged,
        at_next,
    )
