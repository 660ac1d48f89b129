"""The field's reference chain for modes of a response-only record: pyOMA2 (``pip install
pyOMA-2``, the ``oma`` extra), nothing from rigtools. The tests and ``benchmarks/bench_oma.py``
hold the toolkit's operational modes against it.

Procedure (every setting with its reason):

1. The record decimated by ``q`` with ``scipy.signal.decimate`` (order-8 Chebyshev, zero phase):
   the band of interest well below the new Nyquist frequency, as pyOMA2's examples do.
2. pyOMA2 ``SSI(method="cov")`` (covariance-driven SSI, its defaults otherwise: hard criteria
   damping < 20 %, MPC > 0.5, MPD < 0.5) at block rows ``br`` for each of ``block_rows`` (the
   free setting of SSI-cov; its usual range 20-40 for a few tens of modes) up to model order
   ``ordmax``.
3. pyOMA2's automated clustering of the poles, ``Clustering(quick="Dederichs", freqlim=band)``
   (its stated automatic method: hard criteria, GMM pre-clustering of the poles into physical
   and noise, hierarchical clustering, post-processing), for the modes.
4. A mode of the reference in a window ``(lo, hi)``: its clusters there over all ``br``; its
   *spread* is the range of the frequencies of the poles those clusters hold (the chain's own
   scatter over model orders and block rows).
"""

from __future__ import annotations

import logging
import os
import warnings
from dataclasses import dataclass

import numpy as np
from scipy import signal

BLOCK_ROWS = (20, 30, 40)
ORDMAX = 40


@dataclass(frozen=True)
class ReferenceMode:
    """The reference chain's estimates of one mode (one per block-row setting that found it)."""

    frequency_hz: np.ndarray  # the clusters' frequencies
    damping_ratio: np.ndarray
    spread_hz: tuple[float, float]  # lowest and highest pole frequency the clusters hold

    def holds(self, frequency_hz: float) -> bool:
        return self.spread_hz[0] <= frequency_hz <= self.spread_hz[1]


def reference_clusters(
    y: np.ndarray,
    fs: float,
    *,
    q: int,
    band: tuple[float, float],
    block_rows: tuple[int, ...] = BLOCK_ROWS,
    ordmax: int = ORDMAX,
) -> list[tuple[np.ndarray, np.ndarray, list[np.ndarray]]]:
    """Per block-row setting: ``(Fn, Xi, member pole frequencies of each cluster)``."""
    os.environ.setdefault("TQDM_DISABLE", "1")
    from pyoma2.algorithms import SSI
    from pyoma2.algorithms.data.run_params import Clustering
    from pyoma2.setup import SingleSetup

    yd = signal.decimate(np.asarray(y, dtype=float), q, axis=1, zero_phase=True) if q > 1 else y
    out = []
    logging.disable(logging.WARNING)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for br in block_rows:
                setup = SingleSetup(yd.T, fs=fs / q)
                alg = SSI(name="ssicov", method="cov", br=br, ordmax=ordmax)
                setup.add_algorithms(alg)
                setup.run_by_name("ssicov")
                alg.add_clustering(Clustering(name="auto", quick="Dederichs", freqlim=band))
                alg.run_clustering("auto")
                res = alg.result.clustering_results["auto"]
                members = []
                for fn in res.Fn:
                    labels = [lab for lab in np.unique(res.labels) if lab >= 0]
                    near = min(labels, key=lambda lab: abs(np.median(res.Fn_fl[res.labels == lab]) - fn))
                    members.append(np.asarray(res.Fn_fl[res.labels == near], dtype=float))
                out.append((np.asarray(res.Fn, float), np.asarray(res.Xi, float), members))
    finally:
        logging.disable(logging.NOTSET)
    return out


def reference_mode(runs, window: tuple[float, float]) -> ReferenceMode | None:
    """The reference's mode in ``window`` over the runs of :func:`reference_clusters` (None
    when no run has a cluster there)."""
    lo, hi = window
    fn, xi, poles = [], [], []
    for f, z, members in runs:
        for k in np.flatnonzero((f >= lo) & (f <= hi)):
            fn.append(f[k])
            xi.append(z[k])
            poles.append(members[k])
    if not fn:
        return None
    allp = np.concatenate(poles)
    return ReferenceMode(np.array(fn), np.array(xi), (float(allp.min()), float(allp.max())))
