"""``rig report FILE.h5... --out DIR``: one self-contained HTML page of the analyses."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from rigtools.errors import UserError, exit_status_help
from rigtools.options import add_skip_damaged, output_folder

HELP = "one self-contained HTML page (figures embedded, works offline) of the analyses of recordings"
EPILOG = (
    """\
For each recording: the tables and figures of rig analyze (periodic points: force and harmonic
amplitudes, waveforms and spectra; stepped sines and studies: response curves; FRF tests: H1,
H2, Hv with phase and coherence, stabilisation charts, identified modes). Every amplitude is a
peak amplitude. With --fem FILE.h5 or --simulate, an EM-versus-FEM comparison of the first
recording (rigtools.recording_comparison) is added when that module is installed.

--branches B.h5 (files of rig continuation): in the section of each stepped sine or study
swept in the branches' parameter, the model's branches (stable solid, unstable dashed, folds
and period doublings labelled) with the recording's up/down steps on the same axes, its jumps
shaded, and a sentence per jump naming the mechanism by which the sweep leaves the branch it
followed (fold, grazing hairpin, Neimark-Sacker point and torus, period doubling or cascade,
another labelled event), how far from the jump, and the nearest turning point; rig recordings are drawn in the active shroud's fundamental acceleration, model recordings
in peak contact force. Drawn only over a recording of the branches' rig at their fixed
quantities, never over an imported one (rig continuation --measured overlays any recording);
a branch file drawn over nothing gets a section of its own.

A phase-locked loop (rig acquire pll) or control-based continuation (rig acquire cbc) among the
recordings adds one figure of everything measured: left, A (the active shroud's displacement
fundamental) against fe with the model's frequency branches, the stepped sines up and down, the
PLL's points and the CBC's; right, the CBC's S-curve F1 against A at its fe over a branch file
continued in force at that fe (rig continuation --param force --fe "64 Hz" --model rig).

The page is DIR/report.html (DIR is made if missing); an existing report.html is replaced only
if rigtools made it. Open it in any browser, no network needed.

"""
    + exit_status_help(0, 2, notes={0: "written", 2: "bad input (unreadable file, --out)"})
    + """

examples:
  rig report dwell.h5 frf.h5 --out report/
  rig report study.h5 --simulate --branches branches-gap.h5 --out report/
"""
)

PAGE = "report.html"
MARKER = "querySelectorAll('img.figure')"  # in the page script of rigtools.report.html


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "report",
        help=HELP,
        description=HELP + ".",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("files", metavar="FILE", nargs="+", help="recordings (.h5)")
    add_skip_damaged(p)
    p.add_argument("--out", required=True, metavar="DIR", help="folder of the report (report.html)")
    p.add_argument(
        "--kind",
        choices=("accelerance", "mobility", "receptance"),
        default="accelerance",
        help="FRF kind (default accelerance)",
    )
    p.add_argument(
        "--method", choices=("lscf", "peak"), default="lscf", help="modal identification (default lscf)"
    )
    p.add_argument("--fem", metavar="FILE", help="model recording to compare the first FILE with")
    p.add_argument(
        "--simulate", action="store_true", help="compare the first FILE with the model run at its points"
    )
    p.add_argument("--model", choices=("fem", "am"), default="fem", help="model for --simulate (default fem)")
    p.add_argument("--rig", metavar="FILE", help="rig file for --simulate (default: the recording's rig)")
    p.add_argument(
        "--branches",
        nargs="+",
        default=[],
        metavar="B.h5",
        help="branch files (rig continuation) drawn over the sweeps and studies in their parameter",
    )
    p.set_defaults(func=run)


def _is_report(path) -> bool:
    try:
        return MARKER in Path(path).read_text(encoding="utf-8", errors="replace")[-4000:]
    except OSError:
        return False


def add_comparison(report, args, say) -> dict | None:
    """The comparison section from :mod:`rigtools.recording_comparison`, if asked for and available."""
    if not (args.fem or args.simulate):
        return None
    try:
        from rigtools.recording_comparison import compare_recordings
    except ImportError:
        say("rig report: comparison is not available (no rigtools.recording_comparison); report without it")
        return None
    cmp = compare_recordings(args.files[0], args.fem, simulate=args.simulate, model=args.model, rig=args.rig)
    cmp.add_to_report(report)
    return cmp.to_dict()


def run(args: argparse.Namespace) -> int:
    from rich.console import Console

    from rigtools.derived_files import write_derived
    from rigtools.recording_analysis.dispatch import analyze_recording
    from rigtools.report.branches import add_unmatched_branches, load_branch_files
    from rigtools.report.controlled_overview import add_controlled_overview
    from rigtools.report.html import Report
    from rigtools.report.sections import add_analysis

    if args.fem and args.simulate:
        raise UserError("--fem and --simulate: give one")
    out = output_folder(args.out)
    if out.suffix.lower() in (".h5", ".hdf5"):
        raise UserError(f"--out {out}: a folder for the report, not a recording name")
    branches = load_branch_files(args.branches)  # a bad file before any work
    console = Console(stderr=True)
    analyses = []
    for i, f in enumerate(args.files):
        with console.status(f"analysing {f} ({i + 1}/{len(args.files)})"):
            analyses.append(analyze_recording(f, kind=args.kind, method=args.method))
    names = ", ".join(Path(f).name for f in args.files)
    report = Report("Shrouded-blade rig: analysis report", subtitle=names)
    with console.status("building the report"):
        for a in analyses:
            add_analysis(report, a, branches)
        add_controlled_overview(report, analyses, branches)
        add_unmatched_branches(report, branches)
        add_comparison(report, args, lambda s: print(s, file=sys.stderr))
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"--out {out}: cannot make the folder ({exc.strerror})") from None
    page = write_derived(
        out / PAGE, lambda tmp: tmp.write_text(report.html(), encoding="utf-8"), replaceable=_is_report
    )
    print(f"wrote {page} ({len(analyses)} recording(s), {report.n_figures} figures)")
    return 0
