"""FRF sets: measured FRFs (an analyser's, imported from UFF 58) stored for ``rig analyze``.

An FRF set is one HDF5 file, text and numbers only:

==========================  ==================================================================
``/`` attributes            ``schema`` = ``"rigtools.frfset"``, ``schema_version`` = 1,
                            ``created`` (ISO UTC), ``kind`` (``accelerance``, ``mobility`` or
                            ``receptance``), ``reference`` (the excitation's name),
                            ``responses`` (JSON list of names), ``source`` (JSON object: file,
                            format, what the import assumed)
``/frequency``              (n_freq,) float64, Hz, uniform
``/frf_real``, ``/frf_imag``  (n_responses, n_freq) float64, SI (response units per N)
``/coherence``              (n_responses, n_freq) float64, NaN where the source had none
==========================  ==================================================================
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from rigtools.errors import UserError, one_line

SCHEMA = "rigtools.frfset"
SCHEMA_VERSION = 1
KINDS = ("accelerance", "mobility", "receptance")


@dataclass
class FRFSet:
    """FRFs of several responses over one reference on one frequency grid.

    Attributes
    ----------
    frequency_hz
        (n_freq,) uniform grid, Hz.
    frf
        (n_responses, n_freq) complex, SI units of ``kind``.
    coherence
        (n_responses, n_freq), NaN where unknown.
    responses, reference
        Names.
    kind
        ``"accelerance"``, ``"mobility"`` or ``"receptance"``.
    source
        Where the FRFs came from and what their import assumed.
    """

    frequency_hz: np.ndarray
    frf: np.ndarray
    coherence: np.ndarray
    responses: list[str]
    reference: str
    kind: str
    source: dict = field(default_factory=dict)
    created: str = ""


def write_frf_set(path: str | Path, frf_set: FRFSet, *, overwrite: bool = False) -> None:
    """Write ``frf_set`` to ``path`` whole or not at all (:func:`rigtools.derived_files.atomic_write`).

    Raises
    ------
    UserError
        ``path`` exists and ``overwrite`` is False, or is not a place rigtools writes.
    FaultError
        The write failed (disk full, ...), in one line; nothing is left behind.
    """
    import h5py

    from rigtools.derived_files import atomic_write

    path = Path(path)
    if path.exists() and not overwrite:
        raise UserError(f"{path} exists (give --overwrite to replace it)")
    if frf_set.kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {frf_set.kind!r}")

    def write(tmp: Path) -> None:
        with h5py.File(tmp, "w") as f:
            f.attrs.update(
                {
                    "schema": SCHEMA,
                    "schema_version": SCHEMA_VERSION,
                    "created": datetime.now(UTC).isoformat(),
                    "kind": frf_set.kind,
                    "reference": frf_set.reference,
                    "responses": json.dumps(list(frf_set.responses)),
                    "source": json.dumps(frf_set.source),
                }
            )
            h = np.atleast_2d(np.asarray(frf_set.frf, dtype=complex))
            f["frequency"] = np.asarray(frf_set.frequency_hz, dtype=float)
            f["frf_real"], f["frf_imag"] = h.real, h.imag
            f["coherence"] = np.atleast_2d(np.asarray(frf_set.coherence, dtype=float))

    atomic_write(path, write)


def is_frf_set(path: str | Path) -> bool:
    """True if ``path`` is an HDF5 file with the FRF-set schema."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            return f.attrs.get("schema") == SCHEMA
    except (OSError, ValueError):
        return False


def read_frf_set(path: str | Path) -> FRFSet:
    """Read an FRF set (one line :class:`UserError` if it is not one)."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            if f.attrs.get("schema") != SCHEMA:
                raise UserError(f"{path}: not an FRF set (schema {f.attrs.get('schema')!r})")
            if int(f.attrs["schema_version"]) > SCHEMA_VERSION:
                raise UserError(f"{path}: FRF set version {f.attrs['schema_version']}: upgrade rigtools")
            return FRFSet(
                frequency_hz=np.asarray(f["frequency"][:], dtype=float),
                frf=np.asarray(f["frf_real"][:]) + 1j * np.asarray(f["frf_imag"][:]),
                coherence=np.asarray(f["coherence"][:], dtype=float),
                responses=list(json.loads(f.attrs["responses"])),
                reference=str(f.attrs["reference"]),
                kind=str(f.attrs["kind"]),
                source=dict(json.loads(f.attrs.get("source", "{}"))),
                created=str(f.attrs.get("created", "")),
            )
    except (OSError, KeyError, ValueError) as exc:
        raise UserError(f"{path}: cannot read the FRF set ({one_line(exc, 200)})") from None
