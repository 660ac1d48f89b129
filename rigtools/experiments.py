"""Experiments on the rig, as a lab script runs them: one function per procedure.

:func:`dwell`, :func:`stepped_sine`, :func:`acquire_study`, :func:`frf_test` and :func:`tap_test`
(``rig acquire dwell|sweep|study|frf|tap``) run the procedures of :mod:`rigtools.procedures` on
the NI rig (``backend="nidaq"``) or on the simulated rig (``backend="sim"``, the FE model behind
a simulated shaker and DAQ), write one recording each and return a :class:`RunResult`, the
result every procedure returns.

The backend has no default here: a script that measures names it. A script moves between a
laptop and the lab machine; a default either way runs the wrong thing on one of them (a
simulation recorded where a measurement was meant, or the shaker driven by a script written
for the simulated rig), so a missing ``backend`` is one error naming both. (``rig acquire``
defaults to ``--backend nidaq``: its operator stands at the rig; without NI-DAQmx it says so in
one line and offers ``--backend sim``.)

Every parameter takes a quantity string as the CLI does (``"60 Hz"``, ``"0.5 mm"``, ``"1 V"``)
or an SI float; the CLI's range strings (``frequencies="62 Hz:72 Hz:2 Hz"``,
``band="20 Hz:500 Hz"``) and its words (``periods=``, ``max_updates=``) are accepted too
(:mod:`rigtools.keywords`). A bad value is one :class:`rigtools.errors.UserError` line naming
the parameter, the value and the allowed range; an unknown keyword names the accepted ones and
the closest. The parameters, their units, defaults and bounds:
:func:`rigtools.procedures.reference_table`.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, TypeVar

from rigtools import procedures
from rigtools.config import RigConfig, load_rig
from rigtools.errors import UserError, reword
from rigtools.keywords import CONTROL_WORDS, did_you_mean, in_front_door_words
from rigtools.options import seed as seed_option
from rigtools.procedures.result import PointResult, RunResult

__all__ = [
    "PointResult",
    "RunResult",
    "acquire_study",
    "dwell",
    "frf_test",
    "stepped_sine",
    "study",
    "tap_test",
]

#: What a missing backend says (a script: the front door is not the command line).
NO_BACKEND = (
    'backend: not given; a measurement names its backend: backend="nidaq" (the NI rig) or '
    'backend="sim" (the simulated rig)'
)


def _config(rig: Any) -> RigConfig:
    return rig if isinstance(rig, RigConfig) else load_rig(rig)


#: The keywords every procedure of the front door takes besides its own parameters, defined once:
#: :func:`_front_door` adds them to each function's signature and their text to its docstring
#: (``%(shared)s``; ``%(out)s`` for ``out``, which each function takes by position).
SHARED_KEYWORDS = (
    inspect.Parameter(
        "rig", inspect.Parameter.KEYWORD_ONLY, default=None, annotation="RigConfig | str | Path | None"
    ),
    inspect.Parameter("backend", inspect.Parameter.KEYWORD_ONLY, default=None, annotation="str | None"),
    inspect.Parameter("overwrite", inspect.Parameter.KEYWORD_ONLY, default=False, annotation="bool"),
    inspect.Parameter(
        "progress",
        inspect.Parameter.KEYWORD_ONLY,
        default=None,
        annotation="Callable[[ProgressEvent], None] | None",
    ),
    inspect.Parameter("seed", inspect.Parameter.KEYWORD_ONLY, default=None, annotation="int | None"),
)
_DOCS = {
    "out": """\
out
    Recording to write (HDF5).""",
    "shared": """\
rig
    A :class:`rigtools.config.RigConfig`, a rig file, or ``None`` for the calibrated default.
backend
    ``"nidaq"`` (the NI rig) or ``"sim"`` (the simulated rig); no default: a script that
    measures names its backend (a default would run the simulation where a measurement was
    meant, or drive the shaker from a script written for the simulated rig).
overwrite
    Replace ``out`` if it exists.
progress
    Called with each :class:`rigtools.procedures.ProgressEvent`.
seed
    Noise seed of the simulated rig (``None``: 0, so that two runs record the same noise).""",
}
_NAMED = ("out", *(k.name for k in SHARED_KEYWORDS))
_Function = TypeVar("_Function", bound=Callable[..., RunResult])


def _front_door(function: _Function) -> _Function:
    """A front-door procedure with the :data:`SHARED_KEYWORDS`: added to its signature before its
    ``**params`` (what ``help()``, an IDE's call tips and the docs show; the function receives them
    in ``**params`` and passes them to :func:`_run`), their text put for ``%(shared)s`` and
    ``%(out)s`` in its docstring at the marker's indentation, as scipy's docstring templates do."""
    signature = inspect.signature(function)
    *own, var = signature.parameters.values()
    function.__signature__ = signature.replace(parameters=[*own, *SHARED_KEYWORDS, var])  # type: ignore[attr-defined]
    lines: list[str] = []
    for line in (function.__doc__ or "").splitlines():
        key = line.strip()[2:-2] if line.strip().startswith("%(") and line.strip().endswith(")s") else None
        if key in _DOCS:
            indent = line[: len(line) - len(line.lstrip())]
            lines.extend(indent + text if text else text for text in _DOCS[key].splitlines())
        else:
            lines.append(line)
    function.__doc__ = "\n".join(lines)
    return function


def _run(function: str, cls_name: str, params: dict[str, Any], out: str | Path, **kwargs: Any) -> RunResult:
    """Run a procedure: ``params`` holds its parameters and the :data:`SHARED_KEYWORDS` given."""
    params = dict(params)
    rig, backend, overwrite, progress, seed = (params.pop(k.name, k.default) for k in SHARED_KEYWORDS)
    cls = getattr(procedures, cls_name)
    model = getattr(procedures, _MODELS[cls_name])
    given = {name for name, value in params.items() if value is not None}
    params = in_front_door_words(f"rigtools.{function}", params, model.model_fields, (*_NAMED, *kwargs))
    if backend is None:
        raise UserError(NO_BACKEND)
    if backend not in ("sim", "nidaq"):
        raise UserError(
            f'backend = {backend!r}: use "sim" (the simulated rig) or "nidaq" (the NI rig)'
            f"{_did_you_mean(backend)}"
        )
    seed = seed_option(seed, "seed")
    try:
        proc = cls(
            _config(rig),
            params,
            out,
            backend=backend,
            overwrite=overwrite,
            progress=progress,
            seed=seed,
            **kwargs,
        )
        return proc.run()
    except Exception as exc:  # re-raised, its advice in a script's words
        reword(exc)
        _control_word(exc, given)
        raise


def _control_word(error: BaseException, given: set[str]) -> None:
    """A bad ``max_updates=`` named as the script wrote it, not as the model nests it
    (``control.max_updates``); a ``control={...}`` given as such keeps its path."""
    if len(error.args) != 1 or not isinstance(error.args[0], str):
        return
    for word in CONTROL_WORDS:
        if word in given and error.args[0].startswith(f"control.{word} = "):
            error.args = (error.args[0].removeprefix("control."),)


_MODELS = {
    "SineDwell": "DwellParameters",
    "SteppedSine": "SweepParameters",
    "RigStudy": "StudyParameters",
    "FrfTest": "FrfParameters",
    "TapTest": "TapParameters",
}


def _did_you_mean(backend: object) -> str:
    if not isinstance(backend, str):
        return ""
    for word in ("sim", "nidaq"):  # the recordings' names of the backends: "simulated", "nidaqmx"
        if backend.lower().startswith(word):
            return f"; did you mean {word!r}?"
    return did_you_mean(backend, ("sim", "nidaq"))


@_front_door
def dwell(
    fe: float | str,
    force: float | str,
    out: str | Path,
    *,
    gap: float | str | None = None,
    record_periods: int | None = None,
    **params: Any,
) -> RunResult:
    """Hold the force amplitude at one excitation frequency and record the settled response.

    Parameters
    ----------
    fe
        Excitation frequency: ``"60 Hz"`` or Hz.
    force
        Force amplitude F0 (fundamental of the force into the active blade): ``"15 N"`` or N.
    %(out)s
    gap
        Shroud gap, ``"0.5 mm"`` or m; ``None``: as set (the rig file's on the simulated rig).
    record_periods
        Periods recorded once settled (``None``: 60); ``periods=``, the CLI's word, is the same.
    %(shared)s
    **params
        More :class:`rigtools.procedures.DwellParameters` (``k_max``, ``control={...}``), or
        the CLI's words (``periods``, ``max_updates``); an unknown keyword is refused naming the
        accepted ones and the closest.

    Returns
    -------
    RunResult
        One point: the measured force, drive and harmonics, and the settled record window.

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "dwell.h5"
    >>> run = rigtools.dwell("60 Hz", "5 N", out, gap="5 mm", record_periods=6, backend="sim", seed=1)
    >>> run.status, run.points[0].settled
    ('finished', True)
    >>> abs(run.points[0].force_amplitude_measured - 5.0) < 0.05  # force control within 1 %
    True
    """
    p = {"fe": fe, "force": force, "gap": gap, "record_periods": record_periods, **params}
    return _run("dwell", "SineDwell", p, out)


@_front_door
def stepped_sine(
    frequencies: Sequence[float | str] | str,
    force: float | str,
    out: str | Path,
    *,
    gap: float | str | None = None,
    direction: str = "up",
    record_periods: int | None = None,
    **params: Any,
) -> RunResult:
    """Step the excitation frequency at a held force amplitude; one point per step.

    Parameters
    ----------
    frequencies
        Step frequencies, at least two: ``["62 Hz", "64 Hz"]``, Hz, or the CLI's
        ``"62 Hz:72 Hz:2 Hz"`` (start:stop:step, stop included) or ``"62 Hz,65 Hz"``.
    force
        Force amplitude F0 at every step: ``"15 N"`` or N.
    %(out)s
    gap
        Shroud gap, ``"0.7 mm"`` or m; ``None``: as set.
    direction
        ``"up"``, ``"down"`` or ``"both"`` (up, then down: hysteresis and jumps).
    record_periods
        Periods recorded at each step (``None``: 30); ``periods=`` is the same.
    %(shared)s
    **params
        More :class:`rigtools.procedures.SweepParameters` (``jump_threshold``, ``response``, ...)
        or the CLI's words (``periods``, ``max_updates``).

    Returns
    -------
    RunResult
        One point per step; ``summary["jumps"]`` lists the jumps found.

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "sweep.h5"
    >>> run = rigtools.stepped_sine("55 Hz:60 Hz:5 Hz", "5 N", out, gap="5 mm", periods=5, backend="sim")
    >>> [p.fe for p in run.points]
    [55.0, 60.0]
    """
    p = {
        "frequencies": frequencies if isinstance(frequencies, str) else tuple(frequencies),
        "force": force,
        "gap": gap,
        "direction": direction,
        "record_periods": record_periods,
        **params,
    }
    return _run("stepped_sine", "SteppedSine", p, out)


@_front_door
def acquire_study(
    kind: str,
    values: Sequence[float | str] | str,
    out: str | Path,
    *,
    fe: float | str | None = None,
    force: float | str | None = None,
    gap: float | str | None = None,
    direction: str = "up",
    record_periods: int | None = None,
    resume: bool = False,
    **params: Any,
) -> RunResult:
    """A force-controlled study on the rig over the gap, the force amplitude or the excitation
    frequency (``rig acquire study``; the model's study, ``rig study``, is :func:`rigtools.simulate_study`).

    Parameters
    ----------
    kind
        The swept parameter: ``"gap"``, ``"force"`` or ``"frequency"``. On the NI rig a gap study
        asks the operator to set each gap.
    values
        The swept values, in the unit of ``kind``: ``["0.3 mm", "0.6 mm"]``, SI floats, or the
        CLI's ``"0.3 mm:0.9 mm:0.3 mm"`` (start:stop:step) or ``"0.3 mm,0.6 mm"``.
    %(out)s
    fe, force, gap
        The parameters held fixed (the swept one is left ``None``).
    direction
        ``"up"``, ``"down"`` or ``"both"``.
    record_periods
        Periods recorded at each point (``None``: 30); ``periods=`` is the same.
    resume
        Continue an aborted study in ``out`` after its last complete point.
    %(shared)s
    **params
        More :class:`rigtools.procedures.StudyParameters`, or the CLI's words.

    Returns
    -------
    RunResult
        One point per study value.

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "study.h5"
    >>> run = rigtools.acquire_study("gap", "4 mm:5 mm:1 mm", out, fe="60 Hz", force="5 N", periods=5, backend="sim")
    >>> [round(p.gap * 1e3, 3) for p in run.points]
    [4.0, 5.0]
    """
    p = {
        "kind": kind,
        "values": values if isinstance(values, str) else tuple(values),
        "fe": fe,
        "force": force,
        "gap": gap,
        "direction": direction,
        "record_periods": record_periods,
        **params,
    }
    return _run("acquire_study", "RigStudy", p, out, resume=resume)


def study(*args: Any, **kwargs: Any) -> RunResult:
    """Deprecated name of :func:`acquire_study` (the study on the rig, ``rig acquire study``).

    ``rig study`` is the model's study, :func:`rigtools.simulate_study`; ``rigtools.study`` was
    the rig's, so the one word named two things. It still works, with a ``DeprecationWarning``.

    Examples
    --------
    >>> import warnings, rigtools
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     try:
    ...         rigtools.study("gap", ["1 mm"], "never-written.h5")
    ...     except rigtools.UserError as exc:
    ...         print(exc)
    backend: not given; a measurement names its backend: backend="nidaq" (the NI rig) or backend="sim" (the simulated rig)
    >>> str(caught[0].message).split(":")[0]
    'rigtools.study is deprecated'
    """
    import warnings

    warnings.warn(
        "rigtools.study is deprecated: the study on the rig (rig acquire study) is "
        "rigtools.acquire_study; the model's study (rig study) is rigtools.simulate_study",
        DeprecationWarning,
        stacklevel=2,
    )
    return acquire_study(*args, **kwargs)


@_front_door
def frf_test(
    band: tuple[float | str, float | str] | str,
    level: float | str,
    out: str | Path,
    *,
    signal: str = "chirp",
    frame: float | str = 1.0,
    averages: int = 10,
    gap: float | str | None = None,
    **params: Any,
) -> RunResult:
    """Broadband FRF test: periodic chirp or burst random over a band, averaged frames.

    Parameters
    ----------
    band
        ``(low, high)``: ``("20 Hz", "500 Hz")``, Hz, or the CLI's ``"20 Hz:500 Hz"``.
    level
        Drive level: the chirp's peak or the burst's rms within the burst, ``"1 V"`` or V.
    %(out)s
    signal
        ``"chirp"`` or ``"burst"``.
    frame
        Frame (period) length, ``"1 s"`` or s: the frequency resolution is 1/frame.
    averages
        Frames averaged.
    gap
        Shroud gap; open it (e.g. ``"5 mm"``) for the linear FRF.
    %(shared)s
    **params
        More :class:`rigtools.procedures.FrfParameters`.

    Returns
    -------
    RunResult
        One point holding the frames; :func:`rigtools.analyze_recording` (or
        :meth:`RunResult.analyze`) gives the FRF and modes.

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "frf.h5"
    >>> run = rigtools.frf_test("20 Hz:500 Hz", "1 V", out, frame="0.5 s", averages=2, gap="5 mm", backend="sim")
    >>> run.status, run.points[0].extra["signal"]
    ('finished', 'chirp')
    """
    p = {
        "band": band if isinstance(band, str) else tuple(band),
        "level": level,
        "signal": signal,
        "frame": frame,
        "averages": averages,
        "gap": gap,
    }
    return _run("frf_test", "FrfTest", {**p, **params}, out)


@_front_door
def tap_test(
    position: float | str,
    out: str | Path,
    *,
    blade: str = "passive",
    hits: int = 5,
    gap: float | str | None = None,
    **params: Any,
) -> RunResult:
    """Impact-hammer test of one blade: triggered hits, one point each (the simulated rig's
    hammer hits by itself; on the NI rig the operator taps).

    Parameters
    ----------
    position
        Hit position from the blade root: ``"85 mm"`` or m.
    %(out)s
    blade
        ``"passive"`` or ``"active"``.
    hits
        Accepted hits (double hits and undecayed frames are refused and repeated).
    gap
        Shroud gap; open it for the blade alone.
    %(shared)s
    **params
        More :class:`rigtools.procedures.TapParameters` (``frame``, ``trigger``, ...).

    Returns
    -------
    RunResult
        One point per accepted hit; ``summary`` holds the modes identified.

    Examples
    --------
    >>> import rigtools, tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "tap.h5"
    >>> run = rigtools.tap_test("85 mm", out, hits=2, gap="5 mm", backend="sim", seed=1)
    >>> run.status, len(run.points), run.summary["accepted"]
    ('finished', 2, 2)
    """
    p = {"position": position, "blade": blade, "hits": hits, "gap": gap, **params}
    return _run("tap_test", "TapTest", p, out)
