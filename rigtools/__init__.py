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


# The front door: name -> (module, attribute), each imported on first use (as scipy does), so
# `import rigtools` stays light and `import rigtools.sim` costs only sim. No name here may be
# that of a submodule (`rigtools.procedures` is a package): importing it would rebind the attribute.
_API: dict[str, tuple[str, str]] = {
    "load_rig": ("rigtools.config", "load_rig"),
    "dwell": ("rigtools.experiments", "dwell"),
    "stepped_sine": ("rigtools.experiments", "stepped_sine"),
    "acquire_study": ("rigtools.experiments", "acquire_study"),
    "frf_test": ("rigtools.experiments", "frf_test"),
    "tap_test": ("rigtools.experiments", "tap_test"),
    "control_based_continuation": ("rigtools.procedures.cbc_door", "control_based_continuation"),
    "phase_locked_loop": ("rigtools.phase_locked", "phase_locked_loop"),
    "RunResult": ("rigtools.procedures.result", "RunResult"),
    "PointResult": ("rigtools.procedures.result", "PointResult"),
    "open_recording": ("rigtools.recording", "open_recording"),
    "analyze_recording": ("rigtools.recording_analysis.dispatch", "analyze_recording"),
    "spectrum": ("rigtools.point_spectrum", "spectrum"),
    "Spectrum": ("rigtools.point_spectrum", "Spectrum"),
    "simulate_point": ("rigtools.model_point", "simulate_point"),
    "SimulatedPoint": ("rigtools.model_point", "SimulatedPoint"),
    "simulate_study": ("rigtools.simulated_study", "simulate_study"),
    "compare_with_model": ("rigtools.model_comparison", "compare_with_model"),
    "update_model": ("rigtools.model_update", "update_model"),
    "continuation": ("rigtools.branches", "continuation"),
    "UserError": ("rigtools.errors", "UserError"),
}
__all__ = list(_API)
# Old names kept working, with a DeprecationWarning on use: name -> (module, attribute, why).
_DEPRECATED: dict[str, tuple[str, str]] = {
    # `rig study` is the model's study (simulate_study): `rigtools.study` named the rig's
    "study": ("rigtools.experiments", "study"),
}


def __getattr__(name: str) -> object:
    if name in _API:
        import importlib

        module, attribute = _API[name]
        value = getattr(importlib.import_module(module), attribute)
        globals()[name] = value  # the next look-up is a plain attribute
        return value
    if name in _DEPRECATED:  # not cached: the function warns at each call
        import importlib

        module, attribute = _DEPRECATED[name]
        return getattr(importlib.import_module(module), attribute)
    raise AttributeError(f"module 'rigtools' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
