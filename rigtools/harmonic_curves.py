"""Linear amplitude-frequency curves of both blades (no contact), FEM and AM side by side (the
paper's Figure 7): computed from a rig file, written as CSV or JSON, drawn as a figure.

:func:`linear_curves` checks its inputs (one line naming the parameter) and returns the FEM and
AM :class:`rigtools.sim.harmonic.HarmonicResponse`; :func:`write_curves` writes them;
:func:`curves_figure` draws them.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rigtools.errors import UserError

if TYPE_CHECKING:
    from rigtools.sim.harmonic import HarmonicResponse

MIN_POINTS, MAX_POINTS = 2, 200_000


def linear_curves(
    params: Any, force: str | float, fmin: str | float, fmax: str | float, points: int
) -> tuple[HarmonicResponse, HarmonicResponse]:
    """FEM and AM harmonic responses of the rig at ``points`` evenly spaced frequencies.

    Parameters
    ----------
    params
        :class:`rigtools.sim.params.RigParams` of the rig.
    force
        Force amplitude F0 (``"15 N"`` or N), > 0.
    fmin, fmax
        Frequency range (``"10 Hz"`` or Hz), ``0 <= fmin < fmax``.
    points
        Number of frequencies, :data:`MIN_POINTS` to :data:`MAX_POINTS`.

    Returns
    -------
    tuple
        ``(fem, am)`` :class:`rigtools.sim.harmonic.HarmonicResponse`.
    """
    from rigtools.options import quantity

    f0 = quantity(force, "force", "--force")
    lo = quantity(fmin, "frequency", "--fmin")
    hi = quantity(fmax, "frequency", "--fmax")
    if f0 <= 0:
        raise UserError(f"--force = {force!r}: must be > 0")
    if not 0 <= lo < hi:
        raise UserError(f"--fmin = {fmin!r}, --fmax = {fmax!r}: need 0 <= fmin < fmax")
    if not MIN_POINTS <= points <= MAX_POINTS:
        raise UserError(f"--points = {points}: must be between {MIN_POINTS} and {MAX_POINTS}")
    if params.force_sensor.position >= params.passive.length:
        raise UserError(
            f"force_sensor.position = {params.force_sensor.position} m is beyond the passive blade "
            f"(length {params.passive.length} m), which is driven at the same position"
        )
    from rigtools.sim.harmonic import harmonic_curves
    from rigtools.sim.rig_model import build_rig_model

    return harmonic_curves(build_rig_model(params), np.linspace(lo, hi, points), f0)


def _columns(fem: HarmonicResponse, am: HarmonicResponse) -> dict[str, np.ndarray]:
    from rigtools.sim.harmonic import LOCATIONS

    cols = {"frequency_hz": fem.frequencies_hz}
    for res in (fem, am):
        for loc in LOCATIONS:
            cols[f"{res.model}_{loc}_displacement_m"] = res.displacement_amplitude(loc)
            cols[f"{res.model}_{loc}_acceleration_m_s2"] = res.acceleration_amplitude(loc)
    return cols


def implausible_note(fem: HarmonicResponse, am: HarmonicResponse) -> str | None:
    """A one-line warning when a linear curve moves a shroud farther than any blade of the rig
    can (:data:`rigtools.units.MAX_GAP`): e.g. a damping ratio of 1e-9 makes the resonance peak
    kilometres high. ``None`` when every amplitude is plausible."""
    from rigtools.sim.harmonic import LOCATIONS
    from rigtools.units import MAX_GAP

    worst = max(
        (
            (float(np.max(res.displacement_amplitude(loc))), res.model, loc)
            for res in (fem, am)
            for loc in LOCATIONS
        ),
        key=lambda t: t[0],
    )
    if not worst[0] > MAX_GAP:
        return None
    return (
        f"warning: the {worst[1].upper()} {worst[2]} amplitude reaches {worst[0]:.3g} m, more than any blade "
        f"of the rig can move ({MAX_GAP * 1e3:g} mm): not physical there (check [damping] and --force)"
    )


def write_curves(path: Path, fem: HarmonicResponse, am: HarmonicResponse, rig_name: str) -> None:
    """Write the curves as CSV (one column per curve) or JSON (nested by model and location)."""
    from rigtools.derived_files import atomic_write
    from rigtools.json_values import dumps
    from rigtools.sim.harmonic import LOCATIONS

    if path.suffix.lower() == ".csv":
        cols = _columns(fem, am)
        atomic_write(
            path,
            lambda tmp: np.savetxt(
                tmp,
                np.column_stack(list(cols.values())),
                delimiter=",",
                header=",".join(cols),
                comments="",
                fmt="%.9g",
            ),
        )
        return
    doc = {
        "rig": rig_name,
        "force_amplitude_n": fem.force_amplitude,
        "frequency_hz": fem.frequencies_hz.tolist(),
    }
    for res in (fem, am):
        doc[res.model] = {
            loc: {
                "displacement_m": res.displacement_amplitude(loc).tolist(),
                "acceleration_m_s2": res.acceleration_amplitude(loc).tolist(),
            }
            for loc in LOCATIONS
        }
    text = dumps(doc)
    atomic_write(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def curves_figure(fem: HarmonicResponse, am: HarmonicResponse, title: str):
    """The FEM and AM curves as :func:`rigtools.analysis.plots.amplitude_frequency_figure`."""
    from rigtools.analysis.plots import amplitude_frequency_figure
    from rigtools.sim.harmonic import LOCATIONS

    curves = {
        label: {
            "displacement": {loc: res.displacement_amplitude(loc) for loc in LOCATIONS},
            "acceleration": {loc: res.acceleration_amplitude(loc) for loc in LOCATIONS},
        }
        for label, res in (("FEM", fem), ("AM", am))
    }
    return amplitude_frequency_figure(
        fem.frequencies_hz, curves, force_amplitude=fem.force_amplitude, title=title
    )
