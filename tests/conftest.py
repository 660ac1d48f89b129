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
