"""The buffered CBC loop's delay-aware gains for the simulated rig (64 Hz, gap 0.5 mm): identify the
block-rate model of the fundamental at orbits of the S-curve, design the gains for the output
queue's delay over those models, print them (``DELAY_GAINS`` in rigtools/procedures/cbc_iteration.py).

Run: ``PYTHONPATH=. python benchmarks/cbc_delay_design.py`` (about a minute of CPU).

Each identification: the procedure's approach and walk to the orbit at A, its CBC point converged,
then 10 s of the feedforward's fundamental stepped at random (+-0.4 % in phase and in quadrature,
held 1-3 blocks) with the PD law holding the orbit (Kp 300 V/m: the direct method, the drive
as played is the model's input; an orbit near the fold in drive, A 0.345 mm, leaves its branch
under such steps without control), the one-period fundamental and the played drive
logged per block and turned into the orbit's frame (the target's and feedforward's phases); an ARX
(2, 3) fit (:func:`rigtools.procedures.cbc_delay.fit_block_model`) of the blocks before
the orbit is lost (A 4 % from the target), if it is. The design set: those models,
the most unstable one with its growth moved to 10 and 13 1/s, each with its drive gain scaled by
0.8 and 1.25 and turned by +-10 deg (the model's own uncertainty); the min-max spectral radius
(:func:`rigtools.procedures.cbc_delay.design_envelope_gains`).
"""

from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

import numpy as np

from rigtools.config import load_rig
from rigtools.procedures.cbc import ControlBasedContinuation, cbc_point, predicted
from rigtools.procedures.cbc_delay import (
    BlockModel,
    design_envelope_gains,
    fit_block_model,
    spectral_radius,
)
from rigtools.procedures.cbc_iteration import DELAY_GAINS, FeedforwardSecant, Gains
from rigtools.procedures.cbc_loop import BufferedHarmonicLoop

FE, GAP = 64.0, 0.5e-3
PROBE = 0.004  # relative step of the feedforward's fundamental
LEFT = 0.04  # the orbit is lost once A is this far from the target (the blocks after: not fitted)


class _Identify(ControlBasedContinuation):
    """The procedure up to one converged point, then the random steps (no points recorded)."""

    def __init__(self, amplitude: float, gains: Gains, seed: int, out: Path):
        super().__init__(
            load_rig(None), {"fe": FE, "amplitudes": [amplitude], "gap": GAP}, out, backend="sim"
        )
        self.inner_loop_choice = "buffered"
        self.amplitude, self.seed, self.gains_used = amplitude, seed, gains
        self.params = self.params.model_copy(update={"law": "delay"})
        self.blocks: list[tuple[int, complex, complex]] = []
        self.frame = (0j, 0j)
        self.block_seconds = 0.0

    def execute(self) -> None:
        p, loop = self.params, self.loop
        assert isinstance(loop, BufferedHarmonicLoop)
        self.set_gap(p.gap)
        first = self._approach(loop, p)
        secant = self._walk(loop, p, first, self.amplitude, self._probe(loop, p, *first))
        target, ff = predicted(self._leg, first, self.amplitude)
        pt = cbc_point(loop, p, target, ff, FeedforwardSecant(secant.jacobian))
        print(f"  A {self.amplitude * 1e3:.3f} mm: {pt.point}", file=sys.stderr)
        target, ff = pt.target, pt.feedforward
        self.frame = (complex(target[0]), complex(ff[0]))
        loop.set_point(target, ff, ramp_time=0.0)
        loop.set_gains(self.gains_used)
        loop.wait(0.5)
        log: list[tuple[int, complex, complex]] = []
        loop.block_log = log
        rng = np.random.default_rng(self.seed)
        block = self.block_seconds = loop.stream.n / loop.rate
        end = loop.sink.total + 10.0 * loop.rate
        while loop.sink.total < end:
            probe = ff.copy()
            probe[0] *= 1 + PROBE * (rng.choice([-1, 1]) + 1j * rng.choice([-1, 1]))
            loop.set_point(target, probe, ramp_time=0.0)
            loop.wait(block * rng.integers(1, 4))
        loop.set_point(target, ff, ramp_time=0.0)
        loop.wait(0.5)
        self.blocks = list(log)
        loop.finish()


def identify(amplitude: float, gains: Gains, seed: int = 1) -> BlockModel:
    """The ARX model at the orbit of fundamental ``amplitude`` (m) held by ``gains``, in the
    orbit's frame."""
    out = Path(tempfile.mkdtemp()) / "ident.h5"
    proc = _Identify(amplitude, gains, seed, out)
    proc.run()
    target, ff = proc.frame
    x = np.array([b[1] for b in proc.blocks]) * np.exp(-1j * np.angle(target))
    u = np.array([b[2] for b in proc.blocks]) * np.exp(-1j * np.angle(ff))
    off = np.flatnonzero(np.abs(np.abs(x) / abs(target) - 1) > LEFT)
    n = int(off[0]) if off.size else x.size  # the blocks before the orbit was lost, if it was
    print(f"  {n} of {x.size} blocks on the orbit", file=sys.stderr)
    return fit_block_model(x[:n], u[:n], proc.block_seconds)


def varied(model: BlockModel) -> list[BlockModel]:
    """The model with its drive gain scaled by 0.8 and 1.25 and turned by +-10 deg."""
    out = [model]
    for scale in (0.8, 1.25):
        for turn in (-math.radians(10), math.radians(10)):
            r = scale * np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
            out.append(BlockModel(model.a, np.einsum("ij,njk->nik", r, model.b), model.block_seconds))
    return out


def main() -> None:
    gains = DELAY_GAINS
    pd = Gains(300.0)  # the PD law holds these orbits (|mu| 0.93 and 1.04) without the design
    models = {f"{a * 1e3:.3f}": identify(a, pd) for a in (0.315e-3, 0.340e-3, 0.350e-3)}
    for name, m in models.items():
        print(f"{name}: growth {m.growth_rate():+.2f} 1/s, residual {m.residual:.3f}")
    worst = max(models.values(), key=lambda m: m.growth_rate())
    design = [v for m in models.values() for v in varied(m)]
    design += [v for s in (10.0, 13.0) for v in varied(worst.with_growth(s))]
    print(f"present gains: largest radius {max(spectral_radius(m, gains) for m in design):.4f}")
    new, radius = design_envelope_gains(design, start=gains, trials=10)
    print(f"designed: largest radius {radius:.4f} per block over {len(design)} models")
    for s in (10.0, 13.0, 16.0):
        print(f"  growth {s:g} 1/s: radius {spectral_radius(worst.with_growth(s), new):.4f}")
    print("DELAY_GAINS = EnvelopeGains(")
    print(f"    k=({', '.join(f'{v:.2f}' for v in new.k)}),")
    print(f"    d=({', '.join(f'{v:.2f}' for v in new.d)}),")
    print(")")


if __name__ == "__main__":
    main()
