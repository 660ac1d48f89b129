"""``rig analyze FILE``: harmonics, impacts, FRFs and modes of every point of a recording."""

from __future__ import annotations

import argparse

from rigtools import json_values
from rigtools.errors import exit_status_help
from rigtools.frf_options import add_frf_arguments, frf_options
from rigtools.options import add_skip_damaged, output_folder, positive_finite

HELP = "analyse a recording: harmonics and impacts per point; FRFs (H1, H2, Hv) and modes of FRF tests"
EPILOG = f"""\
Per point, by what it is:
  periodic points (sine dwell, stepped-sine step, study point, rig simulate/study run; they have
  fe): harmonics k = 1..30 of every channel (peak amplitude and phase, least squares over the
  record window), peak levels, impacts from the shroud accelerations and the force (impacts per
  period, peak level, contact duration, periodic or not). No modes: a sine excites one frequency
  at a time. A stepped sine or study also gives the first-harmonic FRF X1/F1 and the harmonic
  amplitudes against the swept value.
  broadband points (rig acquire frf: burst random or periodic chirp; a tap test or free decay):
  H1, H2, Hv and coherence of every response over the force as --kind, and natural frequencies
  with damping ratios from --method lscf (sdypy-EMA LSCF with a stabilisation check; modes that
  the force spectrum does not support are dropped with a note) or peak (peak picking with
  half-power damping).
  The FRF estimate follows the excitation: burst random one frame per burst period, periodic
  chirp whole periods (both rectangular); a record written elsewhere by its force: one frame
  per hammer hit (rectangular; --force-window/--exponential as pyFRF's windows) or continuous
  random (Hann, 50 % overlap). rig export uff writes the same FRF.
  A mode is a peak of |H| (3 dB) inside the band that a stable LSCF pole (within 0.1 % in
  frequency and 5 % in damping of the previous order) with damping ratio in (0, 0.1] holds in
  its half-power band at half the converged orders or more (the upper half of the orders,
  raised until the set of modes stops changing), with coherence >= 0.9 over that band; its
  frequency and damping are the medians over those orders. One line says how many candidates
  were not reported (--verbose or --json list them, --json with each mode's evidence).
  The orders and tolerances follow the band's lines (at most lines/10; the tolerances widen as
  1000/lines below 1000 lines, at most 10x): a mode of the whole grid is found in a band that
  holds it with a few half-power bandwidths to spare. No mode in a band is a note saying what
  was tried and what would help, and in --json "no_mode" (null when modes were found),
  "n_modes" and "tried" per response; the exit status stays 0 (the analysis ran, and the other
  responses and points keep their results): a script tests "no_mode".
  points without a force (operational logs): PSD (units^2/Hz, Welch, Hann) and its peaks,
  peak-amplitude spectrum (flattop), with --fe the harmonics k*fe; and the modes of the motion
  channels together (operational modal analysis: covariance-driven SSI in --band, default up to
  80 % of the Nyquist frequency), each with its spread. Harmonic tones of a drive or rotor (a
  steady sine: kurtosis well below a random resonance's 3, damping < 1 %; or on a multiple of
  --fe or of such a tone) are flagged with the reason, never called modes; --json's "oma" says
  "found" and lists modes, harmonics, the averaged spectrum's peaks and what was dropped.
Records are read in blocks: memory stays bounded for long recordings. Amplitudes are peak
amplitudes (RMS = peak / sqrt 2 for a sine).

--out DIR writes the figures as PNG (never over a recording or a file rigtools did not make).

{exit_status_help(0, 2, notes={0: "analysed", 2: "bad input (unreadable file, unknown channel, options; an FRF option that would change nothing, such as --band on a recording with neither a broadband point nor a point without a force)"})}

examples:
  rig analyze dwell.h5
  rig analyze frf.h5 --kind receptance --out figs/
  rig analyze study.h5 --json > study.json
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "analyze",
        help=HELP,
        description=HELP + ".",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("file", metavar="FILE", help="recording (.h5)")
    add_skip_damaged(p)
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.add_argument("--out", metavar="DIR", help="write figures (PNG) into DIR (made if missing)")
    p.add_argument(
        "--kind",
        choices=("accelerance", "mobility", "receptance"),
        default="accelerance",
        help="FRF kind: (m/s^2)/N, (m/s)/N or m/N (default accelerance)",
    )
    p.add_argument(
        "--method",
        choices=("lscf", "peak"),
        default="lscf",
        help="modal identification of FRF tests (default lscf)",
    )
    p.add_argument("--channels", metavar="A,B", help="analyse only these channels (the force is kept)")
    add_frf_arguments(p, analysis=True)
    p.add_argument(
        "--fe", help='excitation frequency whose harmonics a record without force shows, e.g. "50 Hz"'
    )
    p.add_argument(
        "--compare-fem",
        action="store_true",
        help="compare an imported recording's modes with this rig's FEM (never done unasked)",
    )
    p.add_argument("--verbose", action="store_true", help="list every candidate mode not reported and why")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from rich.console import Console

    from rigtools.recording_analysis.dispatch import analyze_recording

    channels = [c.strip() for c in args.channels.split(",") if c.strip()] if args.channels else None
    options = frf_options(args)
    fe = positive_finite(args.fe, "frequency", "--fe", unit="Hz") if args.fe else None
    out = output_folder(args.out) if args.out is not None else None
    console = Console(stderr=args.json)
    with console.status(f"analysing {args.file}"):
        analysis = analyze_recording(
            args.file,
            kind=args.kind,
            method=args.method,
            channels=channels,
            options=options,
            fe=fe,
            compare_fem=True if args.compare_fem else None,
        )
    written = []
    if out is not None:
        written = write_figures(analysis, out)
    if args.json:
        doc = analysis.to_dict()
        doc["figures"] = [str(p) for p in written]
        print(json_values.dumps(doc))
        return 0
    from rigtools.tables import analysis_tables

    for item in analysis_tables(analysis, verbose=args.verbose):
        console.print(item)
    for p in written:
        console.print(f"wrote {p}")
    return 0


def write_figures(analysis, out) -> list:
    """Every figure of :func:`rigtools.report.sections.analysis_figures` as ``DIR/STEM-NAME.png``."""
    from pathlib import Path

    from rigtools.figures import save_figures
    from rigtools.report.sections import analysis_figures

    stem = Path(analysis.path).stem
    named = ((nf.name, nf.figure) for nf in analysis_figures(analysis))
    return save_figures(named, out, lambda name: f"{stem}-{name}.png", source=analysis.path)
