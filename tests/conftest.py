"""Shared test set-up.

The dense eigen-solves of the FE model are small (about 600 DOFs per blade); multithreaded BLAS
only adds contention on a loaded 2-core machine, so tests run BLAS on one thread. This must be
set before numpy is imported.

What a test needs from outside the repository (a headless browser, the public measured data in
``../shared/data``, the ``h5dump`` tool) is found by one rule, :func:`missing`: absent, the test
is skipped saying what is missing and how to get it; with the environment variable that asks for
it set to 1 (``.ci/run`` sets all three) the skip becomes a failure, so CI never passes by
skipping.

========================== ============================================ =======================
fixture                    what                                         variable
========================== ============================================ =======================
``chromium``               a headless Chromium (report, live monitor)   RIGTOOLS_REQUIRE_BROWSER
``public_data``            a folder or file under ``../shared/data``    RIGTOOLS_REQUIRE_DATA
``h5dump``                 HDF5's command-line reader (hdf5-tools)      RIGTOOLS_REQUIRE_H5DUMP
========================== ============================================ =======================
"""

import os
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest  # pytest does not import numpy: the BLAS settings below still come first
from hypothesis import settings as _hypothesis_settings
from public_data import PUBLIC_DATA, missing

# CI runs the property tests on hypothesis's derandomized examples (the same every run, so a red CI
# is reproducible); a developer's run explores new ones (HYPOTHESIS_PROFILE unset). A case found
# either way is kept with @example beside its test.
_hypothesis_settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("HYPOTHESIS_PROFILE"):
    _hypothesis_settings.load_profile(os.environ["HYPOTHESIS_PROFILE"])

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")


@pytest.fixture
def chromium() -> str:
    """Path of a headless Chromium for the browser tests, the one rule for when there is none.

    Without Chromium on PATH the test is skipped, saying why and how to install it; with the
    environment variable ``RIGTOOLS_REQUIRE_BROWSER=1`` (``.ci/run`` sets it) the skip becomes a
    failure, so CI always checks reports in the real browser.
    """
    from headless_chromium import BrowserUnavailable, find_chromium

    try:
        return find_chromium()
    except BrowserUnavailable as exc:
        missing(str(exc), "RIGTOOLS_REQUIRE_BROWSER")


@pytest.fixture(scope="session")
def public_data() -> Callable[..., Path]:
    """``public_data("ufffiles-hammer", "dataset58_FRF.unv")``: the path of a public data set (a
    folder or a file under ``../shared/data``), the one rule for when it is absent.

    Absent (a user's clone has no ``../shared``), the test is skipped naming the path; with
    ``RIGTOOLS_REQUIRE_DATA=1`` (``.ci/run`` sets it) the skip becomes a failure.
    """

    def need(*parts: str) -> Path:
        path = PUBLIC_DATA.joinpath(*parts)
        if not path.exists():
            missing(f"public data {path} is absent (a clone without ../shared)", "RIGTOOLS_REQUIRE_DATA")
        return path

    return need


@pytest.fixture(scope="session")
def h5dump() -> str:
    """Path of HDF5's ``h5dump`` (Debian's hdf5-tools), the one rule for when it is missing:
    skipped, or a failure with ``RIGTOOLS_REQUIRE_H5DUMP=1`` (``.ci/run`` installs it and sets it)."""
    path = shutil.which("h5dump")
    if path is None:
        missing("h5dump is not installed (apt-get install hdf5-tools)", "RIGTOOLS_REQUIRE_H5DUMP")
    return path


@pytest.fixture(scope="session")
def fem_model():
    """``(rig config, rig model, FEM reduced system)`` of the calibrated default rig."""
    from rigtools.config import load_rig
    from rigtools.sim.reduction import reduced_system
    from rigtools.sim.rig_model import build_rig_model

    cfg = load_rig(None)
    params = cfg.to_params()
    rig = build_rig_model(params)
    return cfg, rig, reduced_system(params, "fem", rig_model=rig)


@pytest.fixture(scope="session")
def fem_frequency_branch(fem_model):
    """The FEM's period-1 branch at the paper's point, 55-80 Hz at 15 N and a 0.7 mm gap (its
    fold, its grazing corner; about 5 s, so computed once for every test that needs it)."""
    from rigtools.sim.continuation import continue_orbits

    return continue_orbits(fem_model[2], "fe", 55.0, 80.0, force=15.0, gap=0.7e-3)


@pytest.fixture(scope="session")
def burst_frf_test():
    """A burst-random FRF test of the simulated rig with impacts off (gap 50 mm; test article,
    seed 1): drive 0.5 V over 10 Hz-2 kHz (seed 2), on for 40 % of each 2 s period, 8 periods
    at 25.6 kHz; the response decays by e^-4 before a period ends. Recorded once for the tests
    of the analysis, the model update and the simulated rig that identify its modes.

    Returns ``(rig, fs, period, data)``: the :class:`rigtools.drivers.simulated.SimulatedRig`
    (its ``rig_model()`` is the test article's FEM), the sample rate, the period (s) and the
    (channels, 8 periods) samples in the default rig's input order (force first, active shroud
    acceleration second)."""
    from dataclasses import replace

    from rigtools.acquisition import BlockCollector, RandomDrive, acquire
    from rigtools.config import load_rig
    from rigtools.drivers.simulated import SimulatedRig

    cfg = load_rig(None)
    p = cfg.to_params()
    rig = SimulatedRig(
        replace(p, contact=replace(p.contact, gap=0.05)),
        cfg.shaker.to_params(),
        cfg.test_article.to_params(),
        seed=1,
        abort_ramp_time=cfg.safety.abort_ramp_time,
    )
    fs = rig.configure(cfg.daq.input_specs(), cfg.daq.output_spec(), 25600.0)
    period = 2.0
    drive = RandomDrive(
        fs,
        0.5,
        (10.0, 2000.0),
        max_drive=cfg.safety.max_drive,
        ramp_time=0.002,
        burst_period=period,
        burst_fraction=0.4,
        seed=2,
    )
    sink = BlockCollector()
    acquire(rig, drive, 8 * period, sink=sink)
    data = sink.data[:, : int(8 * period * fs)]
    data.flags.writeable = False  # shared between tests
    return rig, fs, period, data
