"""One runner for every model study: chains of points on a Dask client, results in point order.

A study is a list of independent *chains*: a carried-state sweep (up, down or both) is one chain,
each point of a from-rest study is a chain of its own, and a gap x F0 x fe map is one chain per
(gap, F0) pair sweeping fe. Every point of a chain is one task that takes the previous point's
run (its final state) as input, so points stream back as they finish while chains run side by
side on the workers.

* ``workers=None, scheduler=None`` (default): in-process, no Dask at all, the same point function;
* ``workers=N``: a :class:`distributed.LocalCluster` of N single-threaded worker processes here;
* ``scheduler="tcp://host:port"``: an existing cluster (dask-jobqueue users point it at SLURM).

Results come back in point order, bit-identical whatever the number of workers (each point is the
same computation on the same inputs, with single-threaded BLAS in every worker).

Workers compute as fast as this process. Dask's nanny starts workers with
``MALLOC_TRIM_THRESHOLD_`` in their environment (``distributed.nanny.pre-spawn-environ``), which
turns off glibc's adaptive mmap threshold: every numpy temporary of 128 KiB or more becomes a
fresh mmap (35x the page faults, 2x slower points). The LocalCluster started here spawns its
workers without it (and the nanny's copy in this process's environment is removed again); on any
cluster :class:`rigtools.worker_plugin.ProcessSettingsPlugin` sets single-threaded BLAS and the
allocator's thresholds (:func:`rigtools.runtime.configure_allocator`) on every worker start,
restarts included. A point whose
worker dies is resubmitted once, with the rest of its chain, and reported in ``retried``; a second
loss of the same point stops the study with :class:`StudyRunnerError` naming it (every earlier
point has been yielded). Chains are submitted a few at a time (``window``), so memory does not
grow with the number of points.
"""

from __future__ import annotations

import uuid
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from rigtools.errors import FaultError, UserError, one_line
from rigtools.runtime import MALLOC_TUNING_VARS, WORKER_ENV, without_malloc_tuning
from rigtools.sim.studies import MapPlan, PlannedPoint
from rigtools.sim.vibro_impact import run_harmonic

if TYPE_CHECKING:
    from typing import Self

    from distributed import Client, LocalCluster

Progress = Callable[[int, int, str], None]
#: How long ``--scheduler ADDRESS`` is tried before the study is refused (distributed retries a
#: refused connection until then).
SCHEDULER_CONNECT_TIMEOUT = "10s"


class StudyRunnerError(FaultError):
    """A study that could not go on (a point lost twice, a scheduler that cannot be reached)."""


@dataclass(frozen=True)
class RunOptions:
    """How each point runs (:func:`rigtools.sim.vibro_impact.run_harmonic` options, SI)."""

    record_duration: float = 1.0
    steps_per_period: int | None = None
    max_settle_time: float = 30.0


def run_point(
    system: Any,
    point: PlannedPoint,
    options: RunOptions,
    previous: Any = None,
    progress: Callable[[float, float], None] | None = None,
    force_harmonics: tuple | None = None,
) -> Any:
    """One settled point: the system at the point's gap, from ``previous.final_state`` if given.

    The function every executor runs (in-process or on a Dask worker); ``progress(simulated_s,
    at_most_s)`` while it settles (in-process only); ``force_harmonics``: the periodic force
    replacing ``F0 sin`` (:func:`rigtools.sim.vibro_impact.run_harmonic`)."""
    return run_harmonic(
        system.with_contact(gap=point.gap),
        point.fe,
        point.force,
        record_periods=max(1, round(options.record_duration * point.fe)),
        steps_per_period=options.steps_per_period,
        max_settle_time=options.max_settle_time,
        initial=None if previous is None else previous.final_state,
        progress=progress,
        force_harmonics=force_harmonics,
    )


def map_chains(
    gaps: Sequence[float],
    forces: Sequence[float],
    fes: Sequence[float],
    *,
    direction: str = "up",
    carry_state: bool = True,
) -> list[list[PlannedPoint]]:
    """The chains of a gap x F0 x fe map (:class:`rigtools.sim.studies.MapPlan`)."""
    return MapPlan(tuple(gaps), tuple(forces), tuple(fes), direction, carry_state).chains()


@dataclass
class RunReport:
    """What the runner did: points done, points retried after a worker died (index, reason)."""

    done: int = 0
    retried: list[tuple[int, str]] = field(default_factory=list)


class StudyRunner:
    """Run chains of points in-process or on Dask; see the module docstring.

    Parameters
    ----------
    workers
        Start a LocalCluster with this many worker processes (one thread each).
    scheduler
        Address of an existing Dask scheduler; excludes ``workers``.
    window
        Chains in flight at once (default: twice the number of workers, at least 2).
    """

    def __init__(
        self, workers: int | None = None, scheduler: str | None = None, window: int | None = None
    ) -> None:
        if workers is not None and scheduler is not None:
            raise UserError("--workers and --scheduler exclude each other: give one")
        if workers is not None and not 1 <= workers <= 256:
            raise UserError(f"--workers = {workers}: give 1 to 256 worker processes")
        self.workers = workers
        self.scheduler = scheduler
        self.window = window
        self.report = RunReport()
        self._client: Client | None = None
        self._cluster: LocalCluster | None = None

    # ------------------------------------------------------------------ life cycle
    def __enter__(self) -> Self:
        if self.workers is None and self.scheduler is None:
            return self
        import dask
        from distributed import Client, LocalCluster

        # A task whose worker dies fails at once; the runner resubmits it once and reports it.
        dask.config.set({"distributed.scheduler.allowed-failures": 0, "distributed.worker.daemon": False})
        try:
            if self.scheduler is not None:
                client = Client(self.scheduler, timeout=SCHEDULER_CONNECT_TIMEOUT)
            else:
                # the nanny reads its pre-spawn environment when created and writes it into
                # os.environ before each spawn: keep the allocator variable out of both
                no_malloc = {f"distributed.nanny.pre-spawn-environ.{var}": None for var in MALLOC_TUNING_VARS}
                with dask.config.set(no_malloc), without_malloc_tuning():
                    self._cluster = LocalCluster(
                        n_workers=self.workers,
                        threads_per_worker=1,
                        processes=True,
                        dashboard_address=None,
                        env=dict(WORKER_ENV),
                        silence_logs=40,
                    )
                client = Client(self._cluster)
        except (OSError, TimeoutError) as exc:
            self.close()
            raise StudyRunnerError(
                f"cannot reach the Dask scheduler {self.scheduler or 'LocalCluster'}: {one_line(exc, 200)}"
            ) from None
        self._client = client
        from rigtools.worker_plugin import ProcessSettingsPlugin

        client.register_plugin(ProcessSettingsPlugin(), name=ProcessSettingsPlugin.name)
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self._client is not None:
            self._client.close()
            self._client = None
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None

    @property
    def n_workers(self) -> int:
        if self._client is None:
            return 1
        return max(1, len(self._client.scheduler_info().get("workers", {})))

    @property
    def client(self) -> Client | None:
        """The Dask client (``None`` in-process)."""
        return self._client

    # ------------------------------------------------------------------ running
    def run(
        self,
        system: Any,
        chains: Sequence[Sequence[PlannedPoint]],
        options: RunOptions,
        progress: Progress | None = None,
        point_fn: Callable = run_point,
        settle_progress: Callable[[float, float], None] | None = None,
    ) -> Iterator[tuple[PlannedPoint, Any]]:
        """Yield ``(planned point, run)`` in point order as points finish.

        ``progress(done, total, text)`` after each point; ``settle_progress(simulated_s,
        at_most_s)`` while a point settles (in-process only: workers report points done).

        ``chains`` must be contiguous in point order (chain k holds the indices after chain
        k-1's), as :meth:`rigtools.sim.studies.StudyPlan.chains` and :func:`map_chains` make them.
        """
        total = sum(len(c) for c in chains)
        client = self._client
        if client is None:
            for chain in chains:
                previous = None
                for point in chain:
                    kw = {} if settle_progress is None else {"progress": settle_progress}
                    previous = point_fn(system, point, options, previous, **kw)
                    yield from self._done(point, previous, total, progress)
            return
        yield from self._run_dask(client, system, chains, options, total, progress, point_fn)

    def _done(self, point: PlannedPoint, run: Any, total: int, progress: Progress | None):
        self.report.done += 1
        if progress is not None:
            progress(self.report.done, total, f"point {point.index + 1} of {total}")
        yield point, run

    def _submit_chain(
        self,
        client: Client,
        system_f,
        chain: Sequence[PlannedPoint],
        options: RunOptions,
        previous: Any,
        point_fn: Callable,
        attempt: int,
        token: str,
    ) -> list:
        futures = []
        for point in chain:
            fut = client.submit(
                point_fn,
                system_f,
                point,
                options,
                previous,
                key=f"study-{token}-point-{point.index}-try{attempt}",
                pure=False,
            )
            futures.append(fut)
            previous = fut
        return futures

    def _run_dask(self, client: Client, system, chains, options, total, progress, point_fn):
        from distributed import CancelledError
        from distributed.scheduler import KilledWorker

        token = uuid.uuid4().hex[:12]  # keys unique to this run
        system_f = client.scatter(system, broadcast=True, hash=False)
        window = self.window or max(2, 2 * self.n_workers)
        pending = deque(chains)
        in_flight: deque[tuple[Sequence[PlannedPoint], list]] = deque()
        tried: set[int] = set()
        while pending or in_flight:
            while pending and len(in_flight) < window:
                chain = pending.popleft()
                in_flight.append(
                    (chain, self._submit_chain(client, system_f, chain, options, None, point_fn, 0, token))
                )
            chain, futures = in_flight.popleft()
            i, last = 0, None
            while i < len(chain):
                try:
                    run = futures[i].result()
                except (KilledWorker, CancelledError, OSError) as exc:
                    point = chain[i]
                    if point.index in tried:
                        raise StudyRunnerError(
                            f"point {point.index + 1} of {total} was lost twice with its "
                            f"worker ({type(exc).__name__}); earlier points are kept"
                        ) from None
                    tried.add(point.index)
                    self.report.retried.append((point.index, f"worker lost ({type(exc).__name__}); rerun"))
                    for f in futures[i:]:
                        f.cancel()
                    futures[i:] = self._submit_chain(
                        client, system_f, chain[i:], options, last, point_fn, 1, token
                    )
                    continue
                last = run
                futures[i] = None  # let the scheduler forget it
                yield from self._done(chain[i], run, total, progress)
                i += 1
