"""Orchestration: rig configuration, experiment procedures, HDF5 recordings, CLI, reports.

The distribution installs one import name, ``rigtools``; the repository's ``drivers/``, ``sim/`` and
``analysis/`` folders install as ``rigtools.drivers``, ``rigtools.sim`` and ``rigtools.analysis``.
"""

from pathlib import Path

__version__ = "0.1.0"

_here = Path(__file__).parent
if not (_here / "sim").is_dir() and (_here.parent / "sim" / "__init__.py").is_file():
    # A source checkout imported directly (from the repository's root, ``python -m pytest`` or
    # ``python -m rigtools``): reach the sibling folders as they are installed, as rigtools.*.
    from rigtools._checkout import install_sibling_finder

    install_sibling_finder(_here.parent)


def __getattr__(name: str):
    # rigtools.open_recording (issue 4), imported lazily so `import rigtools` stays light
    if name == "open_recording":
        from rigtools.recording import open_recording

        return open_recording
    if name == "continuation":  # issue 22: branches of periodic orbits
        from rigtools.branches import continuation

        return continuation
    raise AttributeError(f"module 'rigtools' has no attribute {name!r}")
