"""The spectrum of a recorded point (:func:`rigtools.spectrum`, :class:`rigtools.Spectrum`): one
channel's amplitude spectrum over the point's settled record window.

Takes a point of :func:`rigtools.open_recording`, refuses a bad argument with one
:class:`rigtools.errors.UserError` line naming it; the spectrum itself is
:func:`rigtools.analysis.spectra.amplitude_spectrum`'s.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from rigtools.analysis.spectra import amplitude_spectrum
from rigtools.errors import UserError

if TYPE_CHECKING:
    import pandas as pd

    from rigtools.recording.reader import Point


@dataclass(frozen=True)
class Spectrum:
    """Amplitude spectrum of one channel over a point's settled record window.

    Attributes
    ----------
    channel
        The channel's vocabulary name (``"active_shroud_accel"``).
    units
        SI unit of the channel (``"m/s^2"``); the amplitudes are in it.
    frequency_hz
        Bin frequencies, Hz.
    amplitude
        Amplitude per bin (peak, or rms with ``amplitude="rms"``), in ``units``.
    amplitude_kind
        ``"peak"`` or ``"rms"``.
    window
        The window used (``"flattop"``: amplitude-accurate between bins).

    Examples
    --------
    >>> import numpy as np
    >>> from rigtools.point_spectrum import Spectrum
    >>> s = Spectrum("force", "N", np.array([0.0, 60.0, 120.0]), np.array([0.0, 15.0, 0.1]))
    >>> s.at(60.0), s.to_dataframe().shape
    (15.0, (3, 2))
    """

    channel: str
    units: str
    frequency_hz: np.ndarray = field(repr=False)
    amplitude: np.ndarray = field(repr=False)
    amplitude_kind: str = "peak"
    window: str = "flattop"

    def at(self, frequency_hz: float) -> float:
        """Largest amplitude within two bins of ``frequency_hz`` (a flat-top peak spans bins).

        A frequency outside the spectrum (NaN, negative, above its last bin: the Nyquist
        frequency) is a :class:`rigtools.errors.UserError` naming it.
        """
        top = float(self.frequency_hz[-1]) if len(self.frequency_hz) else 0.0
        if not (isinstance(frequency_hz, int | float) and 0.0 <= frequency_hz <= top):
            raise UserError(
                f"frequency_hz = {frequency_hz!r}: not in this spectrum (0 to {top:g} Hz, its last bin)"
            )
        i = int(np.argmin(np.abs(self.frequency_hz - frequency_hz)))
        return float(np.max(self.amplitude[max(0, i - 2) : i + 3]))

    def to_dataframe(self) -> pd.DataFrame:
        """Columns ``frequency_hz`` and ``amplitude`` (in :attr:`units`)."""
        import pandas as pd

        return pd.DataFrame({"frequency_hz": self.frequency_hz, "amplitude": self.amplitude})


def spectrum(point: Point, channel: str, *, window: str = "flattop", amplitude: str = "peak") -> Spectrum:
    """Amplitude spectrum of ``channel`` over the point's settled record window.

    Parameters
    ----------
    point
        A recorded point (``rigtools.open_recording(path).points[i]``).
    channel
        Channel name, e.g. ``"force"`` or ``"active_shroud_accel"``.
    window
        ``"flattop"``, ``"hann"`` or ``"boxcar"`` (:func:`rigtools.analysis.spectra.amplitude_spectrum`).
    amplitude
        ``"peak"`` or ``"rms"``.

    Returns
    -------
    Spectrum

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "dwell.h5"
    >>> run = rigtools.dwell("60 Hz", "5 N", out, gap="5 mm", record_periods=6, backend="sim", seed=1)
    >>> with rigtools.open_recording(run.file) as rec:
    ...     s = rigtools.spectrum(rec.points[0], "force")
    >>> s.units, round(s.at(60.0), 1)  # the force fundamental, N peak
    ('N', 5.0)
    """
    if not hasattr(point, "channels") or not hasattr(point, "settled"):
        raise UserError(f"point = {point!r}: give a recorded point (rigtools.open_recording(path).points[i])")
    if channel not in point.channels:
        raise UserError(
            f"channel = {channel!r}: not in point {point.index} (channels: {', '.join(point.channels)})"
        )
    rate = point.sample_rate
    if rate is None:
        raise UserError(f"point {point.index}: channels at different sample rates")
    try:
        f, a = amplitude_spectrum(point.settled(channel), rate, window=window, amplitude=amplitude)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    return Spectrum(channel, point.channels[channel].units, f, a, amplitude, window)
