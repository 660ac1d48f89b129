"""Shared test set-up.

The dense eigen-solves of the FE model are small (about 600 DOFs per blade); multithreaded BLAS
only adds contention on a loaded 2-core machine, so tests run BLAS on one thread. This must be
set before numpy is imported.
"""

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
