"""The command-line options of the one FRF estimate (:class:`rigtools.recording_analysis.frf_estimate.FRFOptions`), shared by
``rig analyze`` and ``rig export uff`` so both read a recording's FRF the same way.

Each option is checked here with one :class:`~rigtools.errors.UserError` line naming it (exit 2).
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from rigtools.errors import UserError
from rigtools.options import band_option, count, quantity

if TYPE_CHECKING:
    from rigtools.recording_analysis.frf_estimate import FRFOptions

EXCITATIONS = ("burst", "impact", "periodic", "random")


def add_frf_arguments(p: argparse.ArgumentParser, *, analysis: bool) -> None:
    """Add ``--excitation`` and ``--frame-samples`` to a command's parser; with ``analysis`` also
    ``--band`` (the modal identification band) and the impact windows ``--force-window`` and
    ``--exponential``.

    Parameters
    ----------
    p
        The sub-command's parser.
    analysis
        True for ``rig analyze`` (identification band and impact windows), False for a command
        that only writes the FRF.
    """
    p.add_argument(
        "--excitation",
        choices=EXCITATIONS,
        help="override the FRF estimate chosen from the recording"
        + (" (see below)" if analysis else " (as rig analyze)"),
    )
    p.add_argument("--frame-samples", metavar="N", help="frame length in samples with --excitation")
    if not analysis:
        return
    p.add_argument(
        "--band",
        metavar="LOW:HIGH",
        help='modal identification band, e.g. "100 Hz:4 kHz" (default: the procedure\'s band, else '
        "where the force spectrum has energy; without a force, up to 80 %% of the Nyquist frequency)",
    )
    p.add_argument(
        "--force-window", metavar="FRACTION", help="impact: force window, a fraction (0, 1] of the frame"
    )
    p.add_argument(
        "--exponential", metavar="END", help="impact: exponential window's value (0, 1] at the frame's end"
    )


def _fraction(text: str | None, option: str) -> float | None:
    if text is None:
        return None
    value = quantity(text, "ratio", option)
    if not 0 < value <= 1:
        raise UserError(f"{option} = {text!r}: must be in (0, 1]")
    return value


def frf_options(args: argparse.Namespace) -> FRFOptions:
    """The :class:`rigtools.recording_analysis.frf_estimate.FRFOptions` of parsed arguments (options a parser lacks are
    None).

    Parameters
    ----------
    args
        Arguments of a parser given :func:`add_frf_arguments`.

    Returns
    -------
    FRFOptions
        Band in Hz, excitation, frame length (at least
        :data:`rigtools.analysis.frf.MIN_FRAME_SAMPLES` samples, checked by ``FRFOptions``) and
        the impact windows.

    Raises
    ------
    UserError
        One line naming the option: a bad band, frame length or window value.
    """
    from rigtools.recording_analysis.frf_estimate import FRFOptions

    band = getattr(args, "band", None)
    frame = args.frame_samples
    return FRFOptions(
        band=band_option(band, "--band") if band else None,
        excitation=args.excitation,
        frame_samples=count(frame, "--frame-samples", minimum=1) if frame is not None else None,
        force_window=_fraction(getattr(args, "force_window", None), "--force-window"),
        exponential=_fraction(getattr(args, "exponential", None), "--exponential"),
    )
