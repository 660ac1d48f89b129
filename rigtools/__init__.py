"""Orchestration: rig configuration, experiment procedures, HDF5 recordings, CLI, reports."""

__version__ = "0.1.0"


def __getattr__(name: str):
    # rigtools.open_recording (issue 4), imported lazily so `import rigtools` stays light
    if name == "open_recording":
        from rigtools.recording import open_recording

        return open_recording
    raise AttributeError(f"module 'rigtools' has no attribute {name!r}")
