"""What every sine procedure shares (dwell, stepped sine, rig study, and the FRF and tap tests
built on it): the force-control parameters and :class:`SineProcedure`, which opens the rig and
the recording."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field

from rigtools.errors import TargetNotReached, UserError
from rigtools.procedures import rig
from rigtools.procedures.base import (
    Procedure,
    ProcedureResult,
    ProgressEvent,
    Status,
    mark_end_status,
)
from rigtools.procedures.session import SineSession
from rigtools.quantity_fields import Time, VoltageAmplitude
from rigtools.recording import PointWriter, RecordingWriter


class ControlParameters(BaseModel):
    """Force-control settings (SI)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    tolerance: float = Field(0.005, gt=0, le=0.1, description="control tolerance (fraction of F0)")
    max_updates: int = Field(10, ge=1, le=100, description="force-control updates at most")
    initial_drive: VoltageAmplitude = Field(0.2, gt=0, le=10, description="first drive amplitude, V peak")
    max_step: float = Field(4.0, gt=1, le=20, description="largest drive ratio between two updates")
    margin: float = Field(0.8, gt=0, le=1, description="fraction of a warning level never planned past")
    control_ramp: Time = Field(0.05, gt=0, le=2, description="ramp of each update, s")


def target_not_reached(res: dict, force: float, fe: float, kept: str) -> TargetNotReached | None:
    """The error that ends a force-controlled run (exit 5, status ``failed``) when the rig's limits
    stopped a point short of its force target; ``None`` when the target was reached or the point
    only did not settle in time (that is reported by the point's ``settled``).

    Parameters
    ----------
    res
        The point's result (:meth:`SineSession.run_point`).
    force, fe
        The point's force target (N) and excitation frequency (Hz).
    kept
        What of the recording is kept, for the message (``"the point is kept"``).

    Returns
    -------
    TargetNotReached or None
        The error to raise once the point is written and the drive is at zero.
    """
    if not res.get("control_limited_by") or res.get("settled"):
        return None
    return TargetNotReached(
        f"--force {force:g} N cannot be reached at {fe:g} Hz: "
        f"{res['force_amplitude_measured']:.4g} N at the {res['control_limited_by']} limit "
        f"({res['drive_amplitude']:.4g} V); {kept}"
    )


class SineProcedure(Procedure):
    """Opens the device, the safety monitor, the recording and a :class:`SineSession`; ends
    them in ``shutdown`` with the status. Subclasses write ``execute``."""

    name = "sine"

    def __init__(
        self,
        cfg,
        out: str | Path,
        *,
        backend: str = "nidaq",
        overwrite: bool = False,
        device=None,
        pace: bool = False,
        faults=(),
        seed: int | None = None,
        progress: Callable[[ProgressEvent], None] | None = None,
        confirm_gap: Callable[[float, int], None] | None = None,
    ) -> None:
        super().__init__(progress)
        self.cfg, self.out, self.backend, self.overwrite = cfg, Path(out), backend, overwrite
        self.device, self._device_opts = device, {"pace": pace, "faults": faults, "seed": seed}
        self.confirm_gap = confirm_gap
        self.writer: RecordingWriter | None = None
        self.session: SineSession | None = None
        self.point: PointWriter | None = None
        self.result: ProcedureResult = ProcedureResult(Status.FAILED, file=str(self.out))

    def first_frequency(self) -> float:
        raise NotImplementedError

    def running_session(self) -> SineSession:
        """The session :meth:`startup` opened."""
        if self.session is None:
            raise RuntimeError(f"{self.name}: no session; startup() has not run")
        return self.session

    def recording_writer(self) -> RecordingWriter:
        """The recording :meth:`startup` opened."""
        if self.writer is None:
            raise RuntimeError(f"{self.name}: no recording; startup() has not run")
        return self.writer

    def record_seconds(self) -> float:
        return 2.0

    def parameters_doc(self) -> dict:
        return {}

    def startup(self) -> None:
        if self.device is None:
            self.device = rig.open_device(self.cfg, self.backend, **self._device_opts)
        rate = rig.configure(self.device, self.cfg)
        if self.first_frequency() >= rate / 2:
            raise UserError(
                f"fe = {self.first_frequency():g} Hz must be below half the sample rate ({rate / 2:g} Hz)"
            )
        monitor = rig.safety_monitor(self.cfg, self.device)
        self.specs = rig.channel_specs(self.device, self.cfg, rate)
        self.session = SineSession(
            self.device,
            self.cfg,
            monitor,
            self.first_frequency(),
            self,
            rig.force_row(self.device),
            ring_seconds=max(2.0, self.record_seconds() + 0.5),
        )
        self.open_writer(rig.experiment_metadata(self.name, self.device, self.parameters_doc()))

    def open_writer(self, experiment: dict) -> None:
        self.writer = RecordingWriter(
            self.out,
            backend=self.device.backend,
            rig=self.cfg.to_json(),
            experiment=experiment,
            overwrite=self.overwrite,
        )

    def set_gap(self, gap: float | None, index: int = 0) -> float:
        """The gap the point runs at: set directly on the simulated rig; on the real rig the
        operator sets it (``confirm_gap(gap, index)`` prompts and waits)."""
        if gap is None:
            return float(getattr(self.device, "gap", self.cfg.contact.gap))
        if hasattr(self.device, "set_gap"):
            self.device.set_gap(gap)
        elif self.confirm_gap is not None:
            self.confirm_gap(gap, index)
        return float(gap)

    def begin_point(self, params: dict) -> PointWriter:
        point = self.recording_writer().begin_point(params=params, channels=self.specs)
        self.point = point
        self.running_session().sink.begin(point)
        return point

    def end_point(self, attrs: dict) -> None:
        if self.point is None:
            raise RuntimeError(f"{self.name}: end_point() without begin_point()")
        self.point.set_attrs(point_complete=True, **attrs)
        self.point.end()
        self.running_session().sink.point = None
        self.point = None

    def shutdown(self, status: Status, reason: str) -> None:
        try:
            if self.session is not None and not self.session.stream._finished:
                if status is Status.FINISHED:
                    self.session.finish()
                elif status is Status.ABORTED:
                    # a KeyboardInterrupt from a script's own code (a signal already ramped, recorded):
                    # the ramp to zero recorded as a signal's is; device.close() below zeroes it anyway
                    try:
                        self.session.finish()
                    except BaseException:  # noqa: BLE001, S110 - the stream broke meanwhile: close() zeroes the drive
                        pass
        finally:
            try:
                if self.device is not None:
                    self.device.close()
            finally:
                if self.writer is not None:
                    if self.point is not None and not self.point.ended:
                        try:
                            self.point.set_attrs(point_complete=False)
                        except Exception:  # noqa: BLE001, S110 - the file still gets its status
                            pass
                    if status is Status.FINISHED:
                        self.writer.close()
                    else:
                        self.writer.abort(f"{status.value}: {reason}")
                    mark_end_status(self.out, status, reason)
