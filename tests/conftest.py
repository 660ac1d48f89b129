"""Shared test set-up.

The dense eigen-solves of the FE model are small (about 600 DOFs per blade); multithreaded BLAS
only adds contention on a loaded 2-core machine, so tests run BLAS on one thread. This must be
set before numpy is imported.
"""

import os

import pytest  # pytest does not import numpy: the BLAS settings below still come first

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")


@pytest.fixture
def chromium() -> str:
    """Path of a headless Chromium for the browser tests, the one rule for when there is none.

    Without Chromium on PATH the test is skipped, saying why and how to install it; with the
    environment variable ``RIGTOOLS_REQUIRE_BROWSER=1`` (``.ci/run`` sets it) the skip becomes a
    failure, so CI always checks reports in the real browser.
    """
    from rigtools.report.browser import BrowserUnavailable, find_chromium

    try:
        return find_chromium()
    except BrowserUnavailable as exc:
        if os.environ.get("RIGTOOLS_REQUIRE_BROWSER") == "1":
            pytest.fail(f"{exc} (RIGTOOLS_REQUIRE_BROWSER=1 asks for the real browser)")
        pytest.skip(f"{exc}; set RIGTOOLS_REQUIRE_BROWSER=1 to make this a failure")


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
