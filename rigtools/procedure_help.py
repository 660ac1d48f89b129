"""The lab procedures' help texts and options for ``rig acquire`` (light: no package imports, so
``rig acquire --help`` stays fast; the procedures package itself loads numpy)."""

from rigtools.errors import (
    EXIT_FAULT,
    EXIT_HARDWARE,
    EXIT_NOT_REACHED,
    EXIT_STOPPED,
    EXIT_USAGE,
    exit_status_help,
)
from rigtools.options import ratio
from rigtools.pll_help import PLL_EPILOG, PLL_HELP, PLL_OPTIONS

HELP = "lab procedures on the rig: force-controlled dwell, stepped sine, study, FRF test, tap test"
BACKENDS = """\
Backends: --backend nidaq (default) drives the NI-DAQmx rig of the rig file's [daq]; --backend sim
runs the simulated rig (the FE model of [test_article] through the [shaker] model), as fast as
it can (--pace: in real time; --seed: the sensor noise, 0 by default, so runs repeat; --fault KIND@TIME[:CHANNEL] injects a fault:
input-overflow, amplifier-timeout, sensor-overload, nan-samples; TIME is seconds from the start,
"1.5", "1.5 s" or "250 ms", never a block: rigtools.drivers.simulated.Fault.parse).
In Python: rigtools.dwell, rigtools.stepped_sine (sweep), rigtools.acquire_study (study),
rigtools.frf_test (frf), rigtools.tap_test (tap), rigtools.control_based_continuation (cbc),
rigtools.phase_locked_loop (pll) take the same words and range strings; there backend= has no default (a script names backend="nidaq" or backend="sim").
"""
FORCE_CONTROL = """\
Force control: the force sensor's fundamental (least squares over whole periods) is held at
--force F0 within 0.5 % by adjusting the drive amplitude (secant steps, at most --max-updates
after the first ramp, never planned past 80 % of a [safety] warning level), then the response
settles (every input's fundamental steady within 1 %) and --periods whole periods are recorded.
Each point holds the whole stream
of that point (control, settling, record window: record_start / record_samples), the drive as
written, and parameters fe, force_amplitude (target), force_amplitude_measured, gap,
drive_amplitude, control_updates, settled, harmonics k = 1..K of every channel (amplitude and
phase relative to the force fundamental).
"""
QUANTITIES_AND_EXIT = (
    """\
The drive ramps up and down over [safety] ramp_time; on a stop, Ctrl-C, SIGTERM or SIGHUP it
ramps to zero over abort_ramp_time while still recording (status aborted), on a fault or safety
abort at once (status failed); everything recorded is kept. With --json a run that began its
recording and then stopped (130, 143, 129, 6) or failed (4, 5) still prints its document (status
aborted or failed, reason, file, the points recorded so far) before its one line on stderr.

Quantities take units ("60 Hz", "15 N", "0.5 mm", "2 s"); a plain number is SI.
"""
    + exit_status_help(
        0,
        EXIT_USAGE,
        EXIT_HARDWARE,
        EXIT_FAULT,
        EXIT_NOT_REACHED,
        EXIT_STOPPED,
        notes={
            0: "finished",
            EXIT_HARDWARE: "NI-DAQmx not available (use --backend sim)",
            EXIT_NOT_REACHED: "the force target cannot be reached within the rig's limits (max drive, 80 % "
            "of a warning level): dwell, sweep and study stop at the first such point, drive ramped "
            "to zero, status failed with the reason, every point written kept; cbc: no target "
            "converged",
        },
        run=True,
    )
    + "\n"
)
COMMON_EPILOG = BACKENDS + "\n" + FORCE_CONTROL + "\n" + QUANTITIES_AND_EXIT
FORCE_CONTROLLED = ("dwell", "sweep", "study")


def epilog(procedure: str) -> str:
    """The ``rig acquire PROCEDURE --help`` epilog: examples and notes, the backends, force control
    (force-controlled procedures only), quantities and exit statuses."""
    parts = [EPILOGS[procedure], BACKENDS]
    if procedure in FORCE_CONTROLLED:
        parts.append(FORCE_CONTROL)
    return "\n".join([*parts, QUANTITIES_AND_EXIT])


PROCEDURE_HELP = {
    "dwell": "force-controlled sine dwell at one frequency",
    "sweep": "force-controlled stepped sine up/down with harmonics and jumps",
    "study": "force-controlled gap / force / frequency study (the paper's form)",
    "frf": "burst random or periodic chirp FRF test, recorded raw",
    "tap": "impact-hammer (tap) test of a blade, one frame per hit, recorded raw",
    "cbc": "control-based continuation at one frequency: F1(A) through the folds, unstable orbits too",
    "pll": PLL_HELP,
}
_SINE = FORCE_CONTROLLED
# The options of each procedure: (procedures, flags, argparse keywords); "%(default)s" shows defaults.
PROCEDURE_OPTIONS: tuple[tuple[tuple[str, ...], tuple[str, ...], dict], ...] = (
    (("study",), ("kind",), {"choices": ("gap", "force", "frequency"), "help": "swept parameter"}),
    (("study",), ("--values",), {"required": True, "help": '"a,b,c" or "start:stop:step", with units'}),
    (("study",), ("--yes",), {"action": "store_true", "help": "do not wait for the operator to set the gap"}),
    (("study",), ("--resume",), {"action": "store_true", "help": "continue an interrupted study in --out"}),
    (("dwell", "cbc"), ("--fe",), {"required": True, "help": 'excitation frequency, e.g. "60 Hz"'}),
    (
        ("cbc",),
        ("--amplitude",),
        {"required": True, "help": 'target fundamental amplitudes A, e.g. "0.300 mm:0.360 mm:0.005 mm"'},
    ),
    (("cbc",), ("--gains",), {"default": None, "help": 'feedback "KP,KD" in V/m and V s/m (0: open loop)'}),
    (
        ("cbc",),
        ("--inner-loop",),
        {
            "choices": ("realtime", "buffered"),
            "default": None,
            "help": "the feedback: the backend's per-sample real-time loop (default where it has one) or buffered",
        },
    ),
    (
        ("cbc",),
        ("--max-iterations",),
        {"type": int, "default": None, "help": "outer iterations per point (8)"},
    ),
    (
        ("cbc",),
        ("--tolerance",),
        {
            "type": ratio,
            "default": None,
            "help": 'drive harmonics 2-10 / fundamental, e.g. 0.01 or "1 %%" (1 %%)',
        },
    ),
    (
        ("cbc",),
        ("--release",),
        {"default": None, "help": 'after the last point: gains 0 for this long, e.g. "1 s"'},
    ),
    (("study",), ("--fe",), {"help": 'excitation frequency, e.g. "60 Hz"'}),
    (("dwell", "sweep"), ("--force",), {"required": True, "help": 'force amplitude F0, e.g. "15 N"'}),
    (("study",), ("--force",), {"help": 'force amplitude F0, e.g. "15 N"'}),
    (
        _SINE,
        ("--periods", "--record-periods"),
        {
            "type": int,
            "default": None,
            "help": "whole periods recorded per point (record_periods= in Python)",
        },
    ),
    (
        _SINE,
        ("--max-updates",),
        {"type": int, "default": 10, "help": "force-control updates (default %(default)s)"},
    ),
    (
        ("sweep", "study"),
        ("--direction",),
        {"choices": ("up", "down", "both"), "default": "up", "help": "sweep order (default %(default)s)"},
    ),
    (
        ("sweep",),
        ("--frequencies",),
        {"required": True, "help": '"start:stop:step" or "a,b,c", e.g. "340 Hz:380 Hz:2 Hz"'},
    ),
    (
        ("sweep",),
        ("--jump-threshold",),
        {
            "type": float,
            "default": 0.3,
            "help": "relative change of the response between neighbouring steps called a jump (default %(default)s)",
        },
    ),
    (
        ("frf",),
        ("--signal",),
        {"choices": ("chirp", "burst"), "default": "chirp", "help": "excitation (default %(default)s)"},
    ),
    (("frf",), ("--band",), {"required": True, "help": '"low:high", e.g. "20 Hz:500 Hz"'}),
    (("frf",), ("--level",), {"required": True, "help": 'chirp peak or burst rms, e.g. "0.3 V"'}),
    (
        ("frf",),
        ("--frame",),
        {"default": "1 s", "help": 'frame length (resolution 1/frame), default "%(default)s"'},
    ),
    (
        ("frf",),
        ("--averages",),
        {"type": int, "default": 10, "help": "frames averaged (default %(default)s)"},
    ),
    (
        ("tap",),
        ("--blade",),
        {"choices": ("passive", "active"), "default": "passive", "help": "blade hit (default %(default)s)"},
    ),
    (("tap",), ("--position",), {"required": True, "help": 'hit position from the root, e.g. "85 mm"'}),
    (
        ("tap",),
        ("--hits",),
        {"type": int, "default": 5, "help": "accepted hits averaged (default %(default)s)"},
    ),
    (("tap",), ("--frame",), {"default": "2 s", "help": 'frame per hit, default "%(default)s"'}),
    (
        ("tap",),
        ("--pretrigger",),
        {"default": "10 ms", "help": 'kept before the trigger, default "%(default)s"'},
    ),
    (
        ("tap",),
        ("--trigger",),
        {"default": "5 N", "help": 'trigger level on the hammer force, default "%(default)s"'},
    ),
    (
        ("tap",),
        ("--hammer-channel",),
        {"default": "hammer", "help": "the hammer's [daq.channels] entry (default %(default)s)"},
    ),
    (
        ("tap",),
        ("--response",),
        {"default": None, "help": "response channel (default: the blade's accelerometer)"},
    ),
    (
        ("tap",),
        ("--timeout",),
        {"default": "60 s", "help": 'longest wait for the next accepted hit, default "%(default)s"'},
    ),
    (
        ("tap",),
        ("--hit-force",),
        {"default": "20 N", "help": 'simulated rig: peak hammer force, default "%(default)s"'},
    ),
    (
        ("tap",),
        ("--pulse",),
        {"default": "0.5 ms", "help": 'simulated rig: hammer pulse length, default "%(default)s"'},
    ),
    (
        ("tap",),
        ("--f-max",),
        {"default": "2 kHz", "help": 'highest frequency identified, default "%(default)s"'},
    ),
) + PLL_OPTIONS

EPILOGS = {
    "cbc": """examples:
  rig acquire cbc --backend sim --gap "0.5 mm" --fe "64 Hz" --amplitude "0.320 mm:0.330 mm:0.005 mm" --out cbc.h5
  rig acquire cbc --backend sim --gap "0.5 mm" --fe "64 Hz" --amplitude "0.34 mm,0.345 mm" --release "1 s" --inner-loop buffered --out c.h5 --json

A harmonic-domain feedback on the active shroud's displacement (u = u_ff + Kp (x* - x) + Kd (x*' - x'))
holds the rig at a target amplitude A at --fe; an outer iteration on the target's harmonics and the
feedforward makes the drive a pure sine (harmonics 2-10 below --tolerance of its fundamental), so
each converged point is an orbit of the rig without control, stable or not; F1 is measured. A point
converges when, besides, its fundamental is within 0.5 % of the target and its last two windows
agree within that 0.5 % (the iteration learns only from windows steady to 0.2 %). The rig
is brought onto the branch by a sweep up to --fe first. On the buffered path a correction is played
50-65 ms after its data: the default law on the fundamental, designed for that delay, holds orbits
with |mu| up to about 1.17 (64 Hz; --gains selects the PD law); the full unstable sheet needs a
real-time inner loop (--backend nidaq says so and runs the buffered variant). Where an A-step fails
at a turn of the branch in A (the grazing hairpin), points go on by pseudo-arclength in (A, drive);
where no turn is ahead (A rising with the drive, or rising as it falls) a failed or lost step is
cut in half (twice a round; another round while the cuts come nearer), each attempt after a failed
one from the last converged orbit brought back and held until steady; a leg whose cuts came
nearer goes on to its remaining targets (at most 8 extra attempts per leg).
With the real-time loop, below the impacting branch's turn in A (about 0.306 mm at 64 Hz, gap
0.5 mm) the orbit at a target A is the one without contact: the impacting point that did not converge there is kept, then the
orbit without contact is measured and recorded with "branch": "no contact" (two points, one target).
That needs a target above the turn first: a list whose first target lies far below it (e.g. 0.25 mm)
is walked to from the sweep's orbit, the walk loses the impacting orbit at the turn and the run
ends with exit 5 and no point; start the list at or above the turn (e.g. "0.31 mm,0.25 mm").
--json lists each point: fe_hz, amplitude_m, force_fundamental_n, phase_deg, converged, iterations,
drive_harmonics_ratio, control_effort, drive_amplitude_v, parameterisation (and step_cut on the
points of a cut step; with the real-time loop the measured multipliers: multipliers, max_multiplier
and the fit's multipliers_* details, or multipliers_not_measured saying why a point has none, e.g.
a fit whose pairs of periods follow no one linear map); "lost" gives one line per target the loop
let go of (also said on stderr), "skipped_amplitudes" the targets never tried.
In Python: rigtools.control_based_continuation(fe, amplitudes, out, gap=..., backend="sim").
""",
    "dwell": """examples:
  rig acquire dwell --backend sim --fe 60 --force "15 N" --gap "0.5 mm" --out dwell.h5
  rig acquire dwell --backend sim --fe 60 --force "15 N" --gap "0.5 mm" --out d.h5 --json
  rig acquire dwell --rig lab.toml --fe 60 --force "15 N" --out dwell.h5

--json prints {"file", "status", "backend", "fe", "force_amplitude", "force_amplitude_measured",
"gap", "drive_amplitude", "control_updates", "settled", "warnings",
"channels": {name: {"units", "peak", "harmonics": [{"k", "amplitude", "phase"}, ...]}}}.
""",
    "sweep": """examples:
  rig acquire sweep --backend sim --frequencies "340 Hz:380 Hz:2 Hz" --force "2 N" --gap "5 mm" --out s.h5
  rig acquire sweep --backend sim --frequencies "55 Hz:80 Hz:1 Hz" --force "15 N" --gap "0.7 mm" --direction both --out sweep.h5

Jumps: neighbouring steps whose response fundamental differs by more than --jump-threshold
(relative) AND where something else says the rig is not linear: the contact vanishes or appears
across the step (the passive shroud, driven only through the contact, and the active shroud's
harmonics k >= 2 above 5 % of the active fundamental), the sweep the other way disagrees there
(hysteresis), or, in contact on both sides, the step stands out from its neighbours. A step
without contact on either side is never a jump (a resonance passing between coarse steps).
Reported per direction with the frequencies between which they happen and that evidence.
""",
    "study": """examples:
  rig acquire study gap --backend sim --values "0.3 mm:0.9 mm:0.2 mm" --force "15 N" --fe 60 --out study.h5 --yes
  rig acquire study gap --backend sim --values "0.3 mm:0.9 mm:0.2 mm" --force "15 N" --fe 60 --out study.h5 --resume
  rig acquire study force --backend sim --values "5 N,10 N,15 N" --gap "0.7 mm" --fe 60 --out f.h5

The plan (values, order, up/down) is the model study's (rigtools.sim.studies.StudyPlan). On the NI rig
the gap is set by hand: the drive ramps to zero and the command waits for the operator (Enter;
--yes: do not wait). --resume continues an interrupted study in --out from its last complete
point (a point cut off is dropped and run again; none is repeated or lost).
""",
    "frf": """examples:
  rig acquire frf --backend sim --signal chirp --band "20 Hz:500 Hz" --level "0.3 V" --frame "0.5 s" --averages 10 --out chirp.h5
  rig acquire frf --backend sim --signal burst --band "20 Hz:2 kHz" --level "0.3 V" --out b.h5

Recorded raw (drive and inputs); the command prints H1 (response/force) peaks in the band and
their coherence over the averaged frames as a quick check. --level is the chirp's peak or the
burst's rms, V.
""",
    "tap": """examples:
  rig acquire tap --backend sim --blade passive --position "85 mm" --hits 5 --gap "5 mm" --out tap.h5
  rig acquire tap --rig lab.toml --blade passive --position "85 mm" --hits 5 --out tap.h5

An impact-hammer test of one blade (the passive blade has no shaker). The hammer's force is its
own [daq.channels] entry (kind = "force", IEPE; --hammer-channel, default "hammer"); the
response is the blade's shroud accelerometer (--response). A software trigger on the hammer
force (--trigger, default "5 N") starts a frame of --frame (default "2 s", resolution 1/frame),
--pretrigger (default "10 ms") of it from before the hit; one recording point per hit, recorded
raw; a double hit or a response that has not decayed by the frame's end is recorded, marked
rejected and not counted. The shaker's drive stays at 0 V. Tap where modes 1-3 all move: the
shroud sits near a node of the passive blade's third flexural mode; ~85 mm from the root (of
155 mm) moves all three. On the NI rig the command waits up to --timeout for each accepted
hit; the simulated rig hits a half-sine of --pulse (default "0.5 ms") and --hit-force (default
"20 N") peak every frame + 0.5 s. Prints the modes identified from H1 (response / hammer) over the
accepted hits (rectangular window per frame) up to --f-max.
""",
    "pll": PLL_EPILOG,
}
