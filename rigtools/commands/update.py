"""``rig update``: fit the rig file's model to recordings (FRF/tap tests, dwells with impacts)."""

from __future__ import annotations

import argparse
import datetime as _dt
import json
from pathlib import Path

from rigtools.errors import UserError
from rigtools.options import output_path

HELP = "fit the rig file's model to FRF/tap tests (and contact to dwells); write an updated rig file"
PARAMETER_NAMES = (
    "root.rotational_stiffness",
    "root.translational_stiffness",
    "damping.ratio",
    "damping.alpha",
    "damping.beta",
    "shroud.mass",
    "force_sensor.mass",
    "blade.youngs_modulus",
)
DEFAULT_PARAMS = "root.rotational_stiffness,damping.ratio"
EPILOG = f"""\
Steps:
  1. identify natural frequencies and damping ratios in each recording's broadband test (LSCF on
     H1 = acceleration / force; an FRF test 'rig acquire frf' gives the active blade, a tap test
     of the passive blade gives the passive one);
  2. pair them with the model's flexural modes (blade, order; the first --modes of each blade);
  3. fit --params by weighted least squares (relative frequency errors over 0.1 %, damping
     ratios over 10 %; bounds; scipy least_squares) and report identifiability: Jacobian rank,
     correlations, 95 % intervals, and the parameter pairs the data cannot separate (named, not
     fitted silently: such values are kept but flagged);
  4. --contact DWELL.h5: fit the contact stiffness and damping to the shroud acceleration
     harmonics (k = 1..10) of force-controlled dwells with impacts ('rig acquire dwell'), the
     vibro-impact integrator in the loop, and print the EM-versus-FEM agreement score
     (rigtools.analysis.compare.point_agreement, force and shroud harmonics, model driven at the measured
     force) before updating, after the linear update and after the contact fit;
  5. write --out: the rig file's text with the fitted keys replaced (old line kept as '# was:')
     or added, each commented with the recordings, modes and residual it came from.

Parameters (rig-file keys, SI): {", ".join(PARAMETER_NAMES)}.
damping.ratio (modal) or damping.alpha + damping.beta (Rayleigh), not both. Fitting a root spring
turns a clamped root into springs (the other spring stays stiff unless fitted too).

Exit status: 0 written, 2 bad input (unknown parameter, unreadable recording, a recording without
usable modes such as a dwell given as a test, --out existing or a recording), 130 Ctrl-C.

examples:
  rig acquire frf --backend sim --band "20 Hz:2 kHz" --level "0.3 V" --out frf.h5
  rig update frf.h5 --out updated.toml
  rig update frf.h5 tap.h5 --params root.rotational_stiffness,shroud.mass,damping.ratio --out u.toml
  rig update frf.h5 --contact dwell.h5 --out updated.toml --json
  rig modal --rig updated.toml
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "update",
        help=HELP,
        description=HELP + ".",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "recordings",
        nargs="+",
        metavar="TEST.h5",
        help="FRF test / tap test recordings (modes are identified in each)",
    )
    p.add_argument(
        "--rig", metavar="FILE", help="rig file (TOML) to update; default: the calibrated default rig"
    )
    p.add_argument(
        "--params",
        default=DEFAULT_PARAMS,
        metavar="NAME,...",
        help=f"rig-file parameters to fit (default {DEFAULT_PARAMS})",
    )
    p.add_argument("--out", required=True, metavar="FILE.toml", help="updated rig file to write")
    p.add_argument("--overwrite", action="store_true", help="replace --out if it exists")
    p.add_argument(
        "--modes",
        type=int,
        default=3,
        metavar="N",
        help="flexural modes per blade used as targets, lowest first (default 3)",
    )
    p.add_argument(
        "--band",
        default=None,
        metavar="LOW:HIGH",
        help='band searched for modes, e.g. "20 Hz:2 kHz" (default: each test\'s band)',
    )
    p.add_argument(
        "--no-damping", action="store_true", help="fit frequencies only (ignore identified damping)"
    )
    p.add_argument(
        "--contact",
        nargs="+",
        default=[],
        metavar="DWELL.h5",
        help="force-controlled dwells with impacts: fit contact stiffness and damping",
    )
    p.add_argument(
        "--law",
        choices=("rig", "linear", "hertz", "compare"),
        default="rig",
        help="contact law to fit (default: the rig file's); compare: fit linear and Hertz, keep the better",
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of tables")
    p.set_defaults(func=run)


def _band(text: str | None):
    if text is None:
        return None, None
    from rigtools.options import quantity

    parts = text.split(":")
    if len(parts) != 2:
        raise UserError(f'--band = {text!r}: write LOW:HIGH, e.g. "20 Hz:2 kHz"')
    lo, hi = (quantity(x, "frequency", "--band") for x in parts)
    if not 0 < lo < hi:
        raise UserError(f"--band = {text!r}: need 0 < low < high")
    return lo, hi


def _console():
    from rich.console import Console

    return Console()


def run(args: argparse.Namespace) -> int:
    from rigtools.updating import parse_names

    names = parse_names(args.params, PARAMETER_NAMES)
    if not 1 <= args.modes <= 10:
        raise UserError(f"--modes = {args.modes}: use 1..10")
    f_min, f_max = _band(args.band)
    inputs = [*args.recordings, *args.contact] + ([args.rig] if args.rig else [])
    out = output_path(args.out, args.overwrite, "--out", suffixes=(".toml",), inputs=inputs)
    for path in inputs:
        if not Path(path).exists():
            raise UserError(f"{path}: no such file")

    from rigtools import updating as up
    from rigtools.commands.simulate import working
    from rigtools.config import default_rig_text, load_rig, read_rig_text

    cfg = load_rig(args.rig)
    text = read_rig_text(args.rig) if args.rig else default_rig_text()
    nominal = cfg.to_params()
    quiet = args.json
    found = []
    for i, path in enumerate(args.recordings):
        with working(f"identifying modes in {Path(path).name} ({i + 1}/{len(args.recordings)})", quiet):
            found.append(up.identify_recording(path, f_min=f_min, f_max=f_max))
    dwells = []
    for path in args.contact:
        with working(f"reading dwell {Path(path).name}", quiet):
            dwells.extend(up.read_dwell(path))
    targets, paired, notes = up.mode_targets(
        nominal, found, max_modes=args.modes, damping=not args.no_damping
    )
    with working(f"fitting {', '.join(names)} to {len(targets)} modes", quiet):
        res = up.fit_linear(nominal, targets, names)

    scores, cres, hres = {}, None, None
    if dwells:
        from rigtools.sim.reduction import reduced_system

        with working("EM-versus-FEM score of the nominal model", quiet):
            scores["nominal"] = [up.agreement(d, up.model_dwell(nominal, d)).score for d in dwells]
        linear_system = reduced_system(res.params, "fem")
        with working("EM-versus-FEM score after the linear update", quiet):
            scores["linear update"] = [
                up.agreement(d, up.model_dwell(res.params, d, system=linear_system)).score for d in dwells
            ]
        laws = {"rig": [None], "linear": ["linear"], "hertz": ["hertz"], "compare": ["linear", "hertz"]}[
            args.law
        ]
        fits = []
        for law in laws:
            with working(
                f"fitting the contact ({law or res.params.contact.law} law) to {len(dwells)} dwell(s): "
                "vibro-impact runs",
                quiet,
            ):
                fits.append(up.fit_contact_to_dwells(res.params, dwells, law=law))
        cres = min(fits, key=lambda r: r.cost_after)
        hres = [r for r in fits if r is not cres]
        with working("EM-versus-FEM score after the contact fit", quiet):
            scores["contact fit"] = [
                up.agreement(d, up.model_dwell(cres.params, d, system=linear_system)).score for d in dwells
            ]

    modes_used = ", ".join(f"{p.blade} f{p.order} {p.frequency_hz:.2f} Hz" for p in paired)
    new_text = up.rig_file_update(
        text,
        res,
        cres,
        sources=[Path(p).name for p in args.recordings],
        modes_used=modes_used,
        contact_sources=[Path(p).name for p in args.contact],
        when=_dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
    )
    up.check_rig_text(new_text, out)
    try:
        out.write_text(new_text, encoding="utf-8")
    except OSError as exc:
        raise UserError(
            f"cannot write {out}: {exc.strerror or exc}",
        ) from None

    warnings = []
    rms = (2 * res.cost_after / max(1, res.residuals_after.size)) ** 0.5
    if rms > 2.0:
        warnings.append(
            f"the fitted parameters do not explain the identified modes: rms residual {rms:.3g} x "
            f"their uncertainty (frequencies 0.1 %, damping 10 %), largest frequency error "
            f"{100 * res.max_frequency_error_after:.3f} %; the model lacks what differs on the rig "
            "(try the root springs or the masses)"
        )
    warnings += [f"not determined by the data: {line}" for line in res.identifiability.unresolved]
    doc = {
        "file": str(out),
        "warnings": warnings,
        "recordings": [
            {
                "file": r.path,
                "procedure": r.procedure,
                "sets": [
                    {
                        "point": s.point,
                        "blade": s.blade,
                        "response": s.response,
                        "frequencies_hz": s.frequencies_hz,
                        "damping_ratios": s.damping_ratios,
                        "notes": s.notes,
                    }
                    for s in r.sets
                ],
            }
            for r in found
        ],
        "targets": [
            {
                "blade": p.blade,
                "order": p.order,
                "frequency_hz": p.frequency_hz,
                "damping_ratio": p.damping_ratio,
                "model_hz": p.model_hz,
                "sources": p.sources,
            }
            for p in paired
        ],
        "notes": notes,
        "fit": res.as_dict(),
    }
    if dwells:
        doc["contact_fit"] = cres.as_dict()
        doc["contact_fit_other_laws"] = [r.as_dict() for r in hres]
        doc["agreement"] = {"dwells": [d.name for d in dwells], **scores}
    if args.json:
        print(json.dumps(doc, indent=1, default=float))
        return 0
    _print(args, res, paired, notes, dwells, cres, hres, scores, out)
    if warnings and warnings[0].startswith("the fitted"):
        _console().print(f"[yellow]warning:[/] {warnings[0]}")
    return 0


def _print(args, res, paired, notes, dwells, cres, hres, scores, out) -> None:
    from rich.table import Table

    con = _console()
    t = Table(title="identified modes used")
    for col in ("blade", "order", "identified Hz", "zeta", "nominal model Hz", "from"):
        t.add_column(col, justify="left" if col in ("blade", "from") else "right")
    for p in paired:
        t.add_row(
            p.blade,
            str(p.order),
            f"{p.frequency_hz:.3f}",
            "-" if p.damping_ratio is None else f"{p.damping_ratio:.4f}",
            f"{p.model_hz:.3f}",
            ", ".join(p.sources),
        )
    con.print(t)
    for n in notes:
        con.print(f"[yellow]note:[/] {n}")
    con.print(res.report(), markup=False, highlight=False, soft_wrap=True)
    if res.identifiability.unresolved:
        con.print(
            "[yellow]the values of the parameters named above are kept in the rig file but the data do "
            "not determine them: add modes (another blade, higher orders) or fit fewer parameters[/]"
        )
    if dwells:
        con.print(cres.report(), markup=False, highlight=False, soft_wrap=True)
        for r in hres:
            con.print(
                f"other law: {r.law}: rms harmonic error {100 * r.rms_log_error_after:.2f} % "
                f"(kept: {cres.law}, {100 * cres.rms_log_error_after:.2f} %)"
            )
        s = Table(title="EM-versus-FEM agreement (1 = identical harmonics)")
        s.add_column("dwell")
        for step in scores:
            s.add_column(step, justify="right")
        for i, d in enumerate(dwells):
            s.add_row(
                f"{d.name} ({d.fe:g} Hz, {d.force_amplitude:.3g} N, gap {1e3 * d.gap:g} mm)",
                *[f"{scores[k][i]:.4f}" for k in scores],
            )
        con.print(s)
    con.print(f"wrote {out} (check: rig modal --rig {out})")
