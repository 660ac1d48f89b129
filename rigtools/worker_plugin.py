"""The Dask worker plugin that gives every worker the process settings of ``rig``.

Imported only where a Dask client is started (:class:`rigtools.study_runner.StudyRunner`), so an
in-process study does not load ``distributed``.
"""

from __future__ import annotations

import os
from typing import Any

from distributed.diagnostics.plugin import WorkerPlugin

from rigtools.runtime import MALLOC_TUNING_VARS, WORKER_ENV, configure_allocator, configure_process

#: What :class:`ProcessSettingsPlugin` did in this process (empty outside a worker).
WORKER_SETTINGS: dict[str, Any] = {}


class ProcessSettingsPlugin(WorkerPlugin):
    """The process settings of ``rig`` in every Dask worker, applied on each worker start.

    Single-threaded BLAS (environment and the loaded libraries, threadpoolctl), the numba cache
    (:func:`rigtools.runtime.configure_process`), glibc's allocator thresholds
    (:func:`rigtools.runtime.configure_allocator`: a worker started by a nanny has
    ``MALLOC_TRIM_THRESHOLD_`` set), and Dask's statistical profiler stopped: it samples the
    Python stack every 10 ms, sees only the compiled kernel of a point, and costs CPU. Registered with :meth:`distributed.Client.register_plugin`,
    so workers that join or restart later get it too (a one-off ``client.run`` would miss them).
    """

    name = "rigtools-process-settings"

    def setup(self, worker: Any) -> None:
        from threadpoolctl import threadpool_limits

        for key, value in WORKER_ENV.items():
            os.environ.setdefault(key, value)
        settings = configure_process()
        threadpool_limits(limits=1, user_api="blas")
        stopped = []
        for name in ("profile", "profile-cycle"):
            callback = getattr(worker, "periodic_callbacks", {}).pop(name, None)
            if callback is not None:
                callback.stop()
                stopped.append(name)
        WORKER_SETTINGS.update(
            profiler="stopped" if stopped else "off",
            blas_threads=1,
            numba_cache_dir=settings.numba_cache_dir,
            allocator=configure_allocator(),
            malloc_env={var: os.environ[var] for var in MALLOC_TUNING_VARS if var in os.environ},
        )


def worker_settings() -> dict[str, Any]:
    """:data:`WORKER_SETTINGS` of this process (run it on the workers with ``client.run``)."""
    return dict(WORKER_SETTINGS)
