"""Signal processing on arrays: spectra, harmonics, FRF, modal identification, impacts,
EM-vs-FEM comparison, plots.

Modules (no file access, no rigtools/drivers/h5py imports: arrays or iterables of blocks in,
arrays and small dataclasses out):

- :mod:`rigtools.analysis.spectra`: peak or RMS amplitude spectra (flattop/Hann/boxcar), axis labels.
- :mod:`rigtools.analysis.harmonics`: exact least-squares harmonics k*fe (any record length), phases
  relative to the force fundamental, block-by-block accumulation for long records.
- :mod:`rigtools.analysis.frf`: H1, H2, Hv, coherence; receptance/mobility/accelerance; settings for
  random, burst random and periodic chirp; block-by-block spectra (bounded memory).
- :mod:`rigtools.analysis.modal_id`: :func:`~rigtools.analysis.modal_id.identify` (data check, sdypy-EMA LSCF with a
  stabilisation chart and LSFD, or peak picking with half-power damping).
- :mod:`rigtools.analysis.stabilisation`: the LSCF stabilisation chart (frequency, damping and, with
  several responses, shape stability) and the modes it supports over the converged orders.
- :mod:`rigtools.analysis.impacts`: impacts from shroud accelerations (count, levels, contact duration,
  period multiple).
- :mod:`rigtools.analysis.correlation`: natural-frequency and harmonic tables, agreement score, the
  natural-frequency offset that explains a harmonic difference, point pairing.
- :mod:`rigtools.analysis.point`: one call per recorded point (dwell or FRF test) for ``rig analyze``.
- :mod:`rigtools.analysis.plots`: matplotlib figures for the report.
"""
