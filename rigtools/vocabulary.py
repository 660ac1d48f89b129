"""One vocabulary for EM (rig) and FEM (model) recordings: channel and point-parameter names,
their SI units and what they mean, defined once.

A comparison pairs points and channels by these names, so a name means the same thing whoever
wrote the file: ``force`` is the force into the active blade at the force sensor (measured by
the sensor on the rig, applied to the model in a simulation), ``force_amplitude_measured`` is
the fundamental (harmonic 1, peak) of that channel in both.

Light on purpose (standard library only): command modules may import it at the top. The names
themselves are :mod:`rigtools.sim.channel_names` (where sim and analysis may import them).

Schema v1 files written before this vocabulary name one parameter differently; readers map it
with :func:`current_parameters` (see :data:`V1_PARAMETER_RENAMES`).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from rigtools.sim import channel_names as N

EM = "em"  # written by rig runs (backends "nidaqmx", "simulated")
FEM = "fem"  # written by model runs (backend "fem")
BOTH = (EM, FEM)


@dataclass(frozen=True)
class ChannelTerm:
    """A channel name of the vocabulary.

    Attributes
    ----------
    name
        Dataset name in a point group.
    units
        SI units of the samples (``"N"``, ``"m/s^2"``, ``"m"``, ``"m/s"``, ``"V"``).
    quantity
        ``"force"``, ``"acceleration"``, ``"displacement"``, ``"velocity"`` or ``"voltage"``.
    location
        Where on the rig the signal is taken.
    meaning
        What the samples are, in one sentence.
    sources
        Who writes it: ``("em", "fem")``, ``("em",)`` or ``("fem",)``.
    """

    name: str
    units: str
    quantity: str
    location: str
    meaning: str
    sources: tuple[str, ...] = BOTH


@dataclass(frozen=True)
class ParameterTerm:
    """A point-parameter name of the vocabulary.

    Attributes
    ----------
    name
        Attribute name on a point group.
    units
        SI units of the value; ``""`` for counts, flags and text.
    kind
        ``"float"``, ``"int"``, ``"bool"`` or ``"text"``.
    meaning
        What the value is, in one sentence.
    at
        ``"start"``: known when the point begins; ``"end"``: written when it ends (lost if the
        writer is killed mid-point).
    sources
        Who writes it: ``("em", "fem")``, ``("em",)`` or ``("fem",)``.
    """

    name: str
    units: str
    kind: str
    meaning: str
    at: str = "start"
    sources: tuple[str, ...] = BOTH


def _table(*terms):
    return {t.name: t for t in terms}


ACTIVE_SHROUD = "active blade shroud (tip)"
PASSIVE_SHROUD = "passive blade shroud (tip)"
FORCE_POINT = "active blade, force sensor"

CHANNELS: dict[str, ChannelTerm] = _table(
    ChannelTerm(
        N.FORCE,
        "N",
        "force",
        FORCE_POINT,
        "force into the active blade at the force sensor: measured by the sensor (EM), "
        "applied to the model there (FEM)",
    ),
    ChannelTerm(
        N.ACTIVE_SHROUD_ACCEL,
        "m/s^2",
        "acceleration",
        ACTIVE_SHROUD,
        "acceleration of the active blade's shroud in the impact direction",
    ),
    ChannelTerm(
        N.PASSIVE_SHROUD_ACCEL,
        "m/s^2",
        "acceleration",
        PASSIVE_SHROUD,
        "acceleration of the passive blade's shroud in the impact direction",
    ),
    ChannelTerm(
        N.DRIVE,
        "V",
        "voltage",
        "DAQ analog output to the shaker amplifier",
        "drive samples written to the shaker amplifier's input, on the output's clock",
        (EM,),
    ),
    ChannelTerm(
        N.ACTIVE_SHROUD_DISP,
        "m",
        "displacement",
        ACTIVE_SHROUD,
        "displacement of the active shroud, impact direction",
        (FEM,),
    ),
    ChannelTerm(
        N.PASSIVE_SHROUD_DISP,
        "m",
        "displacement",
        PASSIVE_SHROUD,
        "displacement of the passive shroud, impact direction",
        (FEM,),
    ),
    ChannelTerm(
        N.FORCE_POINT_DISP,
        "m",
        "displacement",
        FORCE_POINT,
        "displacement of the active blade at the force sensor",
        (FEM,),
    ),
    ChannelTerm(
        N.ACTIVE_SHROUD_VEL,
        "m/s",
        "velocity",
        ACTIVE_SHROUD,
        "velocity of the active shroud, impact direction",
        (FEM,),
    ),
    ChannelTerm(
        N.PASSIVE_SHROUD_VEL,
        "m/s",
        "velocity",
        PASSIVE_SHROUD,
        "velocity of the passive shroud, impact direction",
        (FEM,),
    ),
    ChannelTerm(
        N.FORCE_POINT_VEL,
        "m/s",
        "velocity",
        FORCE_POINT,
        "velocity of the active blade at the force sensor",
        (FEM,),
    ),
    ChannelTerm(
        N.FORCE_POINT_ACCEL,
        "m/s^2",
        "acceleration",
        FORCE_POINT,
        "acceleration of the active blade at the force sensor",
        (FEM,),
    ),
    ChannelTerm(
        N.CONTACT_FORCE,
        "N",
        "force",
        "between the shrouds",
        "contact force between the shrouds (>= 0, pushing them apart)",
        (FEM,),
    ),
)

PARAMETERS: dict[str, ParameterTerm] = _table(
    ParameterTerm("fe", "Hz", "float", "excitation frequency"),
    ParameterTerm(
        "force_amplitude",
        "N",
        "float",
        "target force amplitude F0 (peak): the amplitude applied to the model (FEM), "
        "the force-control target on the rig (EM)",
    ),
    ParameterTerm(
        "force_amplitude_measured",
        "N",
        "float",
        "fundamental (harmonic 1, peak) of the force channel over the record",
        at="end",
    ),
    ParameterTerm(
        "gap",
        "m",
        "float",
        "shroud gap (closed when the active shroud has moved this far towards the passive one)",
    ),
    ParameterTerm("settled", "", "bool", "the response was steady (periodic) when recorded", at="end"),
    ParameterTerm(
        "drive_amplitude",
        "V",
        "float",
        "drive amplitude (peak) at the DAQ output to the shaker amplifier",
        sources=(EM,),
    ),
    ParameterTerm(
        "record_start", "s", "float", "start of the record, from the start of the drive", sources=(EM,)
    ),
    ParameterTerm("direction", "", "text", 'sweep direction of a study point: "up" or "down"'),
    ParameterTerm(
        "study_value",
        "",
        "float",
        "the swept value of a study point, in the SI units of the swept parameter "
        "(gap m, force N, frequency Hz)",
    ),
    ParameterTerm(
        "model", "", "text", '"fem" (reduced FE model) or "am" (assumed-modes model)', sources=(FEM,)
    ),
    ParameterTerm("steps_per_period", "", "int", "time steps per excitation period", sources=(FEM,)),
    ParameterTerm("time_step", "s", "float", "integration time step (1 / sample rate)", sources=(FEM,)),
    ParameterTerm(
        "settle_time",
        "s",
        "float",
        "simulated time run before the record to reach the steady state",
        sources=(FEM,),
    ),
    ParameterTerm(
        "period_multiple",
        "",
        "int",
        "the response repeats every this many excitation periods (0: not steady)",
        at="end",
        sources=(FEM,),
    ),
    ParameterTerm(
        "peak_contact_force", "N", "float", "largest contact force over the record", at="end", sources=(FEM,)
    ),
    ParameterTerm(
        "impacts_per_period",
        "",
        "float",
        "contact onsets per excitation period over the record",
        at="end",
        sources=(FEM,),
    ),
)

#: SI units of the point parameters that :data:`PARAMETERS` does not hold: the controlled tests'
#: (``rig acquire pll``: ``rigtools.procedures.pll.point_attrs``; ``rig acquire cbc``:
#: ``rigtools.procedures.cbc.CBCPoint.attrs``) and the tap and FRF tests' (``rig acquire tap``:
#: ``rigtools.procedures.tap.TapTest.begin_hit``/``end_hit``; ``rig acquire frf``:
#: ``rigtools.procedures.frf``). Names ending in their unit (``amplitude_m``, ``fe_hz``,
#: ``force_fundamental_n``, ``phase_deg``) say it; ratios, counts and flags have none.
POINT_PARAMETER_UNITS: dict[str, str] = {
    "amplitude_target": "m",  # the target's fundamental, peak
    "feedforward_amplitude": "V",
    "control_effort": "V",  # RMS of the control term over the measurement
    "tip_amplitude_active": "m",  # half the peak-to-peak of the displacement
    "phase_target": "deg",
    "phase_error_rms": "deg",
    "release_seconds": "s",
    "release_growth_rate": "1/s",
    "position": "m",  # the hit's distance from the blade root
    "trigger_level": "N",  # on the hammer force
    "trigger_time": "s",  # from the start of the acquisition
    "hit_peak_force": "N",
    "band_low": "Hz",
    "band_high": "Hz",
    "drive_level": "V",  # RMS within bursts, or the chirp's peak
}


def parameter_units(name: str) -> str:
    """SI units of point parameter ``name`` where the vocabulary defines them, else ``""``.

    Examples
    --------
    >>> parameter_units("gap"), parameter_units("amplitude_target"), parameter_units("converged")
    ('m', 'm', '')
    """
    term = PARAMETERS.get(name)
    if term is not None:
        return term.units
    return POINT_PARAMETER_UNITS.get(name, "")


# Schema v1 files written before this vocabulary: old name -> current name. The old
# ``measured_force_amplitude`` was the fundamental in EM files but max|F| over the record in FEM
# files; the model's force is a pure sine F0 sin(2 pi fe t) sampled n >= 120 times per period
# from phase 0, so there max|F| = F0 |sin(2 pi i / n)|max, within 1 - cos(pi / n) <= 0.034 %
# of the fundamental: the rename is exact enough for either source.
V1_PARAMETER_RENAMES: dict[str, str] = {"measured_force_amplitude": "force_amplitude_measured"}


# Backends of model recordings: "fem" (one model's runs) and "model" (runs of several models,
# each point naming its model, as the demo writes them).
MODEL_BACKENDS = ("fem", "model")


# what a channel may be called: a recording stores each channel as an HDF5 dataset of that name
_CHANNEL_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.\-]*$")


def channel_name_legal(name: str) -> bool:
    """True if ``name`` is a legal channel name: letters, digits, underscore, dot or hyphen, no leading dot."""
    return isinstance(name, str) and bool(_CHANNEL_NAME.match(name))


def source_of(backend: str) -> str:
    """``"fem"`` for model recordings (backend ``"fem"`` or ``"model"``), ``"em"`` for rig ones
    (``"nidaqmx"``, ``"simulated"``, or an import of measured data)."""
    return FEM if backend in MODEL_BACKENDS else EM


def current_parameters(params: Mapping[str, Any]) -> dict[str, Any]:
    """Point parameters with every old (schema v1, pre-vocabulary) name replaced by its current one.

    A current name already present wins over its old alias. Unknown names pass unchanged.
    """
    out = {V1_PARAMETER_RENAMES.get(k, k): v for k, v in params.items() if k not in V1_PARAMETER_RENAMES}
    for old, new in V1_PARAMETER_RENAMES.items():
        if old in params and new not in out:
            out[new] = params[old]
    return out


def excitation_frequency(params: Mapping[str, Any]) -> float | None:
    """The excitation frequency (Hz) of a periodic point, one rule for every reader: its ``fe``
    when above 0; ``None`` without ``fe`` or with ``fe = 0`` (no single excitation frequency: an
    FRF test), so such a point is never analysed at a frequency.

    Examples
    --------
    >>> excitation_frequency({"fe": 60.0}), excitation_frequency({"fe": 0.0}), excitation_frequency({})
    (60.0, None, None)
    """
    fe = params.get("fe")
    try:
        value = float(fe) if fe is not None else 0.0
    except (TypeError, ValueError):  # rig check refuses a non-number before a reader sees it
        return None
    return value if value > 0 else None


def unknown_parameters(params: Mapping[str, Any]) -> list[str]:
    """The names in ``params`` that the vocabulary does not define (for writers' tests)."""
    return [k for k in params if k not in PARAMETERS]


def channel_names(source: str) -> list[str]:
    """The channel names a source writes (``"em"``: the standard rig inputs plus ``drive``;
    ``"fem"``: every model channel), in vocabulary order."""
    return [name for name, term in CHANNELS.items() if source in term.sources]


def describe_channels(names) -> str:
    """``"name (units), ..."`` for help texts."""
    return ", ".join(f"{n} ({CHANNELS[n].units})" for n in names)
