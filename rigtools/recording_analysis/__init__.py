"""A recording analysed: what ``rig analyze`` and ``rig report`` show of a recording.

:func:`rigtools.recording_analysis.dispatch.analyze_recording` (the front door's
:func:`rigtools.analyze_recording`) reads a recording point by point and dispatches on what each
point is:

- a **periodic point** (a sine dwell, a step of a stepped sine, a point of a study, a model run
  of ``rig simulate``/``rig study``; it has ``fe``): harmonics k = 1..30 of every channel (peak
  amplitude and phase, also relative to the force fundamental), peak levels and impacts
  (:func:`rigtools.analysis.point.analyze_dwell`). No modes: a sine excites one frequency at a time.
- a **broadband point** (an FRF test with burst random or periodic chirp: ``frame_samples`` and
  ``signal``; or any record without ``fe`` holding a force, such as a tap test or free decay):
  H1, H2, Hv and coherence of every response over the force as receptance, mobility or
  accelerance, and the modes the data support (:func:`rigtools.analysis.point.analyze_frf_test`: LSCF with
  a stabilisation check, or peak picking).
- a point **without a force** (an operational log): spectra and operational modes
  (:func:`rigtools.operational.analyze_operational`).

A series of periodic points at different ``fe`` (a stepped sine) also gives the response curves
over frequency: the first-harmonic FRF ``X1 / F1`` of every response and every harmonic's
amplitude against ``fe`` (:meth:`~rigtools.recording_analysis.results.RecordingAnalysis.response_curves`).

Samples are read in blocks (:data:`~rigtools.recording_analysis.samples.BLOCK_SAMPLES`): harmonics
and FRFs accumulate block by block (bounded memory for any record length); impacts and waveform
figures use the last :data:`~rigtools.recording_analysis.samples.WINDOW_SAMPLES` samples of a
periodic record.

Modules (each imports only those before it in this list, and the library below):

- :mod:`~rigtools.recording_analysis.results`: :class:`~rigtools.recording_analysis.results.PointAnalysis`,
  :class:`~rigtools.recording_analysis.results.RecordingAnalysis` (what the analysis returns, its
  tables and JSON), the FRF kinds.
- :mod:`~rigtools.recording_analysis.samples`: what is read of a point: its record window, its
  samples in blocks, its force and response channels, a waveform window for figures.
- :mod:`~rigtools.recording_analysis.periodic`: a periodic point (harmonics, impacts).
- :mod:`~rigtools.recording_analysis.frf_estimate`: the one FRF estimate of a broadband point
  (:func:`~rigtools.recording_analysis.frf_estimate.frf_method_of`,
  :class:`~rigtools.recording_analysis.frf_estimate.FRFOptions`,
  :func:`~rigtools.recording_analysis.frf_estimate.point_frf_estimate`) that ``rig analyze``,
  ``rig report``, ``rig export uff``, ``rig compare``, ``rig update`` and the procedures share.
- :mod:`~rigtools.recording_analysis.broadband`: a broadband point's FRFs and modes.
- :mod:`~rigtools.recording_analysis.tap_test`: a tap test written by ``rig acquire tap`` (one
  point per hit), its hits averaged.
- :mod:`~rigtools.recording_analysis.imported_frfs`: the modes of an FRF set (FRFs estimated
  elsewhere, ``rig import uff``).
- :mod:`~rigtools.recording_analysis.fem_frequencies`: the identified natural frequencies beside
  this rig's FEM and analytical ones (the paper's Table 2).
- :mod:`~rigtools.recording_analysis.dispatch`: :func:`~rigtools.recording_analysis.dispatch.analyze_recording`,
  every point of a recording sent to the analysis of its kind.
"""
