"""Set-up shared by the tests of ``rigtools``: recordings of the simulated rig that several test
files read, each made once per test process (``pytest-xdist --dist loadfile`` gives each worker
whole files: a worker that runs two files reading the same recording makes it once)."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import run_cli


class SimRecordings:
    """``recording(argv, name)``: the file ``rig ARGV --out NAME`` writes, made on first use and
    kept for the session; ``output(path)``: that run's ``(stdout, stderr)``.

    The files are shared between tests and test files: read them, never change them (copy one
    to change it)."""

    def __init__(self, tmp_path_factory: pytest.TempPathFactory) -> None:
        self._tmp = tmp_path_factory
        self._made: dict[tuple[tuple[str, ...], str], Path] = {}
        self._output: dict[Path, tuple[str, str]] = {}

    def __call__(self, argv: list[str], name: str = "recording.h5") -> Path:
        key = (tuple(str(a) for a in argv), name)
        if key not in self._made:
            path = self._tmp.mktemp("shared") / name
            code, out, err = run_cli([*key[0], "--out", path])
            assert code == 0, err
            self._made[key], self._output[path] = path, (out, err)
        return self._made[key]

    def output(self, path: Path) -> tuple[str, str]:
        return self._output[path]


@pytest.fixture(scope="session")
def sim_recording(tmp_path_factory: pytest.TempPathFactory) -> SimRecordings:
    """Recordings of the simulated rig shared by the session (:class:`SimRecordings`)."""
    return SimRecordings(tmp_path_factory)
