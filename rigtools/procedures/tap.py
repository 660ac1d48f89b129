"""Impact-hammer (tap) test: the natural frequencies of a blade without a shaker on it.

The passive blade has no shaker: an FRF test driven through the active blade's force sensor
never sees it while the gap is open. A lab measures it the way every modal lab measures a
structure without a shaker: it taps the blade with an instrumented hammer and records the
hammer's force and the shroud accelerometer.

What :class:`TapTest` does:

1. the inputs of ``[daq]`` plus the hammer's force channel (its own ``[daq.channels]`` entry,
   ``kind = "force"``, IEPE; named ``hammer`` by default) run continuously; the shaker's drive
   is held at 0 V the whole time;
2. a software trigger on the hammer force (``trigger``, N) starts a frame of ``frame``
   seconds, the first ``pretrigger`` seconds of it from before the trigger: one recording point
   per hit (``frame_samples`` samples), recorded raw
   (every input and the drive as written), point parameters ``hit``, ``blade``, ``position``,
   ``trigger_level``, ``pretrigger_samples``, ``frame_samples`` and at the end
   ``hit_peak_force``, ``accepted`` and ``reject_reason``;
3. a hit is rejected (recorded, not counted) when the hammer bounced (a second pulse over the
   trigger level after the force has stayed below half of it for ``release`` seconds) or the
   response has not decayed by the frame's end (the last 10 % of the frame above 0.5 % of the
   frame's peak and above the noise before the hit: the rectangular window would leak);
4. after ``hits`` accepted hits the test ends (status ``finished``).

On the NI rig the operator taps (the command says where, then waits up to ``timeout`` s for
each accepted hit); on the simulated rig a :class:`rigtools.drivers.simulated.SimulatedHammer` hits a half-sine
pulse of ``pulse`` seconds and ``hit_force`` peak at ``position`` every
``frame + 0.5 s``.

:func:`analyze_tap_recording` is H1 of the response over the hammer force over the accepted frames
(rectangular window per frame: a frame holds the whole hit and the decay) and
:func:`rigtools.analysis.modal_id.identify` on it: what ``rig analyze`` reports of the recording
(:func:`rigtools.recording_analysis.tap_test.analyze_tap_test`).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from rigtools.acquisition import BlockStream
from rigtools.drivers.contracts import ConfigurationError, DriverUnavailable, InputChannelSpec
from rigtools.drivers.simulated import SimulatedHammer
from rigtools.errors import UserError, option
from rigtools.procedures import rig
from rigtools.procedures.base import StopRequested, validate
from rigtools.procedures.sine import SineProcedure
from rigtools.quantity_fields import Force, Length, Time
from rigtools.recording import PointWriter, open_recording
from rigtools.recording_analysis.tap_test import analyze_tap_test
from rigtools.units import MAX_GAP


def default_hammer(name: str) -> InputChannelSpec:
    """A PCB 086C03-class modal hammer: what the simulated rig fits when the rig file has none."""
    return InputChannelSpec(
        name,
        physical_channel="Dev1/ai3",
        kind="force",
        sensitivity=2.25,
        sensitivity_units="mV/N",
        excitation_current=0.004,
        min_value=-2200.0,
        max_value=2200.0,
        location="impact hammer (simulated rig default)",
    )


DECAY_FRACTION = 0.005  # the last 10 % of a frame must stay below this share of its peak
NOISE_FACTOR = 6.0  # ... or below this many times the rms noise before the hit


class TapParameters(BaseModel):
    """An impact-hammer test (SI: m, N, s)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    blade: Literal["active", "passive"] = "passive"
    position: Length = Field(gt=0, le=1.0, description="hit position, m from the root")
    hits: int = Field(5, ge=2, le=1000, description="accepted hits averaged")
    frame: Time = Field(
        2.0, gt=0, le=60, description="frame per hit with the pretrigger, s (resolution 1/frame)"
    )
    pretrigger: Time = Field(0.01, ge=0, le=1, description="kept before the trigger, s")
    trigger: Force = Field(5.0, gt=0, le=10000, description="trigger level on the hammer force, N")
    release: Time = Field(0.002, gt=0, le=0.1, description="quiet time ending a pulse, s")
    gap: Length | None = Field(None, ge=0, le=MAX_GAP, description="shroud gap, m (None: as set)")
    hammer_channel: str = Field("hammer", description="input channel of the hammer force")
    response: str | None = Field(None, description="response channel (default: the hit blade's shroud)")
    timeout: Time = Field(60.0, gt=0, le=3600, description="longest wait for the next accepted hit, s")
    hit_force: Force = Field(20.0, gt=0, le=2000, description="simulated rig: peak hammer force, N")
    pulse: Time = Field(5e-4, ge=5e-5, le=5e-3, description="simulated rig: half-sine pulse length, s")


class _Trigger:
    """Cuts the continuous stream into one frame per hit (a :class:`BlockStream` sink)."""

    def __init__(self, test: TapTest, row: int, pre: int, frame: int) -> None:
        self.test, self.row, self.pre, self.frame = test, row, pre, frame
        self.total = 0  # samples seen
        self.history = np.zeros((0, 0))  # the latest `pre` samples (all rows)
        self.current: _Hit | None = None  # the frame being recorded
        self.last_event = 0  # sample of the last trigger or frame end

    def append(self, block: np.ndarray) -> None:
        i = 0
        n = block.shape[1]
        while i < n:
            if self.current is None:
                f = np.abs(block[self.row, i:])
                hit = np.flatnonzero(f >= self.test.params.trigger)
                if hit.size == 0:
                    self._remember(block[:, i:])
                    break
                k = i + int(hit[0])
                self._remember(block[:, i:k])
                self.current = self.test.begin_hit(self.total, self.history.copy())
                self.history = np.zeros((block.shape[0], 0))
                i = k
            else:
                take = min(n - i, self.frame - self.current.samples)
                self.current.add(block[:, i : i + take])
                self.total += take
                i += take
                if self.current.samples >= self.frame:
                    self.test.end_hit(self.current)
                    self.current = None

    def _remember(self, part: np.ndarray) -> None:
        self.total += part.shape[1]
        if self.pre == 0:
            return
        joined = part if self.history.size == 0 else np.hstack([self.history, part])
        self.history = joined[:, -self.pre :]


class _Hit:
    def __init__(self, point: PointWriter, before: np.ndarray, row: int, frame: int) -> None:
        self.point, self.row = point, row
        self.samples = 0
        self.parts: list[np.ndarray] = []
        self.pre = before.shape[1] if before.size else 0
        self.frame = frame
        if self.pre:
            self.add(before)

    def add(self, part: np.ndarray) -> None:
        self.point.append(part)
        self.parts.append(part)
        self.samples += part.shape[1]


class TapTest(SineProcedure):
    """Impact-hammer test of one blade; see the module docstring."""

    name = "tap test"

    def __init__(self, cfg, params: TapParameters | dict, out, **kwargs) -> None:
        super().__init__(cfg, out, **kwargs)
        self.params = params if isinstance(params, TapParameters) else validate(TapParameters, **params)
        self.accepted = 0
        self.hits_seen = 0

    def parameters_doc(self) -> dict:
        return self.params.model_dump()

    def first_frequency(self) -> float:
        return 1.0

    # -- start-up --------------------------------------------------------------------------------
    def _inputs(self) -> list[InputChannelSpec]:
        p = self.params
        inputs = list(self.cfg.daq.input_specs())
        names = [s.name for s in inputs]
        if p.hammer_channel not in names:
            if self.backend == "sim" and "hammer" not in p.hammer_channel.lower():
                # the simulated rig's hammer force is a channel whose name says hammer; any other
                # name would be the shaker's force, hit never: the 60 s wait ends "no accepted hit"
                raise UserError(
                    f"{option('hammer_channel')} = {p.hammer_channel!r}: no such input (inputs: "
                    f"{', '.join(names)}; the simulated rig adds one whose name says hammer, e.g. 'hammer')"
                )
            if self.backend != "sim":
                raise UserError(
                    f"the rig file has no [daq.channels.{p.hammer_channel}]: add the impact "
                    f'hammer\'s force channel (kind = "force", IEPE, its sensitivity in mV/N)'
                )
            inputs.append(default_hammer(p.hammer_channel))
        hammer = inputs[[s.name for s in inputs].index(p.hammer_channel)]
        if hammer.kind != "force":
            raise UserError(
                f"[daq.channels.{p.hammer_channel}] is kind {hammer.kind!r}: the hammer "
                f'channel must be kind = "force"'
            )
        return inputs

    def response_channel(self, names: list[str]) -> str:
        p = self.params
        if p.response is not None:
            if p.response not in names:
                raise UserError(
                    f"{option('response')} = {p.response!r}: no such input (inputs: {', '.join(names)})"
                )
            return p.response
        accel = [s.name for s in self.device.input_channels if s.kind == "accel"]
        mine = [n for n in accel if p.blade in n.lower()]
        if not mine:
            raise UserError(
                f"no accelerometer named for the {p.blade} blade among {', '.join(accel) or 'the inputs'}; "
                f"name one with {option('response')}"
            )
        return mine[0]

    def startup(self) -> None:
        p = self.params
        if self.device is None:
            self.device = rig.open_device(self.cfg, self.backend, **self._device_opts)
        inputs = self._inputs()
        try:
            rate = self.device.configure(
                inputs, self.cfg.daq.output_spec(), self.cfg.daq.sample_rate, self.cfg.daq.block_size()
            )
        except DriverUnavailable as exc:
            raise DriverUnavailable(str(exc).replace("--simulated", "--backend sim")) from None
        except ConfigurationError as exc:
            raise UserError(str(exc)) from None
        self.rate = rate
        names = [s.name for s in self.device.input_channels]
        self.hammer_row = names.index(p.hammer_channel)
        self.response = self.response_channel(names)
        self.response_row = names.index(self.response)
        self.frame_samples = round(p.frame * rate)
        self.pre_samples = round(p.pretrigger * rate)
        if hasattr(self.device, "set_hammer"):
            self._simulated_hammer()
        self.specs = rig.channel_specs(self.device, self.cfg, rate)
        self.monitor = rig.safety_monitor(self.cfg, self.device)
        self.trigger = _Trigger(self, self.hammer_row, self.pre_samples, self.frame_samples)
        self.stream = BlockStream(
            self.device,
            _ZeroDrive(),
            sink=self.trigger,
            safety=self.monitor,
            record_drive=True,
            abort_ramp_time=self.cfg.safety.abort_ramp_time,
            hurry=lambda: self.hurry_requested,
        )
        self.open_writer(
            rig.experiment_metadata(
                self.name,
                self.device,
                self.parameters_doc(),
                hammer_channel=p.hammer_channel,
                response=self.response,
            )
        )

    def _simulated_hammer(self) -> None:
        p = self.params
        interval = p.frame + 0.5
        hammer = SimulatedHammer(
            blade=p.blade,
            position=p.position,
            peak=p.hit_force,
            duration=p.pulse,
            interval=interval,
            first=0.3,
            seed=self._device_opts.get("seed") or 0,
        )
        try:
            self.device.set_hammer(hammer)
        except ConfigurationError as exc:
            raise UserError(str(exc)) from None

    # -- hits ------------------------------------------------------------------------------------
    def begin_hit(self, trigger_sample: int, before: np.ndarray) -> _Hit:
        p = self.params
        self.hits_seen += 1
        point = self.recording_writer().begin_point(
            params={
                "hit": self.hits_seen,
                "blade": p.blade,
                "position": p.position,
                "gap": self.gap,
                "trigger_level": p.trigger,
                "trigger_time": trigger_sample / self.rate,
                "pretrigger_samples": before.shape[1] if before.size else 0,
                "frame_samples": self.frame_samples,
            },
            channels=self.specs,
        )
        self.point = point
        self.emit("recording", point=self.accepted + 1, n_points=p.hits, text=f"hit {self.hits_seen}")
        return _Hit(point, before, self.hammer_row, self.frame_samples)

    def end_hit(self, hit: _Hit) -> None:
        p = self.params
        data = np.hstack(hit.parts)
        force = data[self.hammer_row]
        reason = double_hit(force, hit.pre, p.trigger, round(p.release * self.rate))
        if not reason:
            reason = undecayed(data[self.response_row], hit.pre)
        accepted = not reason
        hit.point.set_attrs(
            point_complete=True,
            accepted=accepted,
            reject_reason=reason,
            hit_peak_force=float(np.max(np.abs(force))),
        )
        hit.point.end()
        self.point = None
        if accepted:
            self.accepted += 1
        self.result.points.append(
            {
                "hit": self.hits_seen,
                "accepted": accepted,
                "reject_reason": reason,
                "peak_force": float(np.max(np.abs(force))),
            }
        )
        self.emit(
            "point_done",
            point=self.accepted,
            n_points=p.hits,
            text="accepted" if accepted else f"rejected: {reason}",
        )

    # -- execute ---------------------------------------------------------------------------------
    def execute(self) -> None:
        p = self.params
        self.gap = self.set_gap(p.gap)
        self.emit(
            "message",
            text=f"tap the {p.blade} blade at {p.position * 1e3:g} mm from the root "
            f"(trigger {p.trigger:g} N on {p.hammer_channel})",
        )
        wait_from = 0
        accepted = 0
        while self.accepted < p.hits:
            self.stream.read()
            if self.stop_requested:
                self.stream.finish(ramp_time=self.cfg.safety.abort_ramp_time)
                raise StopRequested(self.stop_reason)
            if self.accepted != accepted:
                accepted, wait_from = self.accepted, self.trigger.total
            if self.trigger.current is None and (self.trigger.total - wait_from) / self.rate > p.timeout:
                rejected = self.hits_seen - self.accepted
                raise UserError(
                    f"no accepted hit over {p.trigger:g} N on {p.hammer_channel} within "
                    f"{p.timeout:g} s ({self.accepted} of {p.hits} hits accepted"
                    + (
                        f", {rejected} rejected: {self.result.points[-1]['reject_reason']}"
                        if rejected
                        else ""
                    )
                    + ")"
                )
        self.stream.finish()
        self.result.summary = {
            "hits": self.hits_seen,
            "accepted": self.accepted,
            "frame_samples": self.frame_samples,
            "response": self.response,
            "hammer": p.hammer_channel,
        }

    def shutdown(self, status, reason) -> None:
        self.session = None
        super().shutdown(status, reason)


class _ZeroDrive:
    """The shaker's drive during a tap test: 0 V throughout."""

    def next_block(self, n: int) -> np.ndarray:
        return np.zeros(n)

    def stop_block(self, ramp_time: float | None = None) -> np.ndarray:
        return np.zeros(1)


def double_hit(force: np.ndarray, start: int, level: float, release: int) -> str:
    """Why a frame's hammer force is not one clean pulse (``""`` if it is): after the first
    pulse (from ``start``) the force stays below ``level / 2`` for ``release`` samples, and
    then a second crossing of ``level`` is a double hit."""
    f = np.abs(np.asarray(force, dtype=float))
    below = f[start:] < 0.5 * level
    run = 0
    for k, b in enumerate(below):
        run = run + 1 if b else 0
        if run >= release:
            later = np.flatnonzero(f[start + k :] >= level)
            if later.size:
                return f"double hit {later[0] + k:d} samples after the trigger"
            return ""
    return ""


def undecayed(response: np.ndarray, pretrigger: int = 0) -> str:
    """``""`` when the last 10 % of the frame stays below :data:`DECAY_FRACTION` of the frame's
    peak response, or within the noise (``NOISE_FACTOR`` times the rms of the ``pretrigger``
    samples before the hit); otherwise why not."""
    x = np.asarray(response, dtype=float)
    r = np.abs(x - (x[:pretrigger].mean() if pretrigger else 0.0))
    tail = r[int(0.9 * r.size) :]
    peak = float(r.max()) if r.size else 0.0
    noise = NOISE_FACTOR * float(np.sqrt(np.mean(r[:pretrigger] ** 2))) if pretrigger else 0.0
    if peak > 0 and tail.size and float(tail.max()) > max(DECAY_FRACTION * peak, noise):
        return (
            f"the response has not decayed by the frame's end ({tail.max() / peak * 100:.1f} % of "
            f"its peak): lengthen --frame"
        )
    return ""


def analyze_tap_recording(
    path,
    response: str | None = None,
    *,
    f_min: float | None = None,
    f_max: float | None = None,
    n_modes: int | None = None,
):
    """H1 of the response over the hammer force over the accepted hits of a tap-test recording
    (rectangular window per frame) and the modes identified from it: the very analysis ``rig
    analyze`` reports (:func:`rigtools.recording_analysis.tap_test.analyze_tap_test`).

    Parameters
    ----------
    path
        A ``rig acquire tap`` recording.
    response
        Response channel (default: the recording's).
    f_min, f_max
        Identification band, Hz (default: 5 Hz to the hammer pulse's reach).
    n_modes
        Keep at most this many modes.

    Returns
    -------
    rigtools.analysis.point.FRFTestAnalysis
        ``.modes[response].modes`` the identified modes; ``.estimate`` the FRF.
    """
    with open_recording(path) as rec:
        exp = rec.experiment or {}
        if (response or exp.get("response")) is None:
            raise UserError(f"{path}: the recording names no response channel; give one")
        return analyze_tap_test(rec.points, exp, band=(f_min, f_max), response=response, n_modes=n_modes).frf
