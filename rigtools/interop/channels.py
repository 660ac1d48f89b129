"""Channels of another tool's file as recording channels: units, names, the excitation, and one
line per channel saying what the import did with it.

Shared by every import (``rig import tdms|lvm|uff``):

* **Units.** A channel's declared units (TDMS ``unit_string``, LVM ``Y_Unit_Label``, UFF axis
  label) are looked up in :data:`UNITS` and the samples converted to SI (``g`` -> m/s^2,
  ``lbf`` -> N, ``mV`` -> V, ``°C`` -> K, ...). ``--units CHANNEL=UNIT`` overrides or supplies
  them; a channel without units takes the units of the toolkit channel of its name (``force``
  -> N, ``active_shroud_accel`` -> m/s^2), said so in its line. A channel whose units are missing
  or unknown is **skipped** with one line naming it (never the whole file).
* **Names** keep letters, digits, ``_ . -`` (``Dev1/ai0`` -> ``Dev1_ai0``, ``Acceleration
  (Trigger)`` -> ``Acceleration_Trigger``); ``--map OLD=NEW`` renames on purpose. Channels keep
  their own names and quantities otherwise.
* **Excitation.** ``--reference NAME`` names it; otherwise it is the one channel of quantity
  force. It is stored as the point parameter ``reference_channel``, which analysis reads.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

from rigtools.errors import UserError
from rigtools.vocabulary import CHANNELS

G = 9.80665
LBF = 4.4482216152605
INCH = 0.0254


@dataclass(frozen=True)
class SIUnits:
    """How a declared unit becomes SI: the SI value is ``factor`` times the declared one plus ``offset``."""

    units: str
    quantity: str
    factor: float = 1.0
    offset: float = 0.0


def _table() -> dict[str, SIUnits]:
    rows: list[tuple[Sequence[str], SIUnits]] = [
        (("n", "newton", "newtons"), SIUnits("N", "force")),
        (("kn",), SIUnits("N", "force", 1e3)),
        (("lbf", "lb", "pounds"), SIUnits("N", "force", LBF)),
        (("m/s^2", "m/s2", "m/s\u00b2", "meterspersecondsquared", "m/s/s"), SIUnits("m/s^2", "acceleration")),
        (("g", "gs", "g's", "g0", "gn"), SIUnits("m/s^2", "acceleration", G)),
        (("mm/s^2", "mm/s2"), SIUnits("m/s^2", "acceleration", 1e-3)),
        (("m/s",), SIUnits("m/s", "velocity")),
        (("mm/s",), SIUnits("m/s", "velocity", 1e-3)),
        (("in/s", "ips"), SIUnits("m/s", "velocity", INCH)),
        (("m", "meters", "metres"), SIUnits("m", "displacement")),
        (("mm",), SIUnits("m", "displacement", 1e-3)),
        (("um", "\u00b5m", "\u03bcm", "micron"), SIUnits("m", "displacement", 1e-6)),
        (("in", "inch"), SIUnits("m", "displacement", INCH)),
        (("v", "volts", "volt"), SIUnits("V", "voltage")),
        (("mv", "millivolts"), SIUnits("V", "voltage", 1e-3)),
        (("a", "amps", "amperes"), SIUnits("A", "current")),
        (("ma",), SIUnits("A", "current", 1e-3)),
        (("k", "kelvin"), SIUnits("K", "temperature")),
        (("\u00b0c", "degc", "deg c", "celsius", "\u2103"), SIUnits("K", "temperature", 1.0, 273.15)),
        (("pa", "pascal", "pascals"), SIUnits("Pa", "pressure")),
        (("kpa",), SIUnits("Pa", "pressure", 1e3)),
        (("mpa",), SIUnits("Pa", "pressure", 1e6)),
        (("bar",), SIUnits("Pa", "pressure", 1e5)),
        (("psi",), SIUnits("Pa", "pressure", 6894.757293168)),
        (("m/m", "strain"), SIUnits("m/m", "strain")),
        (("\u00b5\u03b5", "ue", "microstrain", "\u00b5m/m", "um/m"), SIUnits("m/m", "strain", 1e-6)),
        (("rad",), SIUnits("rad", "angle")),
        (("deg", "\u00b0", "degrees"), SIUnits("rad", "angle", 3.141592653589793 / 180)),
        (("hz",), SIUnits("Hz", "frequency")),
        (("rpm",), SIUnits("Hz", "rotational_speed", 1 / 60)),
        (("s", "sec", "seconds"), SIUnits("s", "time")),
        (("1", "-"), SIUnits("1", "dimensionless")),
    ]
    return {key: si for keys, si in rows for key in keys}


UNITS: dict[str, SIUnits] = _table()
_BAD_NAME_CHARS = re.compile(r"[^A-Za-z0-9_.\-]+")


# declared units whose first letter case tells apart (m milli, M mega; P of pascal, p pico): the
# case the table's entry means; the other case is refused (unknown), never read 10^9 off
_PREFIX_CASE = {
    "mv": "m", "ma": "m", "mm": "m", "mm/s": "m", "mm/s^2": "m", "mm/s2": "m", "mpa": "M", "pa": "P",
}  # fmt: skip


def si_units(text: str) -> SIUnits | None:
    """The SI conversion of a declared unit (case and spaces ignored, except the case of an m/M
    prefix: ``mV`` is millivolt, ``MV`` unknown; ``MPa`` megapascal, ``mPa`` unknown; ``Pa``
    pascal, ``pA`` (picoampere) unknown), None if unknown."""
    plain = str(text).strip()
    key = plain.lower().replace(" ", "")
    if key in _PREFIX_CASE and plain[0] != _PREFIX_CASE[key]:
        return None
    return UNITS.get(key) or UNITS.get(plain.lower())


def storable_name(text: str) -> str:
    """``text`` as a recording channel name: letters, digits, ``_``, ``.`` and ``-`` are kept."""
    name = _BAD_NAME_CHARS.sub("_", str(text).strip()).strip("_") or "channel"
    return name if name[0] != "." else "_" + name[1:]


def parse_pairs(values: Iterable[str] | None, option: str) -> dict[str, str]:
    """``--map``/``--units`` values (each ``OLD=NEW``, or several separated by commas) as a dict."""
    out: dict[str, str] = {}
    for text in values or ():
        for item in (t for t in str(text).split(",") if t.strip()):
            old, sep, new = item.partition("=")
            if not sep or not old.strip() or not new.strip() or "=" in new:
                raise UserError(
                    f"{option} {text!r}: write NAME=VALUE (one per option, or separated by commas)"
                )
            out[old.strip()] = new.strip()
    return out


@dataclass
class ForeignChannel:
    """One channel of a foreign file and what the import does with it.

    Attributes
    ----------
    source
        Where it is in the file (``group/channel`` for TDMS, ``segment 1/Force`` for LVM).
    name
        The recording channel name (after ``--map``); empty when skipped.
    si
        Its SI conversion; None when skipped.
    declared
        The units the file declares (``""`` if none).
    reason
        Why it is skipped, or how its units were found when they are not the file's.
    """

    source: str
    name: str = ""
    si: SIUnits | None = None
    declared: str = ""
    reason: str = ""
    samples: int = 0
    sample_rate: float = 0.0
    point: int | None = None
    excitation: bool = False
    extra: dict = field(default_factory=dict)

    @property
    def kept(self) -> bool:
        return self.si is not None

    def line(self) -> str:
        """One line: what the import did with this channel."""
        if self.si is None:
            return f"skipped {self.source}: {self.reason}"
        si = self.si
        conv = ""
        if self.declared and (si.factor != 1.0 or si.offset != 0.0 or self.declared != si.units):
            conv = f", {self.declared} -> {si.units}"
            if si.factor != 1.0:
                conv += f" (x {si.factor:.10g}"
                conv += f" + {si.offset:g})" if si.offset else ")"
            elif si.offset:
                conv += f" (+ {si.offset:g})"
        how = f" ({self.reason})" if self.reason else ""
        role = ", the excitation" if self.excitation else ""
        where = f" in point {self.point}" if self.point is not None else ""
        return (
            f"kept    {self.source} -> {self.name}: {si.quantity} in {si.units}{conv}{how}{role}, "
            f"{self.samples} samples at {self.sample_rate:g} Hz{where}"
        )

    def to_dict(self) -> dict:
        out = {
            "source": self.source,
            "action": "kept" if self.kept else "skipped",
            "name": self.name or None,
            "declared_units": self.declared,
            "units": self.si.units if self.si else None,
            "quantity": self.si.quantity if self.si else None,
            "factor": self.si.factor if self.si else None,
            "offset": self.si.offset if self.si else None,
            "samples": self.samples,
            "sample_rate": self.sample_rate,
            "point": self.point,
            "excitation": self.excitation,
            "reason": self.reason,
            "text": self.line(),
        }
        return out


def resolve(
    source: str,
    file_name: str,
    declared: str,
    *,
    mapping: dict[str, str],
    units: dict[str, str],
    path: str | None = None,
) -> ForeignChannel:
    """What the import does with one channel.

    Parameters
    ----------
    source
        Its place in the file, for the message.
    file_name
        Its name in the file (what ``--map`` and ``--units`` name; ``path``, e.g. ``group/channel``,
        is accepted too).
    declared
        Its units as the file declares them (``""`` if none).
    mapping, units
        ``--map`` and ``--units``.
    """
    keys = [k for k in (path, file_name) if k]
    name = next((mapping[k] for k in keys if k in mapping), storable_name(file_name))
    ch = ForeignChannel(source=source, name=name, declared=str(declared or "").strip())
    given = next((units[k] for k in keys if k in units), None)
    if given is not None:
        si = si_units(given)
        if si is None:
            raise UserError(f"--units {keys[-1]}={given}: unknown unit; {known_units()}")
        ch.si, ch.declared, ch.reason = si, given, "units from --units"
        return ch
    if ch.declared:
        si = si_units(ch.declared)
        if si is None:
            ch.reason = f"units {ch.declared!r} not known ({known_units()}); give --units {file_name}=UNIT"
            ch.name = ""
        elif (
            (role := named_quantity(name)) is not None
            and role != si.quantity
            and not any(k in mapping for k in keys)
        ):
            ch.reason = (
                f"its name says {role}, its units {ch.declared!r} say {si.quantity}: give --units "
                f"{file_name}=UNIT if the units are wrong, or --map {file_name}=NAME if the name is"
            )
            ch.name, si = "", None
        ch.si = si
        return ch
    if name in CHANNELS and si_units(CHANNELS[name].units) is not None:
        ch.si = si_units(CHANNELS[name].units)
        ch.reason = f"no units in the file; {CHANNELS[name].units} from its name, the toolkit's {name}"
        return ch
    ch.reason = f"no units in the file; give --units {file_name}=UNIT"
    ch.name = ""
    return ch


_ROLE_WORDS = {
    "force": ("force", "kraft", "hammer", "load"),
    "acceleration": ("acc", "accel", "acceleration", "accelerometer"),
    "velocity": ("vel", "velocity"),
    "displacement": ("disp", "displacement"),
}


def named_quantity(name: str) -> str | None:
    """The quantity a channel's name claims, or ``None``: the toolkit's own channel names by their
    definition, other names by a word of theirs (``force``, ``accel``, ...; words split at ``_``,
    spaces and case changes). A name claiming two quantities claims none."""
    if name in CHANNELS:
        return CHANNELS[name].quantity
    words = {w.lower() for w in re.findall(r"[A-Z]?[a-z]+|[A-Z]+(?![a-z])", name)}
    claims = {q for q, terms in _ROLE_WORDS.items() if words & set(terms)}
    return claims.pop() if len(claims) == 1 else None


def known_units() -> str:
    """The SI units the imports store, for messages."""
    return "known: " + ", ".join(sorted({si.units for si in UNITS.values()})) + " and their usual spellings"


def check_names(channels: Sequence[ForeignChannel], where: str) -> None:
    """Refuse two kept channels of one point under one name (a ``--map`` mistake, or two file
    names that read alike); the advice names ``extra["key"]`` of the second (a UFF record's
    ``recordN``) where it has one."""
    seen: dict[str, str] = {}
    for ch in channels:
        if ch.kept and ch.name in seen:
            key = ch.extra.get("key")  # the name --map takes of this channel alone, where the file has one
            advice = f"--map {key}=NEW_NAME" if key else "--map"
            raise UserError(
                f"{where}: {seen[ch.name]} and {ch.source} both become channel {ch.name!r}; "
                f"map one to another name ({advice})"
            )
        seen[ch.name] = ch.source


def check_known(option: str, given: Iterable[str], known: Iterable[str], what: str = "channel") -> None:
    """Refuse ``--map``/``--units``/``--reference`` entries naming no channel of the file (a typo
    would otherwise import the channel unchanged without a word); ``what`` names the kind of
    name (``"group"`` for ``--group``)."""
    known = set(known)
    unknown = sorted(set(given) - known)
    if unknown:
        raise UserError(
            f"{option}: no {what} {', '.join(repr(u) for u in unknown)} in the file "
            f"({what}s: {', '.join(sorted(known)) or 'none'})"
        )


def excitation(channels: Sequence[ForeignChannel], reference: str | None) -> str | None:
    """The excitation among a point's kept channels: ``reference`` (a file or recording name)
    if given and present, else the one channel of quantity force; marks it and returns its
    recording name (None: no single force channel)."""
    kept = [c for c in channels if c.kept]
    if reference is not None:
        hit = [c for c in kept if reference in (c.name, c.extra.get("file_name"), c.source)]
    else:
        hit = [c for c in kept if c.si is not None and c.si.quantity == "force"]
    if len(hit) != 1:
        return None
    hit[0].excitation = True
    return hit[0].name


def excitation_line(
    point: int, name: str | None, channels: Sequence[ForeignChannel], reference: str | None
) -> str:
    """One line about a point's excitation."""
    if name is not None:
        how = "named with --reference" if reference is not None else "its one force channel"
        return f"point {point}: excitation {name} ({how})"
    forces = [c.name for c in channels if c.kept and c.si is not None and c.si.quantity == "force"]
    if reference is not None:
        return f"point {point}: --reference {reference} is not among its channels; no excitation"
    if not forces:
        return f"point {point}: no force channel: a response-only (operational) record"
    return f"point {point}: {len(forces)} force channels ({', '.join(forces)}): name the excitation with --reference"
