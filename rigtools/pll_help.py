"""``rig acquire pll``: its one-line help, its options and the epilog that teaches it (light: no
package imports, so ``rig acquire --help`` stays fast)."""

PLL_HELP = "phase-locked loop: backbone (-90 deg, stepped force) or stepped phase at a held force"

PLL_EPILOG = """examples:
  rig acquire pll --backend sim --gap "0.5 mm" --force "0.2 N" --phase "-90 deg" --out pll.h5
  rig acquire pll --backend sim --gap "0.5 mm" --force "1 N,2 N,5 N,10 N" --out backbone.h5
  rig acquire pll --backend sim --gap "0.5 mm" --force "5 N" --phase "-152 deg,-156 deg,-165 deg" --out fr.h5

What it does: the drive frequency is adjusted until the active shroud's displacement fundamental
(from its accelerometer, X1 = -A1/w^2) lags the force fundamental by --phase. The phase detector
fits the fundamentals of force and response over the last two periods together with harmonics
2..10 (the impacts' harmonics do not leak into the fundamental), on the drive's own phase shifted
by the device's input-to-output delay; a PI (--kp Hz/deg, --ki Hz/(deg s)) moves the frequency,
the sine staying phase-continuous; an outer, slower loop holds the force fundamental at --force
by the drive amplitude, never planned past 80 % of a [safety] warning level.
Modes: one phase and a list of forces is a backbone (phase resonance, -90 deg, the default);
one force and a list of phases traces the frequency response under phase control, through and
beyond the fold where a stepped sine jumps; two lists of the same length give each point both.
A point is locked when the phase error's RMS over the last --lock-periods periods is at most
--lock-tolerance and the force within 1 %; then --record-periods periods are recorded with the
loops running. Not locked within --max-periods, the frequency at --f-min/--f-max or the
amplitude past --max-amplitude: the point is written marked not converged and one line says why;
--on-lock-loss continue (default) goes on to the next point, stop ends the run there (drive
ramped to zero, the points kept). Between points the target phase moves at --phase-rate.
Inner loop (--inner-loop): where the backend has a real-time loop (the simulated rig) the
detector, the PI and the sine run per sample on it (10 kHz, 1.04 ms; gains 0.05 Hz/deg,
0.5 Hz/(deg s), and 0.25, 0.3 while the target lies below -140 deg, where the target also moves
at 5 deg/s, the force is held within 0.4 % and the lock needs 0.5 deg, unless given), the host
holding the force and moving the target; this holds the orbits past the fold (to -165 deg at 5 N). --backend nidaq says in one line
that this needs a real-time target and runs the buffered PLL (the host's, every ~20 ms).
The first point starts at --fe-start (default: the rig file's nominal model's frequency at the
first --phase, without contact).

--json prints {"file", "status", "backend", "procedure": "pll", "points": [{"fe_hz",
"amplitude_m", "force_fundamental_n", "phase_deg", "converged", "iterations",
"drive_harmonics_ratio"}, ...]}: the shared controlled-point record (iterations: periods to
lock; drive_harmonics_ratio: rms of the drive's harmonics 2-10 over its fundamental).
In Python: rigtools.phase_locked_loop(forces, out, phases=..., gap=..., backend="sim").
"""

_P = ("pll",)
PLL_OPTIONS: tuple[tuple[tuple[str, ...], tuple[str, ...], dict], ...] = (
    (
        _P,
        ("--force",),
        {"required": True, "help": 'force fundamental F1, one or a list: "5 N" or "1 N,2 N,5 N"'},
    ),
    (_P, ("--phase",), {"default": "-90 deg", "help": 'target phase, one or a list (default "%(default)s")'}),
    (
        _P,
        ("--fe-start",),
        {"default": None, "help": "frequency of the first point's start (default: the model's)"},
    ),
    (_P, ("--f-min",), {"default": None, "help": "lowest drive frequency (default 0.7 x --fe-start)"}),
    (_P, ("--f-max",), {"default": None, "help": "highest drive frequency (default 1.5 x --fe-start)"}),
    (
        _P,
        ("--kp",),
        {
            "type": float,
            "default": None,
            "help": "proportional gain, Hz/deg (buffered 0.009; real-time 0.05/0.25)",
        },
    ),
    (
        _P,
        ("--ki",),
        {
            "type": float,
            "default": None,
            "help": "integral gain, Hz/(deg s) (buffered 0.07; real-time 0.5/0.3)",
        },
    ),
    (
        _P,
        ("--lock-periods",),
        {"type": int, "default": None, "help": "periods of the lock test (default 20)"},
    ),
    (_P, ("--lock-tolerance",), {"default": None, "help": 'phase error RMS at lock (default "1 deg")'}),
    (
        _P,
        ("--max-periods",),
        {
            "type": int,
            "default": None,
            "help": "periods a point may take to lock, at least --lock-periods (default 600)",
        },
    ),
    (
        _P,
        ("--record-periods",),
        {"type": int, "default": None, "help": "periods recorded after lock (default 20)"},
    ),
    (
        _P,
        ("--phase-rate",),
        {"default": None, "help": 'how fast the target moves between points (default "30 deg/s")'},
    ),
    (
        _P,
        ("--max-amplitude",),
        {"default": None, "help": 'active shroud amplitude limit, e.g. "3 mm" (lock loss)'},
    ),
    (
        _P,
        ("--inner-loop",),
        {
            "choices": ("realtime", "buffered"),
            "default": None,
            "help": "the phase loop: the backend's per-sample real-time PLL (default where it has one) or buffered",
        },
    ),
    (
        _P,
        ("--on-lock-loss",),
        {
            "choices": ("continue", "stop"),
            "default": "continue",
            "help": "after a point not locked (default %(default)s)",
        },
    ),
)
