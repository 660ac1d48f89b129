"""The rig file ``rig update`` writes: the original text with the fitted keys replaced or added,
each commented with its origin (:func:`updated_rig_text`, :func:`rig_file_update`), checked to load
(:func:`check_rig_text`)."""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rigtools.config import parse_rig
from rigtools.errors import UserError

_HEADER = re.compile(r"^\s*\[\s*([A-Za-z0-9_.\-\"']+)\s*\]\s*(#.*)?$")
_KEY = re.compile(r"^(\s*)([A-Za-z0-9_\-]+)\s*=")


def _toml_value(value) -> str:
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    v = float(value)
    if not math.isfinite(v):
        raise UserError(f"cannot write a non-finite value ({v}) to a rig file")
    return repr(v)


def updated_rig_text(
    text: str,
    values: dict[str, float | str],
    comments: dict[str, str],
    *,
    remove: Sequence[str] = (),
    header: str = "",
) -> str:
    """The rig-file ``text`` with ``values`` (``"section.key"`` -> SI value or text) set.

    Each key is replaced in place (its old line kept as a comment) or added at the end of its
    section (the section appended if missing), followed by ``# comments[key]``. Keys in
    ``remove`` are commented out. ``header`` lines go on top, as comments. Only plain
    ``[section]`` tables are edited; the result is checked to parse (``tomllib``) and to hold
    every value given (a key written some other way, e.g. as an inline table, raises).
    """
    lines = text.splitlines()
    sections: dict[str, tuple[int, int]] = {}  # name -> (header line, last line of the section)
    current, start = "", -1
    for i, line in enumerate(lines):
        m = _HEADER.match(line)
        if m:
            sections.setdefault(current, (start, i - 1))
            current, start = m.group(1).strip().strip('"').strip("'"), i
    sections.setdefault(current, (start, len(lines) - 1))

    edits: dict[int, list[str]] = {}  # line index -> replacement lines
    appends: dict[str, list[str]] = {}  # section -> lines added at its end
    new_sections: dict[str, list[str]] = {}
    for full, value in values.items():
        section, key = full.rsplit(".", 1)
        line_text = f"{key} = {_toml_value(value)}"
        note = comments.get(full, "")
        line_text += f"   # {note}" if note else ""
        if section in sections:
            lo, hi = sections[section]
            hit, indent = None, ""
            for i in range(lo + 1, hi + 1):
                m = _KEY.match(lines[i])
                if m and m.group(2) == key:
                    hit = i, m.group(1)
                    break
            if hit is not None:
                i, indent = hit
                edits[i] = [f"{indent}# was: {lines[i].strip()}", indent + line_text]
            else:
                appends.setdefault(section, []).append(line_text)
        else:
            new_sections.setdefault(section, []).append(line_text)
    for full in remove:
        section, key = full.rsplit(".", 1)
        if section not in sections:
            continue
        lo, hi = sections[section]
        for i in range(lo + 1, hi + 1):
            m = _KEY.match(lines[i])
            if m and m.group(2) == key:
                edits[i] = [
                    (
                        f"{m.group(1)}# removed by rig update ({comments.get(full, 'replaced')}): "
                        f"{lines[i].strip()}"
                    )
                ]
    out: list[str] = [f"# {h}" for h in header.splitlines()] if header else []
    # added keys go after the last key line of their section (before trailing comments/blanks)
    after: dict[int, list[str]] = {}
    for section, added in appends.items():
        lo, hi = sections[section]
        keyed = [i for i in range(lo + 1, hi + 1) if _KEY.match(lines[i])]
        after.setdefault(keyed[-1] if keyed else max(lo, 0), []).extend(added)
    for i, line in enumerate(lines):
        out.extend(edits.get(i, [line]))
        out.extend(after.get(i, []))
    for section, added in new_sections.items():
        out += ["", f"[{section}]", *added]
    new = "\n".join(out) + "\n"
    try:
        data = tomllib.loads(new)
    except tomllib.TOMLDecodeError as exc:
        raise UserError(
            f"the updated rig file would not be valid TOML ({exc}): is a fitted section written as an "
            "inline table or dotted keys? edit the rig file by hand"
        ) from None
    for full, value in values.items():
        node: Any = data
        for part in full.split("."):
            node = node.get(part) if isinstance(node, dict) else None
        if node != value and not (
            isinstance(value, float) and isinstance(node, (int, float)) and float(node) == value
        ):
            raise UserError(
                f"could not write {full} into the rig file (is it given as an inline table "
                "or a dotted key?); edit the rig file by hand"
            )
    return new


def rig_file_update(
    text: str,
    linear=None,
    contact=None,
    *,
    sources: Sequence[str] = (),
    modes_used: str = "",
    contact_sources: Sequence[str] = (),
    when: str = "",
    notes: Sequence[str] = (),
) -> str:
    """The updated rig-file text from an :class:`rigtools.sim.parameter_fit.UpdateResult` and/or a
    :class:`rigtools.sim.contact_fit.ContactFitResult`, each key commented with recording, modes and residual;
    ``notes`` go into the header (what the fit moved that its data did not measure)."""
    values: dict[str, float | str] = {}
    comments: dict[str, str] = {}
    remove: list[str] = []
    if linear is not None:
        rms = math.sqrt(2 * linear.cost_after / max(1, linear.residuals_after.size))
        why = (
            f"rig update from {', '.join(sources)} ({modes_used}); max frequency error "
            f"{100 * linear.max_frequency_error_after:.3f} %, rms residual {rms:.3g} sigma"
        )
        fitted = linear.rig_file_values()
        for key, v in fitted.items():
            values[key] = v
            if key in linear.names:
                comments[key] = why
            elif key == "root.kind":
                comments[key] = "springs: root spring(s) fitted by rig update"
            elif key.startswith("root."):
                comments[key] = "not fitted: the stiffest spring a rig file accepts, standing for the clamp"
            else:
                comments[key] = f"follows the fitted {key.split('.')[0]}.mass (same ratio)"
        if "damping.alpha" in fitted and "damping.ratio" not in fitted:
            remove.append("damping.ratio")
            comments["damping.ratio"] = "Rayleigh damping fitted instead"
    if contact is not None:
        why = (
            f"rig update contact fit ({contact.law} law) to {', '.join(contact_sources)}; "
            f"rms harmonic error {100 * contact.rms_log_error_after:.2f} %"
        )
        for key, v in contact.rig_file_values().items():
            values[key] = v
            comments[key] = why
    first = (
        f"updated by rig update{(' on ' + when) if when else ''}: fitted keys are marked; "
        "the original lines follow them as '# was:'"
    )
    header = "\n".join([first, *notes])
    return updated_rig_text(text, values, comments, remove=remove, header=header)


def check_rig_text(text: str, path: str | Path | None = None):
    """Parse the updated text as a rig file (:func:`rigtools.config.parse_rig`); a
    :class:`rigtools.errors.ConfigError` names what the fit produced that the rig file refuses."""
    return parse_rig(tomllib.loads(text), f"updated rig file {path}" if path else "updated rig file")
