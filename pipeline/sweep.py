"""Parallel sweeps of push-off solves into a motion library.

Entries of one stride count form a warm-start chain along velocity; chains run in separate
processes (joblib/loky by default, or an existing dask cluster), one IPOPT per process with BLAS
and OpenMP threads at 1. Every finished entry is cached on disk under a hash of its full spec, so
an interrupted build resumes without redoing it; the library file itself is written only at the
end, atomically.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from typing import Any

from skatelib.library import schema
from skatelib.pipeline.cache import cache_file, entry_key, load_cached, store
from skatelib.pipeline.kinds import BuildOptions
from skatelib.pipeline.quadruped.attempts import judge, solve_with_retries
from skatelib.pipeline.quadruped.config import QuadrupedConfig
from skatelib.pipeline.quadruped.pushoff import PushoffSpec, SolveResult, WarmStart

THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


@dataclass(frozen=True)
class EntryOutcome:
    """A finished sweep entry: the result (without warm-start data), attempts, cache origin, the
    independent physics measurements, the cache key it is stored under and any note for the user."""

    result: SolveResult
    attempts: int
    cached: bool
    physics: dict[str, float]
    cache_key: str = ""
    note: str = ""


@dataclass(frozen=True)
class EntryEvent:
    """What the progress display hears of an entry: it started (``done`` False) or finished, with
    its status. Small, so that no trajectory crosses the process boundary for it."""

    key: str
    done: bool
    status: str = ""
    success: bool = False
    cached: bool = False

    @staticmethod
    def finished(key: str, outcome: EntryOutcome) -> EntryEvent:
        return EntryEvent(key, True, outcome.result.status, outcome.result.success, outcome.cached)


ProgressFn = Callable[[EntryEvent], None]


@dataclass(frozen=True)
class Chain:
    """Entries of one stride count, solved in order of increasing velocity."""

    config: QuadrupedConfig
    n_strides: int
    velocities: tuple[float, ...]
    ipopt: tuple[tuple[str, Any], ...] = ()  # extra IPOPT options of every solve (e.g. its log level)


def chains_for(config: QuadrupedConfig, ipopt: tuple[tuple[str, Any], ...] = ()) -> list[Chain]:
    """One chain per stride count, longest-running (most strides) first for load balance."""
    v = tuple(sorted(config.sweep.velocities_mps))
    return [Chain(config, s, v, ipopt) for s in sorted(config.sweep.strides, reverse=True)]


# Bump when the retry ladder, the solve's post-processing or the cached payload changes: the key
# covers the problem itself (stage function, bounds, guess, options) but not that code.
def exit_with_parent(parent_pid: int | None, poll_s: float = 0.5) -> None:
    """In a worker process: exit at once when the build process ``parent_pid`` is gone (killed with
    SIGKILL, it cannot stop its workers itself). Started once per process; a no-op without a pid or
    when this process is not the build's child (a dask worker, for instance)."""
    global _WATCHDOG_STARTED
    if parent_pid is None or _WATCHDOG_STARTED or os.getppid() != parent_pid:
        return
    _WATCHDOG_STARTED = True

    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(poll_s)
        os._exit(1)  # reparented: the build is gone, and its work with it

    threading.Thread(target=watch, name="skatelib-parent-watchdog", daemon=True).start()


_WATCHDOG_STARTED = False  # per process: workers start one watchdog thread


def run_chain(chain: Chain, use_cache: bool = True, events: Any = None,
              parent_pid: int | None = None, worker: bool = False) -> list[EntryOutcome]:
    """Solve one warm-start chain (a module-level function, so worker processes can import it).

    ``events`` is an optional queue that receives an :class:`EntryEvent` as an entry starts and
    when it is finished; ``parent_pid``: the build process, whose death ends this worker
    (:func:`exit_with_parent`); ``worker``: this is a worker process of a cluster, whose BLAS and
    OpenMP threads this sets to 1 (loky workers start with them at 1; a serial build leaves the
    user's process as it is).
    """
    exit_with_parent(parent_pid)
    if worker:
        for var in THREAD_VARS:
            os.environ[var] = "1"
    out: list[EntryOutcome] = []
    warm: WarmStart | None = None
    warm_key: str | None = None
    for v in chain.velocities:
        use_warm = warm if chain.config.sweep.warm_start else None
        spec = PushoffSpec(chain.config, v, chain.n_strides, warm=use_warm, ipopt=chain.ipopt)
        key = entry_key(spec, warm_key if use_warm is not None else None)
        if events is not None:
            events.put(EntryEvent(schema.entry_key(v, chain.n_strides), done=False))
        path = cache_file(key)
        hit = load_cached(path) if use_cache else None
        note = hit if isinstance(hit, str) else ""
        if isinstance(hit, tuple):
            result, attempts = hit
        else:
            result, attempts = solve_with_retries(spec)
            if use_cache:
                store(path, result, attempts)
        if note:
            note += "; solved again"
        if result.success:
            warm, warm_key = result.warm, key
        judged, physics = judge(chain.config, result)
        outcome = EntryOutcome(replace(judged, warm=None), attempts, isinstance(hit, tuple), physics, key, note)
        out.append(outcome)
        if events is not None:
            events.put(EntryEvent.finished(schema.entry_key(v, chain.n_strides), outcome))
    return out


def run_sweep(config: QuadrupedConfig, options: BuildOptions | None = None, on_entry: ProgressFn | None = None,
              ipopt: tuple[tuple[str, Any], ...] = ()) -> list[EntryOutcome]:
    """Solve every (velocity, strides) of ``config.sweep`` and return the outcomes.

    Args:
        options: ``jobs`` (worker processes of the loky backend), ``backend`` (``"loky"``: this
            machine, or ``"dask"``: an existing cluster at ``scheduler``, ``tcp://host:port``),
            ``cache`` (reuse and store finished entries).
        on_entry: Called in the main process with an :class:`EntryEvent` as an entry starts (not
            with the dask backend) and as it finishes.
        ipopt: Extra IPOPT options of every solve (``(("print_level", 5),)`` shows its log).
    """
    options = options or BuildOptions()
    chains = chains_for(config, ipopt)
    jobs, use_cache = options.jobs, options.cache
    if options.backend == "dask":
        return _run_dask(chains, options.scheduler, use_cache, on_entry)
    if options.backend != "loky":
        raise ValueError(f"unknown backend {options.backend!r}; use 'loky' or 'dask'")
    if jobs <= 1:
        direct = _Direct(on_entry)
        return [o for c in chains for o in run_chain(c, use_cache, direct)]
    return _run_loky(chains, jobs, use_cache, on_entry)


class _Direct:
    """A queue that hands each event straight to the callback (a serial build)."""

    def __init__(self, on_entry: ProgressFn | None):
        self.on_entry = on_entry

    def put(self, event: EntryEvent) -> None:
        if self.on_entry:
            self.on_entry(event)


def _drain(events: Any, on_entry: ProgressFn | None, stop: threading.Event) -> None:
    import queue

    while not stop.is_set() or not events.empty():
        try:
            event = events.get(timeout=0.1)
        except (queue.Empty, EOFError, OSError):
            continue
        if on_entry:
            on_entry(event)


def _run_loky(chains: list[Chain], jobs: int, use_cache: bool,
              on_entry: ProgressFn | None) -> list[EntryOutcome]:
    from multiprocessing.managers import SyncManager

    from joblib import Parallel, delayed, parallel_config

    manager = SyncManager()
    manager.start(initializer=exit_with_parent, initargs=(os.getpid(),))  # the queue's server dies with us too
    with manager:
        events = manager.Queue()
        stop = threading.Event()
        drain = threading.Thread(target=_drain, args=(events, on_entry, stop), daemon=True)
        drain.start()
        try:
            # BLAS and OpenMP at 1 thread in the workers, from their start; the caller's process untouched.
            with parallel_config(backend="loky", inner_max_num_threads=1):
                results = Parallel(n_jobs=min(jobs, len(chains)), backend="loky", return_as="generator_unordered")(
                    delayed(run_chain)(c, use_cache, events, os.getpid()) for c in chains)
                outcomes = [o for chain_out in results for o in chain_out]
        finally:
            stop.set()
            drain.join(timeout=5)
    return outcomes


def _run_dask(chains: list[Chain], scheduler: Any, use_cache: bool,
              on_entry: ProgressFn | None) -> list[EntryOutcome]:
    try:
        from distributed import Client, as_completed
    except ImportError as e:
        raise ImportError("the dask backend needs dask.distributed: pip install 'skatelib[dask]'") from e
    own = not isinstance(scheduler, Client)
    client = Client(scheduler) if own else scheduler
    try:
        futures = [client.submit(run_chain, c, use_cache, None, None, True, pure=False) for c in chains]
        outcomes: list[EntryOutcome] = []
        for fut in as_completed(futures):
            chain_out = fut.result()
            for o in chain_out:
                if on_entry:
                    on_entry(EntryEvent.finished(schema.entry_key(o.result.target_velocity_mps, o.result.n_strides), o))
            outcomes.extend(chain_out)
        return outcomes
    finally:
        if own:
            client.close()


def ordered(outcomes: Iterable[EntryOutcome]) -> list[EntryOutcome]:
    """Outcomes sorted by strides, then velocity (the library's entry order)."""
    return sorted(outcomes, key=lambda o: (o.result.n_strides, o.result.target_velocity_mps))
