"""FRF test: burst random or periodic chirp over a band, with averages, recorded raw.

One recording point holds the whole stream (ramp, the settling frame, the averaged frames, the
ramp down); ``record_start`` and ``frame_samples`` say where the averaged frames are. The
quick check (:func:`quick_check`) is H1 of the response over the force with whole frames as
segments (rectangular window: a burst has decayed and a periodic chirp is periodic in a frame),
the estimate ``rig analyze`` reports, and the coherence at its peaks; the analysis of the raw
record belongs to :mod:`rigtools.analysis`.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator
from scipy.signal import find_peaks

from rigtools.acquisition import BlockStream
from rigtools.drivers.drive_signals import PeriodicChirp, RandomDrive
from rigtools.errors import UserError
from rigtools.options import band_option
from rigtools.procedures import rig
from rigtools.procedures.base import Status, StopRequested, validate
from rigtools.procedures.session import PointSink
from rigtools.procedures.sine import SineProcedure
from rigtools.quantity_fields import Frequency, Length, Time, Voltage
from rigtools.recording import open_recording
from rigtools.recording_analysis.frf_estimate import point_frf_estimate
from rigtools.units import MAX_GAP


class FrfParameters(BaseModel):
    """An FRF test (SI)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    signal: Literal["burst", "chirp"] = "chirp"
    band: tuple[Frequency, Frequency] = Field(description="(low, high) Hz")
    level: Voltage = Field(gt=0, le=10, description="drive: rms within bursts, or chirp peak, V")
    frame: Time = Field(1.0, gt=0, le=100, description="frame (period) length, s: resolution 1/frame")
    averages: int = Field(10, ge=2, le=10000, description="frames averaged")
    burst_fraction: float = Field(0.5, gt=0, le=1, description="share of each frame the burst is on")
    gap: Length | None = Field(None, ge=0, le=MAX_GAP, description="shroud gap, m (None: as set)")
    response: str | None = Field(
        None, description="response channel of the quick check (default: the active shroud accelerometer)"
    )
    seed: int | None = Field(None, ge=0, description="random seed of the burst signal")

    @field_validator("band", mode="before")
    @classmethod
    def _band_string(cls, v):
        # the CLI's "20 Hz:500 Hz", read by its one band parser
        if isinstance(v, str):
            return band_option(v, "band", allow_zero=False)
        return v

    @model_validator(mode="after")
    def _band(self):
        lo, hi = self.band
        if not (0 < lo < hi):
            raise ValueError(f"band {self.band} Hz must satisfy 0 < low < high")
        return self


class FrfTest(SineProcedure):
    """Broadband FRF test; see the module docstring."""

    name = "frf test"

    def __init__(self, cfg, params: FrfParameters | dict, out, **kwargs) -> None:
        super().__init__(cfg, out, **kwargs)
        self.params = params if isinstance(params, FrfParameters) else validate(FrfParameters, **params)

    def parameters_doc(self) -> dict:
        return self.params.model_dump()

    def startup(self) -> None:
        p = self.params
        if self.device is None:
            self.device = rig.open_device(self.cfg, self.backend, **self._device_opts)
        rate = rig.configure(self.device, self.cfg)
        if p.band[1] >= rate / 2:
            raise UserError(
                f"band {p.band[0]:g}..{p.band[1]:g} Hz: the top must be below half the "
                f"sample rate ({rate / 2:g} Hz)"
            )
        max_drive = self.cfg.safety.max_drive
        peak = p.level * (3.5 if p.signal == "burst" else 1.0)
        if peak > max_drive:
            raise UserError(
                f"level {p.level:g} V: the drive would reach about {peak:.3g} V, above "
                f"[safety] max_drive {max_drive:g} V"
            )
        self.drive: RandomDrive | PeriodicChirp
        if p.signal == "burst":
            burst = RandomDrive(
                rate,
                p.level,
                p.band,
                max_drive=max_drive,
                ramp_time=self.cfg.safety.ramp_time,
                burst_period=p.frame,
                burst_fraction=p.burst_fraction,
                seed=p.seed,
            )
            assert burst.burst_samples is not None  # burst_period is given: it is burst random
            self.drive, self.frame_samples = burst, burst.burst_samples
        else:
            chirp = PeriodicChirp(
                rate,
                p.level,
                p.band,
                period=p.frame,
                max_drive=max_drive,
                ramp_time=self.cfg.safety.ramp_time,
            )
            self.drive, self.frame_samples = chirp, chirp.period_samples
        self.monitor = rig.safety_monitor(self.cfg, self.device)
        self.specs = rig.channel_specs(self.device, self.cfg, rate)
        self.rate = rate
        self.sink = PointSink(len(self.specs), 1)
        self.stream = BlockStream(
            self.device,
            self.drive,
            sink=self.sink,
            safety=self.monitor,
            record_drive=True,
            abort_ramp_time=self.cfg.safety.abort_ramp_time,
            hurry=lambda: self.hurry_requested,
        )
        self.open_writer(rig.experiment_metadata(self.name, self.device, self.parameters_doc()))

    def _read(self) -> None:
        self.stream.read()
        if self.stop_requested:
            self.stream.finish(ramp_time=self.cfg.safety.abort_ramp_time)
            raise StopRequested(self.stop_reason)

    def execute(self) -> None:
        p = self.params
        gap = self.set_gap(p.gap)
        point = self.recording_writer().begin_point(
            params={
                "gap": gap,
                "signal": p.signal,
                "band_low": p.band[0],
                "band_high": p.band[1],
                "drive_level": p.level,
                "frame_samples": self.frame_samples,
                "averages": p.averages,
            },
            channels=self.specs,
        )
        self.point = point
        self.sink.begin(point)
        # the ramp, then one frame to reach the periodic state, then the averaged frames
        ramp = math.ceil(self.cfg.safety.ramp_time * self.rate)
        start = math.ceil((ramp + self.frame_samples) / self.frame_samples) * self.frame_samples
        total = start + p.averages * self.frame_samples
        self.emit("point", point=1, n_points=1, text=f"{p.signal} {p.band[0]:g}-{p.band[1]:g} Hz")
        while self.sink.total < total:
            before = self.sink.total
            self._read()
            self.emit(
                "recording" if before >= start else "settling",
                point=1,
                n_points=1,
                text=f"{max(0, before - start) / self.frame_samples:.0f}/{p.averages} frames",
            )
        self.stream.finish()
        self.record_start = start
        point.set_attrs(
            point_complete=True,
            record_start=start / self.rate,
            record_samples=p.averages * self.frame_samples,
        )
        point.end()
        self.point = None
        self.result.summary = {
            "record_start": start / self.rate,
            "frame_samples": self.frame_samples,
            "averages": p.averages,
        }

    def shutdown(self, status, reason) -> None:
        self.session = None
        stream = getattr(self, "stream", None)
        if status is Status.ABORTED and stream is not None and not stream._finished:
            # a KeyboardInterrupt from a script's own callback (a signal's stop already ramped,
            # recorded): the ramp to zero recorded in the point it cut; close() zeroes it anyway
            try:
                stream.finish(ramp_time=self.cfg.safety.abort_ramp_time)
            except BaseException:  # noqa: BLE001, S110 - the stream broke meanwhile: close() zeroes the drive
                pass
        super().shutdown(status, reason)


EDGE_BINS = 2  # frequency lines next to each band edge where the quick check looks for no peak


def quick_check(path, response: str | None = None, n_peaks: int = 5) -> dict:
    """H1 (response / force) over the averaged frames of an FRF test recording, its peaks in the
    band and their coherence: the very estimate ``rig analyze`` reports
    (:func:`rigtools.recording_analysis.frf_estimate.point_frf_estimate`: whole frames, no window)."""
    with open_recording(path) as rec:
        point = rec.points[0]
        prm = point.params
        if point.sample_rate is None:
            raise UserError(f"{path}: the channels of the FRF test have different sample rates")
        if response is None:
            response = next(
                name
                for name, ch in point.channels.items()
                if ch.quantity == "acceleration" and "passive" not in name.lower()
            )
        est, _, force_name, _, _ = point_frf_estimate(point, responses=[response])
        lo, hi = float(prm["band_low"]), float(prm["band_high"])
        h1_units = f"({point.channels[response].units})/({point.channels[force_name].units})"
    h1, coherence = est.h1[0], est.coherence[0]
    f = est.frequency_hz
    mag = np.abs(h1)
    # peaks strictly inside the band: the excitation's edges are steps of |H1|, not resonances
    inside = np.flatnonzero(
        (f >= lo + EDGE_BINS * est.resolution_hz) & (f <= hi - EDGE_BINS * est.resolution_hz)
    )
    idx, props = (
        find_peaks(mag[inside], prominence=0) if inside.size else (np.array([], int), {"prominences": []})
    )
    idx = inside[idx]
    order = idx[np.argsort(props["prominences"])[::-1][:n_peaks]]
    peaks = [
        {"frequency_hz": float(f[i]), "h1": float(mag[i]), "coherence": float(coherence[i])}
        for i in sorted(order)
    ]
    return {
        "response": response,
        "force": force_name,
        "h1_units": h1_units,
        "averages": est.n_averages,
        "resolution_hz": est.resolution_hz,
        "peaks": peaks,
        "mean_coherence_in_band": float(np.mean(coherence[(f >= lo) & (f <= hi)])),
    }
