"""VISA backend of :class:`rigtools.drivers.contracts.SignalSource`: a 33500-series waveform generator.

The generator makes the sine that the shaker amplifier amplifies. Commands are the common
33500-series SCPI set: ``FUNC SIN``, ``FREQ <Hz>``, ``VOLT:UNIT VPP``, ``VOLT <Vpp>``,
``VOLT:OFFS 0``, ``OUTP ON|OFF``, their queries, ``SYST:ERR?``, ``*IDN?``, ``*RST``, ``*CLS``.

* Terminations are explicit (``\\n`` both ways), the timeout is set at open.
* Limits (frequency range, maximum Vpp) are enforced before anything is sent
  (:class:`~rigtools.drivers.contracts.LimitExceeded`).
* After every setting the error queue is drained; an entry other than ``+0,"No error"`` raises
  :class:`~rigtools.drivers.contracts.SignalSourceError` naming the command and the instrument's text. A
  reply that is an error string where a value was expected raises the same. A VISA timeout raises
  :class:`~rigtools.drivers.contracts.AmplifierTimeout`.
* ``close()`` (and leaving ``with``) switches the output off first.

A simulated instrument ships as package data (:func:`simulator_path`); open it with
``WaveformGenerator(SIMULATED_RESOURCE, limits, backend=simulator_backend())``.
"""

from __future__ import annotations

import contextlib
import math
import re
from importlib import resources
from pathlib import Path

import pyvisa
from pyvisa.errors import VisaIOError
from pyvisa.resources import MessageBasedResource

from rigtools.drivers.contracts import (
    AmplifierTimeout,
    DriverUnavailable,
    LimitExceeded,
    SignalSource,
    SignalSourceError,
    SourceLimits,
    SourceState,
)
from rigtools.drivers.errors import one_line

SIMULATED_RESOURCE = "TCPIP0::192.168.1.20::inst0::INSTR"
TERMINATION = "\n"
MIN_AMPLITUDE_VPP = 0.001  # the 33500's smallest amplitude
SUPPORTED_MODELS = ("335", "336")  # 33500 and 33600 series share the command set
MAX_ERRORS_DRAINED = 32  # the instrument's queue holds at most 20
DEFAULT_LIMITS = SourceLimits()  # frozen: one instance is safe to share as a default

# SCPI error queue entry: <code>,"<text>"
_SCPI_ERROR = re.compile(r'^\s*([-+]?\d+)\s*,\s*"(.*)"\s*$')


def simulator_path() -> Path:
    """Path of the pyvisa-sim description of the generator shipped with the package."""
    return Path(str(resources.files("rigtools.drivers").joinpath("data/function_generator_sim.yaml")))


def simulator_backend() -> str:
    """The pyvisa backend string that opens the simulated generator (``"<yaml>@sim"``)."""
    return f"{simulator_path()}@sim"


def open_resource_manager(backend: str = "") -> pyvisa.ResourceManager:
    """A VISA resource manager, or one line saying why there is none.

    Parameters
    ----------
    backend
        ``""`` for the default VISA library, ``"@py"`` for pyvisa-py, ``"<yaml>@sim"`` for a
        simulator.

    Raises
    ------
    DriverUnavailable
        If no VISA implementation is installed (or the backend cannot be loaded).
    """
    try:
        return pyvisa.ResourceManager(backend)
    except Exception as exc:  # noqa: BLE001 - backends raise what they like (pyvisa-sim: yaml errors)
        first = one_line(exc, first=True)
        # pyvisa-sim puts the repr of a whole traceback after its own sentence: keep the sentence
        first = first.split(" 'Traceback")[0].strip()
        raise DriverUnavailable(
            f"no VISA library available ({first}); install NI-VISA or pyvisa-py, or use --backend sim"
        ) from None


def _parse_scpi_error(text: str) -> tuple[int, str] | None:
    """``(code, message)`` if ``text`` is an error-queue entry, else ``None``."""
    match = _SCPI_ERROR.match(text)
    if not match:
        return None
    return int(match.group(1)), match.group(2)


class WaveformGenerator(SignalSource):
    """A 33500-series generator behind VISA, with the rig's limits.

    Parameters
    ----------
    resource
        VISA resource name, e.g. ``"TCPIP0::192.168.1.20::inst0::INSTR"``.
    limits
        Frequency range and maximum amplitude (Vpp) allowed on this rig.
    backend
        pyvisa backend (see :func:`open_resource_manager`); ignored if ``resource_manager`` given.
    resource_manager
        An open :class:`pyvisa.ResourceManager` to use (not closed by :meth:`close`).
    timeout
        I/O timeout in seconds.

    Raises
    ------
    DriverUnavailable
        If there is no VISA library or the resource cannot be opened.
    SignalSourceError
        If the instrument does not identify itself as a waveform generator.
    """

    def __init__(
        self,
        resource: str,
        limits: SourceLimits = DEFAULT_LIMITS,
        *,
        backend: str = "",
        resource_manager: pyvisa.ResourceManager | None = None,
        timeout: float = 2.0,
    ) -> None:
        self.limits = limits
        self.resource = resource
        self._own_rm = resource_manager is None
        self._rm = resource_manager if resource_manager is not None else open_resource_manager(backend)
        try:
            inst = self._rm.open_resource(
                resource,
                read_termination=TERMINATION,
                write_termination=TERMINATION,
                timeout=round(timeout * 1000),
            )
        except VisaIOError as exc:
            self._close_rm()
            raise DriverUnavailable(f"cannot open VISA resource {resource!r}: {exc.abbreviation}") from None
        except ValueError as exc:  # malformed resource name
            self._close_rm()
            raise DriverUnavailable(f"cannot open VISA resource {resource!r}: {exc}") from None
        if not isinstance(inst, MessageBasedResource):  # SCPI needs a message-based session
            inst.close()
            self._close_rm()
            raise DriverUnavailable(f"VISA resource {resource!r} is not a message-based instrument")
        self._inst = inst
        self._closed = False
        try:
            self._idn = self._query("*IDN?")
            fields = [f.strip() for f in self._idn.split(",")]
            if len(fields) < 4 or not fields[1].upper().startswith(SUPPORTED_MODELS):
                raise SignalSourceError(
                    f"{self._name()} is not a 33500/33600-series waveform generator "
                    f"(*IDN? answered {self._idn!r})"
                )
            self.errors()  # start from an empty queue
        except BaseException:
            self.close()
            raise

    # ------------------------------------------------------------------------- plumbing

    def _close_rm(self) -> None:
        if self._own_rm:
            with contextlib.suppress(Exception):  # best effort: the manager may be half open
                self._rm.close()

    def _query(self, command: str) -> str:
        """Send a query and return the reply; an error string as a reply raises."""
        try:
            reply = self._inst.query(command).strip()
        except VisaIOError as exc:
            raise self._io_error(command, exc) from None
        parsed = _parse_scpi_error(reply)
        if command != "SYST:ERR?" and (
            reply.upper().startswith("ERROR") or (parsed is not None and parsed[0] != 0)
        ):
            raise SignalSourceError(f"{self._name()}: {command!r} answered with an error: {reply}")
        return reply

    def _query_float(self, command: str) -> float:
        reply = self._query(command)
        try:
            return float(reply)
        except ValueError:
            raise SignalSourceError(f"{self._name()}: unexpected reply {reply!r} to {command!r}") from None

    def _send(self, command: str) -> None:
        """Send a setting and check the error queue; an instrument error raises."""
        try:
            self._inst.write(command)
        except VisaIOError as exc:
            raise self._io_error(command, exc) from None
        errors = self.errors()
        if errors:
            raise SignalSourceError(f"{self._name()}: {command!r} refused: {'; '.join(errors)}")

    def _io_error(self, command: str, exc: VisaIOError) -> Exception:
        if exc.error_code == pyvisa.constants.StatusCode.error_timeout:
            return AmplifierTimeout(f"{self._name()} did not answer {command!r} (VISA timeout)")
        return SignalSourceError(f"{self._name()}: {command!r} failed: {exc.abbreviation}")

    def _name(self) -> str:
        return f"signal source {self.resource}"

    # ------------------------------------------------------------------------ contract

    def identify(self) -> str:
        return self._idn

    def errors(self) -> list[str]:
        found: list[str] = []
        for _ in range(MAX_ERRORS_DRAINED):
            reply = self._query("SYST:ERR?")
            parsed = _parse_scpi_error(reply)
            if parsed is None:
                found.append(f"unreadable error entry {reply!r}")
                break
            if parsed[0] == 0:
                break
            found.append(f"{parsed[0]:+d} {parsed[1]}")
        return found

    def reset(self) -> None:
        """``*RST``/``*CLS``, then sine, Vpp units, 0 V offset, smallest amplitude, output off."""
        self._send("*RST")
        self._send("*CLS")
        self._send("OUTP OFF")
        self._send("FUNC SIN")
        self._send("VOLT:UNIT VPP")
        self._send(f"VOLT:OFFS {0.0:.6f}")
        self._send(f"VOLT {MIN_AMPLITUDE_VPP:.6f}")

    def configure_sine(self, hz: float, vpp: float) -> None:
        """Sine of ``vpp`` volts peak-to-peak at ``hz`` with zero offset (output unchanged)."""
        self._check_frequency(hz)
        self._check_amplitude(vpp)
        self._send("FUNC SIN")
        self._send("VOLT:UNIT VPP")
        self._send(f"VOLT:OFFS {0.0:.6f}")
        self.set_frequency(hz)
        self.set_amplitude(vpp)

    def _check_frequency(self, hz: float) -> None:
        lim = self.limits
        if not (
            isinstance(hz, (int, float))
            and math.isfinite(hz)
            and lim.frequency_min <= hz <= lim.frequency_max
        ):
            raise LimitExceeded(
                f"frequency {hz!r} Hz is outside the allowed "
                f"{lim.frequency_min:g}..{lim.frequency_max:g} Hz; not sent"
            )

    def _check_amplitude(self, vpp: float) -> None:
        lim = self.limits
        if not (
            isinstance(vpp, (int, float))
            and math.isfinite(vpp)
            and MIN_AMPLITUDE_VPP <= vpp <= lim.amplitude_max_vpp
        ):
            raise LimitExceeded(
                f"amplitude {vpp!r} Vpp is outside the allowed "
                f"{MIN_AMPLITUDE_VPP:g}..{lim.amplitude_max_vpp:g} Vpp; not sent"
            )

    def set_frequency(self, hz: float) -> None:
        self._check_frequency(hz)
        self._send(f"FREQ {hz:.6f}")

    def set_amplitude(self, vpp: float) -> None:
        self._check_amplitude(vpp)
        self._send(f"VOLT {vpp:.6f}")

    def set_output(self, on: bool) -> None:
        self._send("OUTP ON" if on else "OUTP OFF")

    def state(self) -> SourceState:
        unit = self._query("VOLT:UNIT?").upper()
        if unit != "VPP":
            raise SignalSourceError(f"{self._name()}: amplitude unit is {unit}, expected VPP")
        output = self._query("OUTP?").upper()
        if output not in ("0", "1", "ON", "OFF"):
            raise SignalSourceError(f"{self._name()}: unexpected reply {output!r} to 'OUTP?'")
        return SourceState(
            function=self._query("FUNC?").upper(),
            frequency=self._query_float("FREQ?"),
            amplitude_vpp=self._query_float("VOLT?"),
            offset=self._query_float("VOLT:OFFS?"),
            output_on=output in ("1", "ON"),
        )

    def close(self) -> None:
        """Output off (best effort), then release the instrument. Idempotent."""
        if getattr(self, "_closed", True):
            return
        self._closed = True
        with contextlib.suppress(Exception):  # the instrument may be gone; closing must still happen
            self._inst.write("OUTP OFF")
        try:
            self._inst.close()
        finally:
            self._close_rm()
