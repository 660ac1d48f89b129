"""The model's periodic orbits continued in a parameter: what ``rig continuation`` and
:func:`rigtools.continuation` compute (:func:`continue_model`, on the rig file's reduced model or
the simulated rig's, :func:`simulated_rig_model`), held against the model's range and the memory
first, written as a branches file (:func:`continue_to_file`; the file itself:
:mod:`rigtools.branches_file`), and told as text (:func:`summary`, :func:`located_lines`).

Drawn by :mod:`rigtools.branches_figure`, with recorded sweeps from :mod:`rigtools.measured_sweeps`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rigtools.branches_file import X_LABELS, X_UNITS, write_branches
from rigtools.config import load_rig
from rigtools.errors import UserError, option
from rigtools.memory import check_memory
from rigtools.options import drive_amplitude, positive_finite
from rigtools.options import gap as gap_value
from rigtools.options import switch as yes_no
from rigtools.sim.continuation import Branch, ShakerDrive, trace
from rigtools.sim.params import SimulationInputError
from rigtools.sim.reduction import reduced_system
from rigtools.simulation import (
    LONG_WORK_SECONDS,
    check_model_range,
    continuation_cost,
    human_seconds,
    load_system,
)
from rigtools.units import MAX_GAP

DIMENSION = {"fe": "frequency", "force": "force", "gap": "length"}
DEFAULT_FORCE = "15 N"  # the force held when none is given


def parse_inputs(
    param: str,
    start: str | float,
    stop: str | float,
    fe: str | float,
    force: str | float | None,
    gap: str | float,
    drive: str | float | None = None,
) -> tuple[float, float, dict[str, float]]:
    """``(start, stop, {"fe", "force", "gap"})`` in SI from quantity strings (``"0.7 mm"``; a
    plain number is SI); one-line :class:`UserError` naming the option otherwise. With
    ``drive`` (the simulated rig's model driven at a fixed drive amplitude) ``"force"`` is that
    amplitude in peak volts, and so is a ``"force"`` range; ``force`` None is 15 N, and a force
    given with ``drive`` is refused (it would not be held)."""
    # each named as the caller gives it: --from on the command line, start= in a script
    p_, f_, t_ = option("param"), option("start", flag="--from"), option("stop", flag="--to")
    fe_, force_, gap_, drive_ = option("fe"), option("force"), option("gap"), option("drive")

    if param not in DIMENSION:
        raise UserError(f"{p_} = {param!r}: one of {', '.join(DIMENSION)}")
    if param == "gap":
        lo, hi = gap_value(start, f_), gap_value(stop, t_)
    elif param == "force" and drive is not None:
        lo, hi = drive_amplitude(str(start), f_), drive_amplitude(str(stop), t_)
    else:
        lo = positive_finite(start, DIMENSION[param], f_)
        hi = positive_finite(stop, DIMENSION[param], t_)
    if lo == hi:
        raise UserError(f"{f_} and {t_} are both {start!r}: give a range")
    if drive is not None and force is not None:
        raise UserError(
            f"{force_} = {force!r} with {drive_} = {drive!r}: the model holds either the force or the "
            "drive amplitude; give one"
        )
    force = DEFAULT_FORCE if force is None else force
    fixed = {
        "fe": positive_finite(fe, "frequency", fe_),
        "force": (
            positive_finite(force, "force", force_) if drive is None else drive_amplitude(str(drive), drive_)
        ),
        "gap": gap_value(gap, gap_),
    }
    return lo, hi, fixed


def continuation(
    param: str,
    start: str | float,
    stop: str | float,
    *,
    fe: str | float = "60 Hz",
    force: str | float | None = None,
    gap: str | float = "0.7 mm",
    model: str = "fem",
    rig: str | None = None,
    switch: bool = True,
    drive: str | float | None = None,
    found: list | None = None,
) -> list[Branch]:
    """Branches of the rig model's periodic orbits continued in ``param`` (what ``rig
    continuation`` computes, without the file).

    Parameters
    ----------
    param
        ``"fe"``, ``"force"`` or ``"gap"``.
    start, stop
        The range of ``param`` (``"55 Hz"``, ``"0.5 mm"``; a plain number is SI).
    fe, force, gap
        The fixed quantities (the continued one is ignored); ``force`` None: 15 N (not with
        ``drive``).
    model
        ``"fem"`` or ``"am"`` reduction of the rig; ``"rig"``: the simulated rig's model (the
        FEM of its test article driven through the shaker and amplifier, as ``--backend sim``
        integrates it), under force control at ``force`` as the rig's procedures hold it.
    rig
        Rig file (TOML); default the calibrated default rig.
    switch
        Also the period-2 branch of each period doubling.
    drive
        With ``model="rig"``: hold this drive amplitude (``"1 V"``, peak) instead of the force;
        ``"force"`` then means the drive amplitude (a ``"force"`` range too).
    found
        A list the branches grow in as they are computed: after a Ctrl-C (KeyboardInterrupt)
        it holds what was computed so far, the branch being traced marked "interrupted".

    Returns
    -------
    list of rigtools.sim.continuation.Branch
        The period-1 branch first; its points carry stability, Floquet multipliers, labels
        (fold, period-doubling, neimark-sacker, grazing) and response measures.

    Examples
    --------
    Without contact (a 5 mm gap no orbit closes) every orbit is stable:

    >>> import rigtools
    >>> (b,) = rigtools.continuation("fe", "56 Hz", "57 Hz", gap="5 mm", switch=False)
    >>> b.status, b.points[0].value, b.points[-1].value, bool(b.stable().all())
    ('complete', 56.0, 57.0, True)
    >>> b.points[-1].max_multiplier < 1.0
    True

    A long continuation stopped with Ctrl-C keeps its points in ``found`` (minutes of work:
    not run here):

    >>> found = []
    >>> try:  # doctest: +SKIP
    ...     branches = rigtools.continuation("fe", "15 Hz", "80 Hz", found=found)
    ... except KeyboardInterrupt:
    ...     branches = found
    >>> branches[-1].status  # after a Ctrl-C  # doctest: +SKIP
    'interrupted'
    """
    if found is not None and not isinstance(found, list):
        raise UserError(
            f"found = {found!r}: give a list (found=[]) to hold the branches as they are computed"
        )
    lo, hi, fixed = parse_inputs(param, start, stop, fe, force, gap, drive)
    return continue_model(
        param,
        lo,
        hi,
        **fixed,
        model=model,
        rig=rig,
        switch=yes_no(switch, "switch"),
        drive=drive is not None,
        found=found,
    )[1]


def continue_model(
    param: str,
    start: float,
    stop: float,
    *,
    fe: float,
    force: float,
    gap: float,
    model: str = "fem",
    rig: str | None = None,
    switch: bool = True,
    progress=None,
    drive: bool = False,
    found: list | None = None,
    announce=None,
):
    """``(rig config, branches)``: the period-1 branch of the rig's reduced model over
    ``[start, stop]`` and the period-2 branches of its period doublings
    (:func:`rigtools.sim.continuation.trace`). ``model="rig"``: the simulated rig's model
    (:func:`simulated_rig_model`), ``force`` the force fundamental held or, with ``drive``, the
    drive amplitude (V). Bad input becomes a :class:`UserError`. ``found``: the branches grow
    there as they are computed (kept when interrupted, :func:`rigtools.sim.continuation.trace`).
    The range is held against the model and the memory first (:func:`check_continuation_resources`);
    ``announce(line)`` is told when the work will be long."""
    if model not in ("fem", "am", "rig"):
        raise UserError(f"--model = {model!r}: one of fem, am, rig")
    if drive and model != "rig":
        raise UserError("--drive holds the simulated rig's drive: use it with --model rig")
    shaker = None
    if model == "rig":
        cfg, system, shaker = simulated_rig_model(rig, force_control=not drive)
    else:
        cfg, system = load_system(rig, model)
    check_continuation_resources(system, param, start, stop, fe=fe, force=force, announce=announce)
    try:
        branches = trace(
            system,
            param,
            start,
            stop,
            fe=fe,
            force=force,
            gap=gap,
            shaker=shaker,
            switch=switch,
            progress=progress,
            found=found,
        )
    except SimulationInputError as exc:
        raise UserError(str(exc)) from None
    check_plausible_branches(branches, drive)
    return cfg, branches


def check_continuation_resources(
    system, param: str, start: float, stop: float, *, fe: float, force: float, announce=None
) -> None:
    """Refuse, before any orbit, a continuation the model cannot answer or the memory cannot
    hold: a frequency more than the model's range above its highest mode
    (:func:`rigtools.simulation.check_model_range`), or one orbit at the lowest frequency (the
    most steps per period) larger than the memory (:func:`rigtools.memory.check_memory`), each
    in one line with the estimate; ``announce`` gets one line when a point takes long."""
    lo, hi = sorted((start, stop))
    fe_lo, fe_hi = (lo, hi) if param == "fe" else (fe, fe)
    check_model_range(system, fe_hi, "--to" if param == "fe" else "--fe")
    force_max = hi if param == "force" else force
    steps, need, seconds = continuation_cost(system, fe_lo, abs(force_max))
    check_memory(
        need,
        f"an orbit at {fe_lo:g} Hz ({steps} steps per period)",
        "start the range at a higher frequency (the steps per period grow as 1/fe)",
    )
    if announce is not None and seconds * 100 > LONG_WORK_SECONDS:
        announce(
            f"each point at {fe_lo:g} Hz takes about {human_seconds(seconds)} ({steps} steps per period); "
            "a branch holds up to 2000 points"
        )


def continue_to_file(
    out: Path,
    param: str,
    start: float,
    stop: float,
    fixed: dict[str, float],
    *,
    model: str,
    rig: str | None,
    switch: bool,
    drive: bool,
    measured: list[str],
    found: list,
    announce=None,
):
    """``(rig config, branches)`` of :func:`continue_model`, written to ``out``
    (:func:`write_branches`, ``experiment`` naming the inputs). Interrupted (Ctrl-C, SIGTERM), the
    branches computed so far (``found``, the one in progress ``"interrupted"``) are written before
    the interrupt goes on."""
    experiment = {
        "procedure": "continuation",
        "param": param,
        "from": start,
        "to": stop,
        **fixed,
        "model": model,
        "drive": drive,  # "force" is then the drive amplitude, V (--model rig)
        "measured": [str(m) for m in measured],
    }
    try:
        cfg, branches = continue_model(
            param,
            start,
            stop,
            **fixed,
            model=model,
            rig=rig,
            switch=switch,
            drive=drive,
            found=found,
            announce=announce,
        )
    except KeyboardInterrupt:
        if any(b.points for b in found):
            write_branches(out, [b for b in found if b.points], load_rig(rig).to_json(), experiment)
        raise
    write_branches(out, branches, cfg.to_json(), experiment)
    return cfg, branches


def check_plausible_branches(branches, drive: bool = False) -> None:
    """Refuse branches on which a shroud moves farther than any blade of the rig can (more than
    :data:`rigtools.units.MAX_GAP`), as :func:`rigtools.simulation.check_plausible` refuses such a
    run: the linear beam model is meaningless there (a typical cause: ``"1 MN"`` for ``"1 mN"``)."""
    for b in branches:
        for name in ("active", "passive"):
            amplitude = b.measure(f"tip_amplitude_{name}")
            if amplitude.size and float(np.max(amplitude)) > MAX_GAP:
                p = b.points[int(np.argmax(amplitude))]
                what = "--drive and its unit (mV, V)" if drive else "--force and its unit (mN, N, kN)"
                unit = "V" if drive and b.param == "force" else X_UNITS[b.param]
                raise UserError(
                    f"at {b.param} = {p.value * X_LABELS[b.param][1]:.6g} {unit} the {name} shroud "
                    f"moves {float(np.max(amplitude)):.3g} m, more than any blade of the rig can "
                    f"({MAX_GAP * 1e3:g} mm): not a physical orbit; check {what}"
                )


def simulated_rig_model(rig: str | None, force_control: bool = True):
    """``(rig config, reduced system, shaker drive)`` of the simulated rig (``--backend sim``):
    the rig file's ``[test_article]`` applied to its nominal parameters, reduced as the
    simulated rig's vibro-impact physics reduces it, and its ``[shaker]`` with the amplifier
    gain (:class:`rigtools.sim.continuation.ShakerDrive`)."""
    cfg = load_rig(rig)
    article = cfg.test_article.to_params().apply(cfg.to_params())
    shaker = cfg.shaker.to_params()
    drive = ShakerDrive(shaker.coupling(), shaker.amplifier_gain, force_control)
    return cfg, reduced_system(article, "fem"), drive


def summary(branches) -> dict:
    """The ``--json`` document: per branch its periods, status, points, labels (``bifurcations``:
    every label of every point, start and end included) and the labelled bifurcations and events
    with their critical multiplier and converged location (``located``,
    :meth:`rigtools.sim.bifurcations.Bifurcation.as_dict`)."""
    return {
        "branches": [
            {
                "periods": b.periods,
                "status": b.status,
                "message": b.message,
                "points": len(b.points),
                "steps_per_period": b.steps_per_period,
                "bifurcations": [
                    {"label": lab, "value": p.value, "stable": p.stable, "max_multiplier": p.max_multiplier}
                    for p in b.points
                    for lab in p.labels
                ],
                "located": [r.as_dict() for r in b.bifurcations],
            }
            for b in branches
        ]
    }


def located_lines(branch, param: str) -> list[str]:
    """One line per labelled bifurcation or event of a branch (``Branch`` or
    :class:`rigtools.branches_file.StoredBranch`): label, value at the branch's time step,
    converged value and its last change, critical multiplier, contact structures of an event."""
    unit, scale = X_UNITS[param], X_LABELS[param][1]
    out = []
    for r in [x if isinstance(x, dict) else x.as_dict() for x in branch.bifurcations]:
        mu = r["multiplier_converged"] if r["converged"] is not None else r["multiplier"]
        mu_text = "" if mu[0] is None else f", multiplier {complex(mu[0], mu[1] or 0.0):.4f}"
        text = f"  {r['label']} at {r['value'] * scale:.6g} {unit}"
        if r["converged"] is not None:
            text += (
                f" -> {r['converged'] * scale:.6g} {unit} at {r['steps_per_period']} steps/period "
                f"(last change {r['change'] * scale:+.2g} {unit}{'' if r['converged_ok'] else ', not converged'})"
            )
        text += mu_text
        if not r["smooth"]:
            text += f"; contact {r['contact_before']} -> {r['contact_after']}"
        out.append(text)
    return out
