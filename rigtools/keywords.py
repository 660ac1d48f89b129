"""The keywords of the front door's procedures: ``rig acquire``'s words accepted, an unknown
keyword answered with the accepted ones and a "did you mean".

A lab script may use the command line's words: ``periods=`` is ``record_periods=``
(``--periods``), ``max_updates=`` is ``control={"max_updates": ...}`` (``--max-updates``), and
a range string (``"62 Hz:72 Hz:2 Hz"``, ``"20 Hz:500 Hz"``) is read by the command line's one
parser (:func:`rigtools.options.value_list`, :func:`rigtools.options.band_option`, called by the
parameter models).
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Mapping
from typing import Any

from rigtools.errors import UserError

#: ``rig acquire``'s option (as a keyword) -> the front door's keyword, where they differ.
CLI_WORDS: dict[str, str] = {"periods": "record_periods"}

#: ``rig acquire``'s options that set a field of the ``control`` parameter (force control).
CONTROL_WORDS = ("max_updates",)


def did_you_mean(name: str, accepted: Iterable[str]) -> str:
    """``"; did you mean 'x'?"`` for the accepted name closest to ``name`` (difflib), else ``""``."""
    close = difflib.get_close_matches(name, list(accepted), n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else ""


def unknown_keyword(function: str, name: str, accepted: Iterable[str]) -> UserError:
    """The one line for a keyword ``function`` does not take: the closest accepted one and all."""
    known = sorted(set(accepted))
    return UserError(
        f"{function}: no keyword {name!r}{did_you_mean(name, known)} (accepted: {', '.join(known)})"
    )


def in_front_door_words(
    function: str, params: Mapping[str, Any], fields: Iterable[str], named: Iterable[str]
) -> dict[str, Any]:
    """The parameters of a procedure with the command line's words renamed and every keyword
    checked.

    Parameters
    ----------
    function
        The front door's function (``"rigtools.dwell"``), for the message.
    params
        The parameters as given (``None``: not given).
    fields
        The fields of the procedure's parameter model.
    named
        The function's own keywords (``rig``, ``backend``, ...), accepted in the message.

    Returns
    -------
    dict
        The parameters by the model's field names, those not given left out.

    Raises
    ------
    UserError
        A keyword neither the model nor the command line knows (with a "did you mean"), or a
        parameter given twice under both its names.

    Examples
    --------
    >>> from rigtools.keywords import in_front_door_words
    >>> in_front_door_words("rigtools.dwell", {"fe": 60.0, "periods": 6, "max_updates": 3},
    ...                     ["fe", "record_periods", "control"], [])
    {'fe': 60.0, 'record_periods': 6, 'control': {'max_updates': 3}}
    >>> in_front_door_words("rigtools.dwell", {"record_period": 6}, ["fe", "record_periods"], ["rig"])
    Traceback (most recent call last):
    ...
    rigtools.errors.UserError: rigtools.dwell: no keyword 'record_period'; did you mean 'record_periods'? (accepted: fe, periods, record_periods, rig)
    """
    fields = set(fields)
    words = {cli: kw for cli, kw in CLI_WORDS.items() if kw in fields}
    control = [w for w in CONTROL_WORDS if "control" in fields]
    out: dict[str, Any] = {}
    for name, value in params.items():
        if value is None:
            continue
        if name in words:
            target = words[name]
            if params.get(target) is not None and params[target] != value:
                raise UserError(
                    f"{function}: {name}={value!r} and {target}={params[target]!r} name one parameter; "
                    f"give one of them"
                )
            out[target] = value
        elif name in control:
            out["control"] = {**dict(params.get("control") or {}), name: value}
        elif name in fields:
            if name == "control" and "control" in out:
                out["control"] = {**dict(value), **out["control"]}
            else:
                out[name] = value
        else:
            raise unknown_keyword(function, name, fields | set(words) | set(control) | set(named))
    return out
