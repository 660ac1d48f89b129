"""An EM recording compared with the model from a lab script (:func:`rigtools.compare_with_model`,
as ``rig compare``): harmonics, waveforms and the agreement per point.

Checks the arguments a lab script gives (one :class:`rigtools.errors.UserError` line naming a bad
one); the comparison is :func:`rigtools.recording_comparison.compare_recordings`'s.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from rigtools.errors import UserError
from rigtools.options import duration, switch
from rigtools.recording import reading_damaged
from rigtools.recording_comparison import Comparison, compare_recordings


def compare_with_model(
    em: str | Path,
    model_recording: str | Path | None = None,
    *,
    model: str = "fem",
    excitation: str = "measured",
    rig: str | Path | None = None,
    frf: str | Path | None = None,
    k_max: int = 30,
    workers: int | None = None,
    max_settle_time: float | str = "30 s",
    progress: Callable[[int, int, str], None] | None = None,
    skip_damaged: bool = False,
) -> Comparison:
    """Compare an EM recording with the model: harmonics, waveforms, agreement per point.

    Parameters
    ----------
    em
        The EM recording (a dwell, stepped sine or study on the rig or the simulated rig).
    model_recording
        A model recording to pair with (``rigtools.simulate_study``, ``rig simulate``/``study``);
        ``None``: run the model at every EM point (fe, gap and the force felt there).
    model
        ``"fem"`` or ``"am"``: the model run (with ``model_recording=None``).
    excitation
        ``"measured"`` (the EM force's harmonics drive the model) or ``"nominal"`` (``F0 sin``).
    rig
        Rig file of the model; default: the rig description stored in the EM recording.
    frf
        An FRF test recording whose modes fill the EM column of the natural-frequency table.
    k_max
        Harmonics compared, k = 1..k_max.
    workers
        Model runs on a Dask LocalCluster of this many workers (default: in-process).
    max_settle_time
        Longest simulated settling per model run, ``"30 s"`` or s.
    progress
        ``progress(done, total, text)`` as model runs finish.
    skip_damaged
        Read recordings ``rig check`` rejects, leaving their damaged points and channels out
        (one note each); by default such a file is refused in one line.

    Returns
    -------
    rigtools.recording_comparison.Comparison
        ``points`` (per point: EM and model harmonics, ``score``), ``mean_score``, ``to_dict()``.

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "dwell.h5"
    >>> run = rigtools.dwell("60 Hz", "5 N", out, gap="5 mm", record_periods=6, backend="sim", seed=1)
    >>> cmp = rigtools.compare_with_model(run.file)
    >>> t = cmp.points[0].table  # one row per channel and harmonic k, peak amplitudes in SI
    >>> f1 = t[(t.channel == "force") & (t.k == 1)].iloc[0]
    >>> bool(round(f1.em, 3) == round(f1.fem, 3))  # the model is driven by the measured force
    True
    >>> a1 = t[(t.channel == "active_shroud_accel") & (t.k == 1)].iloc[0]
    >>> bool(0.8 < a1.fem / a1.em < 1.25)  # the active shroud's fundamental agrees within 25 %
    True
    """
    if isinstance(k_max, bool) or not isinstance(k_max, int) or k_max < 1:
        raise UserError(f"k_max = {k_max!r}: the harmonics compared are k = 1..k_max, a whole number >= 1")
    with reading_damaged(switch(skip_damaged, "skip_damaged")):
        return compare_recordings(
            str(em),
            None if model_recording is None else str(model_recording),
            simulate=model_recording is None,
            model=model,
            excitation=excitation,
            rig=None if rig is None else str(rig),
            frf=None if frf is None else str(frf),
            k_max=k_max,
            workers=workers,
            max_settle_time=duration(max_settle_time, "max_settle_time"),
            progress=progress,
        )
