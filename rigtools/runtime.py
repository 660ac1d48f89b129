"""Process-level settings: signals, console encoding, BLAS threads, the numba cache.

Nothing here happens on import. ``rig`` calls these where its process starts work; library users
and worker processes call :func:`configure_process` themselves (it is cheap and idempotent).

* :func:`handle_stop_signals` turns SIGINT, SIGTERM and SIGHUP into :class:`rigtools.errors.Interrupted`
  (a :class:`KeyboardInterrupt`) in the main thread, so every Ctrl-C path (drive ramped to zero,
  recording ``aborted`` with the signal as its reason) covers ``kill``, ``timeout``, a job
  scheduler and a closed terminal too.
* :func:`configure_console` lets stdout/stderr print any text on any console ("m/s²" on an
  ASCII console or a plain C locale becomes ``m/s^2`` instead of a UnicodeEncodeError).
* :func:`configure_process` sets the BLAS thread count (small dense problems: threads only add
  overhead) and a writable numba cache directory.
* :func:`configure_allocator` gives back glibc's adaptive allocator behaviour to a process started
  with a ``MALLOC_*_`` tuning variable (a Dask nanny sets one): without it every numpy temporary
  of 128 KiB or more is a fresh mmap, page-faulted in and unmapped again (2x slower points).
* :func:`ensure_kernels_compiled` says "compiling the simulation kernels" on the first run
  instead of showing a frozen progress bar, and compiles them.
"""

from __future__ import annotations

import _thread
import codecs
import contextlib
import ctypes
import ctypes.util
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from rigtools.errors import Interrupted

if TYPE_CHECKING:
    from typing import Self

#: Signals handled like Ctrl-C (those this platform has).
STOP_SIGNALS: tuple[int, ...] = tuple(
    getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)
)

#: A repeated stop signal within this many seconds of the first is ignored, so the drive's ramp
#: to zero and the recording's close are not cut short by an impatient second Ctrl-C.
REPEAT_GRACE_S = 5.0

BLAS_THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")

APP_NAME = "shrouded-blade-rig"

#: Table width when stdout is a file or pipe (no terminal to ask).
WIDE_OUTPUT_COLUMNS = 160


# -- signals ---------------------------------------------------------------------------------
#: The last stop request of this process (None if none came). Code that catches exceptions
#: broadly (pydantic building a schema wraps any exception raised inside it, the signal's too)
#: can still tell that the run was stopped by a signal.
last_stop: Interrupted | None = None


class StopRequests:
    """Within the block, SIGINT/SIGTERM/SIGHUP raise :class:`rigtools.errors.Interrupted`.

    The exception is raised in the main thread between two Python byte codes (a compiled
    kernel finishes its block first). Inside :meth:`protected` a stop request is held until the
    block is done (a point being written is never cut in half), then raised. A second signal
    within :data:`REPEAT_GRACE_S` of the first is ignored so clean-up (drive to zero, file
    closed) completes; SIGKILL still ends anything. The previous handlers are restored on exit.
    Outside the main thread nothing is installed.

    Examples
    --------
    A SIGTERM that arrives while point 2 is being written: the point is finished, then the
    stop is raised (here the process sends the signal to itself, as ``kill`` would):

    >>> import os, signal
    >>> from rigtools.errors import Interrupted
    >>> written = []
    >>> try:
    ...     with StopRequests() as stops:
    ...         for point in (1, 2, 3):
    ...             with stops.protected():
    ...                 if point == 2:
    ...                     os.kill(os.getpid(), signal.SIGTERM)
    ...                 written.append(point)
    ... except Interrupted as stop:
    ...     print(stop.signal_name, stop.exit_code)
    SIGTERM 143
    >>> written
    [1, 2]
    """

    def __init__(self, signals: tuple[int, ...] = STOP_SIGNALS, *, ignore_after_stop: bool = False) -> None:
        self.signals = signals
        self.ignore_after_stop = ignore_after_stop
        self.first: float | None = None
        self._previous: dict[int, Any] = {}
        self._depth = 0
        self._held: Interrupted | None = None
        self._previous_hook = sys.unraisablehook
        self._reporting = False

    def __enter__(self) -> Self:
        if threading.current_thread() is threading.main_thread():
            for sig in self.signals:
                self._previous[sig] = signal.signal(sig, self._handler)
            self._previous_hook = sys.unraisablehook
            sys.unraisablehook = self._unraisable
        return self

    def __exit__(self, *exc: object) -> None:
        # after a stop, a process about to exit ignores further stop signals (a Ctrl-C then a
        # kill 30 ms later, as a scheduler sends): its exit status stays the first one's, not
        # a death by the second; otherwise the previous handlers come back
        stopped = self.ignore_after_stop and self.first is not None
        for sig, old in self._previous.items():
            with contextlib.suppress(Exception):
                signal.signal(sig, signal.SIG_IGN if stopped else old if old is not None else signal.SIG_DFL)
        if self._previous:
            sys.unraisablehook = self._previous_hook
        self._previous.clear()

    def _unraisable(self, unraisable: Any) -> None:
        """A stop raised where Python can only report it (a C library's callback: numba's
        compiler calls back into Python through ctypes while it loads kernels; a ``__del__``)
        is not lost: it is delivered again once this thread has left that code."""
        stop = unraisable.exc_value
        if not isinstance(stop, Interrupted):
            self._previous_hook(unraisable)
            return
        self.first = None  # not a repeat: the same request, delivered again
        self._reporting = True
        try:
            _deliver_later(stop.signum)
        finally:
            self._reporting = False

    def _handler(self, signum: int, frame: Any) -> None:
        global last_stop
        if self._reporting:  # still inside _unraisable: raised there, it would be lost again
            _deliver_later(signum)
            return
        now = time.monotonic()
        if self.first is not None and now - self.first < REPEAT_GRACE_S:
            return
        self.first = now
        last_stop = Interrupted(signum)
        if self._depth:
            self._held = self._held or last_stop
            return
        raise last_stop

    @contextlib.contextmanager
    def protected(self) -> Iterator[None]:
        """Hold stop requests until the block is done, then raise the first one."""
        self._depth += 1
        try:
            yield
        finally:
            self._depth -= 1
        if not self._depth and self._held is not None:
            held, self._held = self._held, None
            raise held


def _deliver_later(signum: int, delay_s: float = 0.01) -> None:
    """Send ``signum`` to the main thread again after ``delay_s``, from another thread (raised
    from the main thread itself, it is handled at the main thread's next call: still inside the
    code that lost it); a wait in the main thread (``select``, ``sleep``) is interrupted by it."""
    main = threading.main_thread().ident

    def deliver() -> None:
        time.sleep(delay_s)
        if hasattr(signal, "pthread_kill") and main is not None:
            signal.pthread_kill(main, signum)
        else:  # Windows: the handler runs at the main thread's next bytecode
            _thread.interrupt_main(signal.Signals(signum))

    threading.Thread(target=deliver, name="stop-request", daemon=True).start()


def handle_stop_signals(
    signals: tuple[int, ...] = STOP_SIGNALS, *, ignore_after_stop: bool = False
) -> StopRequests:
    """:class:`StopRequests` for ``signals`` (what ``rig`` installs around every command, with
    ``ignore_after_stop``: once stopped, the exiting process ignores the next stop signals)."""
    return StopRequests(signals, ignore_after_stop=ignore_after_stop)


# -- console ---------------------------------------------------------------------------------
#: ASCII spellings of the non-ASCII characters the toolkit prints (units, arrows, signs), used
#: where the console's encoding lacks them; anything else is escaped (``\\xb2``-style).
ASCII_SPELLINGS = {
    "\u00b2": "^2",
    "\u00b3": "^3",
    "\u00b0": " deg",
    "\u00b5": "u",
    "\u03bc": "u",
    "\u00b7": "*",
    "\u00d7": "x",
    "\u00b1": "+/-",
    "\u2212": "-",
    "\u2013": "-",
    "\u2014": "--",
    "\u2192": "->",
    "\u2190": "<-",
    "\u2264": "<=",
    "\u2265": ">=",
    "\u2248": "~",
    "\u2260": "!=",
    "\u2026": "...",
    "\u2018": "'",
    "\u2019": "'",
    "\u201c": '"',
    "\u201d": '"',
    "\u03a9": "Ohm",
    "\u221a": "sqrt",
    "\u00bd": "1/2",
    "\u2022": "*",
    "\u2502": "|",
    "\u2500": "-",
    "\u2501": "-",
    "\u2588": "#",
    "\u2591": ".",
    "\u2593": "#",
    "\u2714": "ok",
    "\u2718": "x",
}
CONSOLE_ERRORS = "rigtools.ascii"


def _ascii_fallback(exc: UnicodeError) -> tuple[str, int]:
    """Codec error handler: ASCII spellings where known, surrogate-escaped bytes back, else escapes."""
    if not isinstance(exc, UnicodeEncodeError):
        raise exc
    out = []
    for char in exc.object[exc.start : exc.end]:
        if char in ASCII_SPELLINGS:
            out.append(ASCII_SPELLINGS[char])
        elif 0xDC80 <= ord(char) <= 0xDCFF:  # a byte the locale could not decode (surrogateescape)
            out.append(f"\\x{ord(char) - 0xDC00:02x}")
        else:
            out.append(char.encode("ascii", "backslashreplace").decode("ascii"))
    return "".join(out), exc.end


codecs.register_error(CONSOLE_ERRORS, _ascii_fallback)


def configure_console(*streams: TextIO) -> None:
    """Let ``streams`` (default stdout and stderr) print any character.

    Characters the console's encoding cannot show are written in ASCII: units and signs by their
    usual spelling (``m/s²`` as ``m/s^2``, ``≥`` as ``>=``; :data:`ASCII_SPELLINGS`), anything
    else as a ``\\xb2``-style escape, instead of raising :class:`UnicodeEncodeError`. A plain C
    locale (stdout's errors ``surrogateescape``) included. Streams without ``reconfigure``
    (captured or replaced streams) are left alone.
    """
    for stream in streams or (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)
        if reconfigure is None or getattr(stream, "errors", None) not in ("strict", "surrogateescape", None):
            continue
        with contextlib.suppress(Exception):
            reconfigure(errors=CONSOLE_ERRORS)
    # Output into a file or pipe has no terminal width; rich would wrap tables at 80 columns and
    # cut channel names. Give it room unless the user set COLUMNS.
    with contextlib.suppress(Exception):
        if not sys.stdout.isatty() and "COLUMNS" not in os.environ:
            os.environ["COLUMNS"] = str(WIDE_OUTPUT_COLUMNS)


def silence_stdout() -> None:
    """After a closed pipe: point stdout at the null device so the exit flush cannot fail."""
    with contextlib.suppress(Exception):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)


# -- BLAS threads and numba cache --------------------------------------------------------------
@dataclass(frozen=True)
class ProcessSettings:
    """What :func:`configure_process` set (for logs and tests).

    Attributes
    ----------
    blas_threads
        The BLAS/OpenMP thread limit in force (None: left to the user's environment).
    blas_limited_live
        True when the limit was applied to already loaded BLAS libraries (threadpoolctl).
    numba_cache_dir
        The numba cache directory; None = numba's default beside the package sources.
    """

    blas_threads: int | None
    blas_limited_live: bool
    numba_cache_dir: str | None


_user_set_threads = {var for var in BLAS_THREAD_VARS if var in os.environ}


def user_cache_dir() -> Path:
    """The per-user cache directory of this toolkit (platform convention)."""
    if sys.platform == "win32":
        base = Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    elif sys.platform == "darwin":
        base = Path.home() / "Library" / "Caches"
    else:
        base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / APP_NAME


def _writable_dir(path: Path) -> bool:
    return path.is_dir() and os.access(path, os.W_OK | os.X_OK)


def numba_cache_dir() -> Path | None:
    """Where the numba kernels are cached.

    ``NUMBA_CACHE_DIR`` if the user set it; None (numba's default ``__pycache__`` beside the
    sources) if that is writable; otherwise ``<user cache>/numba`` (a read-only install, e.g.
    site-packages owned by root or a container image).
    """
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"])
    from rigtools import sim  # light: a package docstring

    pkg = Path(sim.__file__).resolve().parent
    pycache = pkg / "__pycache__"
    if _writable_dir(pycache) or (not pycache.exists() and _writable_dir(pkg)):
        return None
    return user_cache_dir() / "numba"


def configure_process(blas_threads: int | None = 1, *, numba_cache: bool = True) -> ProcessSettings:
    """Set the process-wide settings the toolkit's numerical work expects. Idempotent.

    Call it where a process starts work: ``rig`` does; a script or a worker process using
    :mod:`rigtools.sim` or :mod:`rigtools` directly should too.

    Parameters
    ----------
    blas_threads
        BLAS/OpenMP threads (default 1: the FE problems are small and dense, and studies run
        points in parallel processes). Sets ``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS`` and
        ``MKL_NUM_THREADS`` unless the user set them; if numpy is already loaded, the limit is
        applied to the loaded libraries with threadpoolctl. None leaves threads alone.
    numba_cache
        Make sure compiled kernels can be cached: if the package directory is read-only,
        ``NUMBA_CACHE_DIR`` is set to a per-user cache directory (numba's config too, if numba
        is already loaded).

    Returns
    -------
    ProcessSettings
    """
    live = False
    if blas_threads is not None and not _user_set_threads:
        value = str(int(blas_threads))
        for var in BLAS_THREAD_VARS:
            os.environ[var] = value
        if "numpy" in sys.modules:
            try:
                from threadpoolctl import threadpool_limits
            except ImportError:
                pass
            else:
                threadpool_limits(limits=int(blas_threads), user_api="blas")
                live = True
    elif _user_set_threads:
        blas_threads = None
    cache: Path | None = None
    if numba_cache:
        cache = numba_cache_dir()
        if cache is not None:
            with contextlib.suppress(OSError):
                cache.mkdir(parents=True, exist_ok=True)
            os.environ["NUMBA_CACHE_DIR"] = str(cache)
            numba_config: Any = sys.modules.get("numba.core.config")  # numba's settings, if loaded
            if numba_config is not None:
                numba_config.CACHE_DIR = str(cache)
    return ProcessSettings(blas_threads, live, str(cache) if cache is not None else None)


#: The environment of a study's worker process (:class:`rigtools.study_runner.StudyRunner`,
#: :class:`rigtools.worker_plugin.ProcessSettingsPlugin`): one BLAS and one numba thread each.
WORKER_ENV = {
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "NUMBA_NUM_THREADS": "1",
}


# -- the C allocator ------------------------------------------------------------------------
#: Variables that make glibc fix its mmap and trim thresholds (turning off the adaptive mmap
#: threshold) when present at the first malloc, whatever their value.
MALLOC_TUNING_VARS = (
    "MALLOC_TRIM_THRESHOLD_",
    "MALLOC_MMAP_THRESHOLD_",
    "MALLOC_TOP_PAD_",
    "MALLOC_MMAP_MAX_",
)
# glibc's mallopt parameters (malloc.h) and the largest mmap threshold its adaptive rule reaches
# on 64-bit (DEFAULT_MMAP_THRESHOLD_MAX: 4 * 1024 * 1024 * sizeof(long)); the adaptive rule keeps
# the trim threshold at twice the mmap threshold.
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
ADAPTIVE_MMAP_MAX = 32 * 1024 * 1024


def _glibc() -> Any:
    """The C library if it is glibc (has ``gnu_get_libc_version`` and ``mallopt``), else None."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        libc.gnu_get_libc_version  # noqa: B018 - probe: musl and others lack it
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return None
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return libc


def configure_allocator(force: bool = False) -> str:
    """Undo a fixed glibc mmap/trim threshold set through the environment (no-op off glibc).

    A ``MALLOC_TRIM_THRESHOLD_`` (or another :data:`MALLOC_TUNING_VARS`) present when the
    process started turned glibc's adaptive mmap threshold off for good: every allocation of
    128 KiB or more is then a fresh mmap, zero-filled page by page and unmapped on free. The
    adaptive rule cannot be switched back on, so its steady state is set instead: mmap only
    above :data:`ADAPTIVE_MMAP_MAX` (32 MiB) and trim the heap above twice that.

    Parameters
    ----------
    force
        Set those thresholds even if no tuning variable is in the environment (the adaptive rule
        is then replaced by its steady state).

    Returns
    -------
    str
        What was done: ``"adaptive"`` (nothing to undo), ``"mallopt"`` (thresholds set),
        ``"not glibc"``, or ``"mallopt failed"``.
    """
    if not force and not any(var in os.environ for var in MALLOC_TUNING_VARS):
        return "adaptive"
    libc = _glibc()
    if libc is None:
        return "not glibc"
    ok = libc.mallopt(_M_MMAP_THRESHOLD, ADAPTIVE_MMAP_MAX) == 1
    ok = libc.mallopt(_M_TRIM_THRESHOLD, 2 * ADAPTIVE_MMAP_MAX) == 1 and ok
    return "mallopt" if ok else "mallopt failed"


@contextlib.contextmanager
def without_malloc_tuning() -> Iterator[None]:
    """Within the block, no :data:`MALLOC_TUNING_VARS` in ``os.environ``; restored as found on exit.

    Child processes started inside (Dask's nanny spawning workers) then keep glibc's adaptive
    allocator, and a variable such a nanny writes into this process's environment does not leak
    into later subprocesses.
    """
    saved = {var: os.environ.pop(var) for var in MALLOC_TUNING_VARS if var in os.environ}
    try:
        yield
    finally:
        for var in MALLOC_TUNING_VARS:
            os.environ.pop(var, None)
        os.environ.update(saved)


# -- first-run kernel compilation --------------------------------------------------------------
def _dispatchers(module: Any) -> list[Any]:
    from numba.core.dispatcher import Dispatcher

    return [
        obj
        for obj in vars(module).values()
        if isinstance(obj, Dispatcher)
        and getattr(obj, "_cache", None) is not None
        and obj.__module__ == module.__name__
    ]


def _is_cached(dispatcher: Any) -> bool:
    """True if numba's cache index of ``dispatcher`` is fresh and has an entry."""
    try:
        return bool(dispatcher._cache._cache_file._load_index())
    except Exception:  # noqa: BLE001 - numba internals changed: say "not cached" (costs a message)
        return False


def _index_exists(dispatcher: Any) -> bool:
    try:
        return os.path.exists(dispatcher._cache._cache_file._index_path)
    except Exception:  # noqa: BLE001 - numba internals changed: say "no index"
        return False


def kernels_cached(module_name: str = "rigtools.sim.impact_kernel") -> bool:
    """True if the numba kernels of ``module_name`` are in numba's on-disk cache.

    A kernel counts once an index file exists for it that matches the current source (numba
    drops an index whose source file changed). Kernels never compiled through that module's
    entry points have no index and are not counted; at least one must be cached.
    """
    import importlib

    module = importlib.import_module(module_name)
    found = [d for d in _dispatchers(module) if _index_exists(d)]
    return bool(found) and all(_is_cached(d) for d in found)


def _warm_up_vibro_impact() -> None:
    """Run the vibro-impact kernels once on a two-mode system: compiles (and caches) them with
    the argument types every caller uses (float64 arrays, float scalars, int law code)."""
    import numpy as np

    from rigtools.sim.params import ContactParams, DampingParams
    from rigtools.sim.reduction import ReducedSystem
    from rigtools.sim.vibro_impact import VibroImpactStepper

    omega = 2 * np.pi * np.array([50.0, 55.0])
    system = ReducedSystem(
        omega=omega,
        zeta=np.array([0.01, 0.01]),
        shapes=np.array([[1.0, 0.0], [0.0, 1.0], [0.5, 0.0]]),
        blade=np.array([0, 1]),
        contact=ContactParams(gap=1e-4, stiffness=1e6, damping=1.0),
        damping=DampingParams(),
    )
    u = 10.0 * np.sin(2 * np.pi * 50.0 * 1e-4 * np.arange(1, 201))
    VibroImpactStepper(system, 1e-4).step(u)


def _warm_up_simulated_rig() -> None:
    """Run the simulated rig's shaker/test-article propagator once on a two-state system, with
    the argument types :class:`rigtools.drivers.simulated.SimulatedRig` passes (complex128 modal data)."""
    import numpy as np

    from rigtools.sim import rig_physics

    n, m = 2, len(rig_physics.SIGNALS)
    c = np.full(n, 0.5 + 0.1j)
    rig_physics._propagate(
        c.copy(),
        c.copy(),
        c.copy(),
        c.copy(),
        c.copy(),
        np.ones((m, n), dtype=complex),
        np.zeros(m),
        np.zeros(n, dtype=complex),
        np.zeros(1),
        np.ones(8),
        np.empty((m, 8)),
    )


#: Module -> (what compiles its kernels, first-run compile time in s measured on the 2-core CI
#: machine under load: 4 s and 3.5 s).
KERNELS: dict[str, tuple[Callable[[], None], float]] = {
    "rigtools.sim.impact_kernel": (_warm_up_vibro_impact, 5.0),
    "rigtools.sim.rig_physics": (_warm_up_simulated_rig, 4.0),
}


def ensure_kernels_compiled(
    console: Any = None, modules: tuple[str, ...] = ("rigtools.sim.impact_kernel",)
) -> bool:
    """Compile the numba kernels of ``modules`` now if numba has not cached them, saying so.

    Call it before a progress bar starts on work that runs compiled kernels, so the first run
    prints "compiling the simulation kernels (first run only, ~5 s)" instead of a frozen bar:
    ``rig simulate`` and ``rig study`` with the default; ``rig acquire --simulated`` with
    ``modules=("rigtools.sim.impact_kernel", "rigtools.sim.rig_physics")``.

    Parameters
    ----------
    console
        A :class:`rich.console.Console` (``.print``), or a text stream (``.write``); default
        ``sys.stderr``. Nothing is printed when the kernels are cached.
    modules
        Modules of :data:`KERNELS` whose kernels are needed.

    Returns
    -------
    bool
        True if kernels were compiled now, False if all were already cached.
    """
    configure_process(blas_threads=None)
    missing = [name for name in modules if not kernels_cached(name)]
    if not missing:
        return False
    seconds = sum(KERNELS[name][1] for name in missing)
    line = f"compiling the simulation kernels (first run only, ~{seconds:.0f} s)"
    if console is None:
        console = sys.stderr
    if hasattr(console, "print") and not hasattr(console, "write"):
        console.print(line)
    else:
        with contextlib.suppress(OSError, ValueError):
            console.write(line + "\n")
            console.flush()
    for name in missing:
        KERNELS[name][0]()
    return True
