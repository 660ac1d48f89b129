"""One BLAS thread inside the model's solvers, whatever the calling process set.

The FE problems are banded or small and dense: BLAS threads only add overhead there, and on a busy
machine make a build erratic (issue 20: 1.9 s instead of 0.39 s at 200 elements). The caller's
own setting is restored when the solver returns.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

_controller: Any = None


@contextlib.contextmanager
def single_blas_thread() -> Iterator[None]:
    """Within the block, the loaded BLAS libraries use one thread (threadpoolctl)."""
    global _controller
    if _controller is None:
        from threadpoolctl import ThreadpoolController

        _controller = ThreadpoolController()  # finds the loaded libraries once (1.5 ms)
    with _controller.limit(limits=1, user_api="blas"):
        yield
