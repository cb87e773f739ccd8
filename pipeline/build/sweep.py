"""The parallel runner of builds and closed-loop runs. A build's tasks, for every robot kind, run
in separate processes (joblib/loky by default, or an existing dask cluster), one solver per
process with BLAS and OpenMP threads at 1, or in this process with ``jobs = 1``.

A task is what a robot kind cuts its build into (a quadruped's warm-start chain along velocity,
a humanoid's motion): a picklable object whose ``run(use_cache, events)`` solves its entries,
caching each finished one on disk (:mod:`skatelib.pipeline.build.cache`) so that an interrupted build
resumes, and reports each start and finish as a small :class:`EntryEvent`. Outcomes come back
whole; the library file itself is written only at the end, atomically.

:func:`run_calls` runs other picklable jobs (the closed loop's) on the same workers: the same
thread limits, and each worker ends with the process that started it.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from functools import partial
from typing import Any, TypeVar

from skatelib.library.errors import ConfigError
from skatelib.pipeline.build.contract import BuildOptions, BuildTask, EntryEvent, EventSink, Outcome, ProgressFn
from skatelib.pipeline.build.profile import ENV, profile_to, span

THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


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


def run_task(task: BuildTask, use_cache: bool = True, events: EventSink | None = None,
             parent_pid: int | None = None, worker: bool = False, profile_dir: str | None = None) -> list[Outcome]:
    """Run one task (a module-level function, so worker processes can import it).

    ``events`` is an optional queue that receives an :class:`EntryEvent` as an entry starts and
    when it is finished; ``parent_pid``: the build process, whose death ends this worker
    (:func:`exit_with_parent`); ``worker``: this is a worker process of a cluster, whose BLAS and
    OpenMP threads this sets to 1 (loky workers start with them at 1; a serial build leaves the
    user's process as it is); ``profile_dir``: the build's profile folder in a worker ('' when it
    is not profiled; a reused worker may have been started under another build's), None: as it is.
    """
    exit_with_parent(parent_pid)
    if profile_dir is not None:
        profile_to(profile_dir)
    if worker:
        for var in THREAD_VARS:
            os.environ[var] = "1"
    with span("task", task=type(task).__name__):
        return list(task.run(use_cache, events))


def run_sweep(tasks: Sequence[BuildTask], options: BuildOptions | None = None,
              on_entry: ProgressFn | None = None) -> list[Outcome]:
    """Run every task and return all their outcomes (in no particular order).

    Args:
        options: ``jobs`` (worker processes of the loky backend; 1: this process), ``backend``
            (``"loky"``: this machine, or ``"dask"``: an existing cluster at ``scheduler``,
            ``tcp://host:port``), ``cache`` (reuse and store finished entries).
        on_entry: Called in the main process with an :class:`EntryEvent` as an entry starts (not
            with the dask backend) and as it finishes.
    """
    options = options or BuildOptions()
    jobs, use_cache = options.jobs, options.cache
    if options.backend == "dask":
        return _run_dask(tasks, options.scheduler, use_cache, on_entry)
    if options.backend != "loky":
        raise ValueError(f"unknown backend {options.backend!r}; use 'loky' or 'dask'")
    if jobs <= 1:
        direct = _Direct(on_entry)
        return [o for task in tasks for o in run_task(task, use_cache, direct)]
    return _run_loky(tasks, jobs, use_cache, on_entry)


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


def _run_loky(tasks: Sequence[BuildTask], jobs: int, use_cache: bool, on_entry: ProgressFn | None) -> list[Outcome]:
    from multiprocessing.managers import SyncManager

    manager = SyncManager()
    manager.start(initializer=exit_with_parent, initargs=(os.getpid(),))  # the queue's server dies with us too
    with manager:
        events = manager.Queue()
        stop = threading.Event()
        drain = threading.Thread(target=_drain, args=(events, on_entry, stop), daemon=True)
        drain.start()
        try:
            calls = [partial(run_task, task, use_cache, events, os.getpid(), profile_dir=os.environ.get(ENV, ""))
                     for task in tasks]
            outcomes = [o for task_out in in_workers(calls, jobs) for o in task_out]
        finally:
            stop.set()
            drain.join(timeout=5)
    return outcomes


def tls_settings() -> Any:
    """dask's security settings for a ``tls://`` scheduler (``distributed.security.Security`` from
    the dask config: ``distributed.comm.tls.ca-file``, ``.client.cert``, ``.client.key``).

    Raises:
        ConfigError: When the config names no CA file or no client certificate (key ``--scheduler``).
    """
    try:
        from distributed.security import Security
    except ImportError as e:
        raise ImportError("the dask backend needs dask.distributed: pip install 'skatelib[dask]'") from e
    security: Any = Security()  # its TLS attributes are set from the config at run time
    if not security.tls_ca_file or not security.tls_client_cert:
        raise ConfigError("--scheduler", "--scheduler",
                          "a tls:// scheduler needs dask's TLS settings: set distributed.comm.tls.ca-file, "
                          "distributed.comm.tls.client.cert and .client.key in the dask config (or "
                          "DASK_DISTRIBUTED__COMM__TLS__CA_FILE and the like)")
    return security


def _run_dask(tasks: Sequence[BuildTask], scheduler: Any, use_cache: bool,
              on_entry: ProgressFn | None) -> list[Outcome]:
    try:
        from distributed import Client, as_completed
    except ImportError as e:
        raise ImportError("the dask backend needs dask.distributed: pip install 'skatelib[dask]'") from e
    own = not isinstance(scheduler, Client)
    if own:  # a tls:// scheduler with the certificates of the dask config
        client = Client(scheduler, security=tls_settings() if str(scheduler).startswith("tls://") else None)
    else:
        client = scheduler
    try:
        futures = [client.submit(run_task, task, use_cache, None, None, True, pure=False) for task in tasks]
        outcomes: list[Outcome] = []
        for fut in as_completed(futures):
            task_out = fut.result()
            for o in task_out:
                if on_entry:
                    on_entry(o.event())
            outcomes.extend(task_out)
        return outcomes
    finally:
        if own:
            client.close()


T = TypeVar("T")


def call_in_worker(job: Callable[[], T], parent_pid: int | None, worker: bool = False) -> T:
    """``job()`` in a worker: one that ends with the process ``parent_pid`` (:func:`exit_with_parent`);
    ``worker``: a cluster's worker, whose BLAS and OpenMP threads this sets to 1."""
    exit_with_parent(parent_pid)
    if worker:
        for var in THREAD_VARS:
            os.environ[var] = "1"
    return job()


def in_workers(jobs: Sequence[Callable[[], T]], n_jobs: int, ordered: bool = False) -> Iterator[T]:
    """Each picklable no-argument callable's result as it finishes (``ordered``: in the order given),
    in ``min(n_jobs, len(jobs))`` loky workers that end with this process and start with BLAS and
    OpenMP at one thread (``Parallel`` names no backend of its own: one would drop that setting);
    the caller's process is left as it is."""
    from joblib import Parallel, delayed, parallel_config

    with parallel_config(backend="loky", inner_max_num_threads=1):
        yield from Parallel(n_jobs=min(n_jobs, len(jobs)), return_as="generator" if ordered else "generator_unordered")(
            delayed(call_in_worker)(job, os.getpid()) for job in jobs)


def run_calls(jobs: Sequence[Callable[[], T]], n_jobs: int, done: Callable[[int], None] | None = None) -> list[T]:
    """Each picklable no-argument callable's result, in the order given: in ``n_jobs`` workers
    (:func:`in_workers`), or in this process with ``n_jobs`` 1 or one job; ``done(n)`` hears how
    many results are in as they come (in the order given)."""
    out: list[T] = []
    results = (job() for job in jobs) if n_jobs <= 1 or len(jobs) <= 1 else in_workers(jobs, n_jobs, ordered=True)
    for r in results:
        out.append(r)
        if done is not None:
            done(len(out))
    return out
