"""The one-line text of an error, where the drivers can have it.

Drivers import nothing of the orchestration (:mod:`rigtools.drivers.contracts`); their faults
are the exception classes there, and their messages are made one line by :func:`one_line`,
which :mod:`rigtools.errors` re-exports for the rest of the toolkit (the CLI, abort reasons).
"""

from __future__ import annotations


def one_line(
    error: BaseException | str, limit: int | None = 500, *, first: bool = False, typed: bool = False
) -> str:
    """The one line an error is shown as (a message, a recording's abort reason): the one rule.

    Parameters
    ----------
    error
        An exception or its text.
    limit
        At most this many characters (cut with ``...``); ``None``: no limit.
    first
        Keep only the first non-blank line (driver messages put details on the lines after);
        otherwise every line joined, white space folded.
    typed
        Prefix ``"TypeName: "`` (abort reasons: what failed).

    Returns
    -------
    str
        The line; the exception's type name when it has no text; a Ctrl-C without text
        ``"KeyboardInterrupt: interrupted by the user"``.
    """
    text = str(error)
    if first:
        text = next((line for line in text.splitlines() if line.strip()), "")
    text = " ".join(text.split())
    if isinstance(error, BaseException):
        name = type(error).__name__
        if isinstance(error, KeyboardInterrupt):  # rigtools.errors.Interrupted names its signal
            text = text or "KeyboardInterrupt: interrupted by the user"
        elif not text:
            text = name
        elif typed:
            text = f"{name}: {text}"
    return text if limit is None or len(text) <= limit else text[: limit - 3] + "..."
