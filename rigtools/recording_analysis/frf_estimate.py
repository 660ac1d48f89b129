"""The one FRF estimate of a broadband point (:func:`frf_method_of`, :func:`point_frf`,
:func:`point_frf_estimate`) with the user's overrides (:class:`FRFOptions`): ``rig analyze``,
``rig report``, ``rig export uff``, ``rig compare``, ``rig update``, the procedures' checks and
the front door all report these numbers."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from rigtools.analysis.frf import (
    METHOD_EXCITATIONS,
    MIN_FRAME_SAMPLES,
    FRFMethod,
    impact_method,
    method_from_content,
    random_frame_samples,
)
from rigtools.errors import UserError
from rigtools.recording_analysis.results import frf_kind_of_units
from rigtools.recording_analysis.samples import (
    WINDOW_SAMPLES,
    force_channel,
    record_window,
    response_channels,
    sample_blocks,
)

EXCITATIONS = METHOD_EXCITATIONS  # the estimates --excitation may ask for
#: the estimate of a recorded broadband test (``frame_samples`` and ``signal``) by its drive
#: signal; any other signal with recorded frames (a tap test's ``tap``) is taken frame by frame
#: as a burst
SIGNAL_EXCITATION = {"chirp": "periodic", "periodic": "periodic", "burst": "burst", "random": "random"}


def frf_method_of(
    point,
    force: str,
    start: int,
    n: int,
    *,
    excitation: str | None = None,
    frame_samples: int | None = None,
    force_window: float | None = None,
    exponential: float | None = None,
):
    """The FRF estimate of a broadband point (:class:`rigtools.analysis.frf.FRFMethod`): the one
    choice ``rig analyze``, ``rig report``, ``rig export uff``, ``rig compare``, ``rig update``,
    the procedures' checks and the front door share.

    - ``rig acquire frf`` points (``frame_samples`` and ``signal``): burst random, one frame per
      burst period, or periodic chirp over whole periods (:data:`SIGNAL_EXCITATION`);
      rectangular window.
    - other records (a tap record, a recording imported from elsewhere): from the force's content,
      hits of a hammer (one frame per hit) or continuous random (Hann, 50 % overlap), see
      :func:`rigtools.analysis.frf.method_from_content`.
    - ``excitation`` (and ``frame_samples``) override the choice; ``force_window`` and
      ``exponential`` apply to impacts.

    An override that would not change the estimate is refused in one line, never ignored:
    ``frame_samples`` without ``excitation`` on a recorded test or with an impact estimate (its
    frames follow the hits), windows with an estimate other than impact.
    """
    if excitation is not None and excitation not in EXCITATIONS:
        raise UserError(f"--excitation {excitation!r}: use one of {', '.join(EXCITATIONS)}")
    windows = [
        o for o, v in (("--force-window", force_window), ("--exponential", exponential)) if v is not None
    ]
    if windows and excitation not in (None, "impact"):
        raise UserError(f"{' and '.join(windows)} apply to impact tests, not to --excitation {excitation}")
    rate = float(point.sample_rate)
    recorded = "frame_samples" in point.params
    if excitation is None and recorded:
        signal = str(point.params.get("signal", "")).lower()
        kind = SIGNAL_EXCITATION.get(signal, "burst")
        given = (["--frame-samples"] if frame_samples is not None else []) + windows
        if given:
            raise UserError(
                f"point {point.index}: {' and '.join(given)} would be ignored: its FRF is the recorded "
                f"{signal or 'burst'} test's ({kind}, {point.params['frame_samples']}-sample frames); "
                "give --excitation to estimate it otherwise"
            )
        return FRFMethod(
            kind, int(point.params["frame_samples"]), reason=f"recorded {signal or 'burst'} test"
        )
    if excitation in ("burst", "periodic"):
        seg = frame_samples or (int(point.params["frame_samples"]) if recorded else None)
        if seg is None:
            raise UserError(f"--excitation {excitation} needs the frame length (--frame-samples)")
        return FRFMethod(excitation, int(seg), reason="asked for")
    if n > WINDOW_SAMPLES:
        raise UserError(
            f"point {point.index}: {n} samples without a recorded frame length; records up to "
            f"{WINDOW_SAMPLES} samples are read whole to find the excitation (give --excitation "
            "and --frame-samples)"
        )
    x = np.asarray(point.channels[force][start : start + n], dtype=float)
    try:
        if excitation == "random":
            return FRFMethod("random", int(frame_samples or random_frame_samples(n)), reason="asked for")
        if excitation == "impact" or windows:
            method = impact_method(
                x, rate, force_window=force_window, exponential=exponential, reason="asked for"
            )
        else:
            method = method_from_content(x, rate, frame_samples=frame_samples)
    except ValueError as exc:
        raise UserError(f"point {point.index}: {exc}") from None
    if method.excitation == "impact" and frame_samples is not None:
        raise UserError(
            f"--frame-samples {frame_samples}: point {point.index} is an impact test, one frame per "
            f"hit as long as the hits' spacing ({method.frame_samples} samples); leave it out"
        )
    return method


def frf_blocks(point, names: Sequence[str], start: int, n: int, method) -> Iterator[dict]:
    """``{channel: samples}`` blocks of a point for :func:`rigtools.analysis.point.analyze_frf_test`:
    one block per frame for an impact method, else the record window in blocks."""
    if method.excitation == "impact":
        for s in method.frame_starts:
            a = start + int(s)
            yield {c: np.asarray(point.channels[c][a : a + method.frame_samples], dtype=float) for c in names}
        return
    for b in sample_blocks(point, names, start, n):
        yield dict(zip(names, b, strict=True))


@dataclass(frozen=True)
class FRFOptions:
    """How ``rig analyze`` (and every reader of the same FRF) treats a broadband point.

    Attributes
    ----------
    band
        ``(f_min, f_max)`` Hz for the modal identification; None: the procedure's band, else where
        the force has energy (:func:`rigtools.analysis.modal_id.excitation_band`).
    excitation, frame_samples, force_window, exponential
        Overrides of the FRF estimate (:func:`frf_method_of`); ``frame_samples`` at least
        :data:`rigtools.analysis.frf.MIN_FRAME_SAMPLES` (a shorter frame is one
        :class:`UserError` line naming the minimum).
    """

    band: tuple[float, float] | None = None
    excitation: str | None = None
    frame_samples: int | None = None
    force_window: float | None = None
    exponential: float | None = None

    def __post_init__(self) -> None:
        n = self.frame_samples
        if n is not None and n < MIN_FRAME_SAMPLES:
            raise UserError(
                f"--frame-samples = {n}: an FRF frame needs at least {MIN_FRAME_SAMPLES} samples "
                "(N samples give N/2 + 1 lines from 0 Hz to half the sample rate)"
            )

    def estimate_options(self) -> list[str]:
        """The command-line names of the estimate overrides given (``--excitation``, ...)."""
        return [
            option
            for option, value in (
                ("--excitation", self.excitation),
                ("--frame-samples", self.frame_samples),
                ("--force-window", self.force_window),
                ("--exponential", self.exponential),
            )
            if value is not None
        ]

    def refuse_unused(self, what: str, *, band: bool = True) -> None:
        """One :class:`UserError` line when options were given for FRFs that ``what`` (the
        reason, e.g. "run.h5 holds no broadband point") does not estimate: never ignored."""
        given = self.estimate_options() + (["--band"] if band and self.band is not None else [])
        if given:
            raise UserError(
                f"{' and '.join(given)}: {what}, so {'it' if len(given) == 1 else 'they'} would be ignored"
            )


def point_frf(point, *, responses: Sequence[str] | None = None, options: FRFOptions | None = None):
    """The FRF of a broadband point as every command reports it: ``(force, responses, measured
    kind, FRFMethod, (start, n), blocks)``; ``blocks`` feeds
    :func:`rigtools.analysis.point.analyze_frf_test` or the method's accumulator."""
    options = options or FRFOptions()
    force = force_channel(point)
    if force is None:
        raise UserError(
            f"point {point.index}: no force channel (channels: {', '.join(point.channels)}); "
            "an FRF needs the force (name one with --reference)"
        )
    resp = list(responses or response_channels(point, force))
    if not resp:
        raise UserError(
            f"point {point.index}: no response channel (acceleration, velocity or "
            f"displacement) beside {force}"
        )
    not_motion = [c for c in resp if frf_kind_of_units(point.channels[c].units) is None]
    if not_motion:
        raise UserError(
            f"point {point.index}: {', '.join(not_motion)} is not an acceleration, velocity or "
            f"displacement ({', '.join(point.channels[c].units for c in not_motion)}): no FRF response"
        )
    measured = {k for c in resp if (k := frf_kind_of_units(point.channels[c].units)) is not None}
    if len(measured) != 1:
        raise UserError(
            f"point {point.index}: responses {', '.join(resp)} measure different quantities; "
            "analyse them one at a time (--channels)"
        )
    start, n = record_window(point)
    method = frf_method_of(
        point,
        force,
        start,
        n,
        excitation=options.excitation,
        frame_samples=options.frame_samples,
        force_window=options.force_window,
        exponential=options.exponential,
    )
    if method.excitation != "impact" and n < method.frame_samples:
        raise UserError(
            f"point {point.index}: {n} samples recorded, fewer than one frame ({method.frame_samples})"
        )
    names = [force, *resp]
    return force, resp, measured.pop(), method, (start, n), frf_blocks(point, names, start, n, method)


def point_frf_estimate(point, *, responses: Sequence[str] | None = None, options: FRFOptions | None = None):
    """``(FRFEstimate in the responses' own kind, responses, force, FRFMethod, measured kind)`` of
    a broadband point: the same numbers ``rig analyze`` reports (``rig export uff`` and the
    procedures' checks use these)."""
    force, resp, measured, method, _, blocks = point_frf(point, responses=responses, options=options)
    try:
        est = method.estimate((np.vstack([b[c] for c in [force, *resp]]) for b in blocks), point.sample_rate)
    except ValueError as exc:
        raise UserError(f"point {point.index}: {exc}") from None
    return est, resp, force, method, measured
