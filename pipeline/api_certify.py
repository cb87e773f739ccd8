"""``skatelib certify`` as a Python function (:func:`certify`; ``skatelib.certify``), beside the
other commands' in :mod:`skatelib.pipeline.api`."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from skatelib.pipeline.api import Backend, PathLike, require_pipeline
from skatelib.pipeline.limits import MAX_JOBS, MAX_SEED, check_choice, check_range

if TYPE_CHECKING:
    from skatelib.library.certificate import Certificate
    from skatelib.proving.certify.ride import DrawResult


def certify(library: PathLike, entries: Sequence[str] | None = None, *, samples: int | None = None,  # noqa: PLR0913
            seed: int | None = None, config: PathLike | None = None, jobs: int = 2, backend: Backend = "loky",
            scheduler: Any = None, cache: bool = True,
            progress: Callable[[DrawResult, bool], None] | None = None) -> Certificate:
    """Certify a quadruped library's entries and store the certificate in it, as ``skatelib certify``
    does: each entry ridden ``samples`` times on the twin, each ride under model errors and a shove
    drawn from the ``[certify]`` table (docs/certify.md).

    Args:
        library: The library file (.h5) of a quadruped; the certificate is written into it.
        entries: Entry keys; every successful entry when None.
        samples: Rides per entry (1 to 100,000); the table's when None.
        seed: Seed of the draws (0 to 2**32 - 1); the table's when None.
        config: A quadruped config whose ``[certify]`` table to draw from; the library's own when None.
        jobs: Worker processes on this machine (1: this process).
        backend: ``loky`` (this machine) or ``dask`` (a cluster at ``scheduler``).
        scheduler: A dask scheduler's address or a ``distributed.Client`` (``backend="dask"``).
        cache: Reuse finished rides and store new ones (an interrupted run resumes).
        progress: Called with each ride's result and whether it came from the cache.

    Returns:
        The stored :class:`~skatelib.library.certificate.Certificate`: per entry the success rate,
        its 95 % Wilson interval, the failure modes and the shove margin.

    Raises:
        SkatelibError: Not a quadruped library, an unknown entry, a bad ``[certify]`` table or a
            library that cannot be rewritten, before any ride.
        ValueError: An argument out of its range (naming it).
        KeyboardInterrupt: Interrupted (finished rides are cached; the library is unchanged).
    """
    require_pipeline("skatelib.certify")
    check_range("skatelib.certify", "jobs", jobs, 1, MAX_JOBS)
    check_choice("skatelib.certify", "backend", backend, ("loky", "dask"))
    if samples is not None:
        check_range("skatelib.certify", "samples", samples, 1, 100_000)
    if seed is not None:
        check_range("skatelib.certify", "seed", seed, 0, MAX_SEED)
    from skatelib.pipeline.certify_run import CertifyOptions, certify_into, certify_plan, check_writable

    path = Path(library)
    spec, keys = certify_plan(path, entries, samples, seed, None if config is None else Path(config))
    options = CertifyOptions(jobs, backend, scheduler, cache)
    check_writable(path, options)
    return certify_into(path, spec, keys, options, progress)
