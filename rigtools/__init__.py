"""Orchestration: rig configuration, experiment procedures, HDF5 recordings, CLI, reports."""

__version__ = "0.1.0"
