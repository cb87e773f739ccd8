"""``skatelib certify``'s work: every chosen entry ridden once per draw on the build's parallel
runner (loky workers on this machine or a dask cluster, BLAS at one thread), each ride's outcome
cached as it comes in (so an interrupted certification resumes where it stopped), then the
certificate made and stored in the library file (atomically, a format 1.6 root attribute).

A ride's cache key is the entry's digest, the draw's seed, the distributions (not N, not the
seed: a larger N reuses the rides of a smaller one) and the twin's code fingerprint
(:mod:`skatelib.proving.twin.fingerprint`): a certificate from other code or other
distributions never reuses a ride."""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from skatelib.library import schema
from skatelib.library.amend import amend_library, check_amendable
from skatelib.library.certificate import Certificate, entry_digest
from skatelib.library.errors import SkatelibError
from skatelib.pipeline.build import cache
from skatelib.proving.certify.ride import CertifyJob, DrawResult
from skatelib.proving.certify.spec import CertifySpec

FIELDS = ("passed", "modes", "shove_Ns", "reasons")


@dataclass(frozen=True)
class CertifyOptions:
    """Where the rides run: ``jobs`` loky workers (1: this process) or ``backend`` ``"dask"`` at
    ``scheduler`` (an address, or a ``distributed.Client``); ``cache``: reuse and store rides."""

    jobs: int = 2
    backend: str = "loky"
    scheduler: Any = None
    cache: bool = True


def ride_key(spec: CertifySpec, digest: str, seed: int, code: str) -> str:
    """The cache key of one ride (module docstring)."""
    distributions = {k: v for k, v in json.loads(spec.as_json()).items() if k not in ("samples", "seed")}
    return cache.cache_key("certify", digest, seed, distributions, code)


def _cached(path: Path, key: str, seed: int) -> DrawResult | None:
    hit = cache.load_cached(path, FIELDS)
    if not isinstance(hit, dict):
        return None
    return DrawResult(key, seed, bool(hit["passed"]), tuple(hit["modes"]), float(hit["shove_Ns"]), str(hit["reasons"]))


def certify(path: Path, spec: CertifySpec, keys: Sequence[str] | None, options: CertifyOptions,
            on_ride: Callable[[DrawResult, bool], None] | None = None) -> Certificate:
    """The certificate of ``keys`` (every successful entry by default) of the library at ``path``;
    ``on_ride(result, cached)`` hears each ride as it comes in.

    Raises:
        SkatelibError: Not a quadruped library, an unknown entry (naming the valid ones), MuJoCo
            missing; all before any ride.
        KeyboardInterrupt: Ctrl-C or SIGTERM (every finished ride is cached; the workers are stopped).
    """
    from skatelib.proving.certify.draw import draw_seeds
    from skatelib.proving.certify.stats import summarize
    from skatelib.proving.track import chosen_keys
    from skatelib.proving.twin.fingerprint import twin_fingerprint
    from skatelib.proving.twin.track import check_twin

    lib = check_twin(path, "")
    chosen = chosen_keys(lib, keys)
    if not chosen:
        raise SkatelibError(f"{path}: no entry of this library was solved: nothing to certify")
    code = twin_fingerprint()
    digests = {k: entry_digest(lib[k].arrays) for k in chosen}  # an unknown key raises EntryNotFound
    seeds = {k: draw_seeds(spec, k) for k in chosen}
    results: dict[tuple[str, int], DrawResult] = {}
    todo: list[tuple[CertifyJob, Path]] = []
    for k in chosen:
        for seed in seeds[k]:
            file = cache.cache_file(ride_key(spec, digests[k], seed, code))
            hit = _cached(file, k, seed) if options.cache else None
            if hit is None:
                todo.append((CertifyJob(str(path), k, spec, seed), file))
            else:
                results[(k, seed)] = hit
                if on_ride:
                    on_ride(hit, True)
    files = {(job.key, job.seed): file for job, file in todo}
    for r in run_unordered([job for job, _ in todo], options):
        if options.cache:
            cache.store(files[(r.key, r.seed)], {f: v for f, v in asdict(r).items() if f in FIELDS})
        results[(r.key, r.seed)] = r
        if on_ride:
            on_ride(r, False)
    entries = {k: summarize(k, [results[(k, s)] for s in seeds[k]], digests[k]) for k in chosen}
    return Certificate(spec.as_json(), code, entries)


def run_unordered(jobs: Sequence[CertifyJob], options: CertifyOptions) -> Iterator[DrawResult]:
    """Each job's result as it finishes: in this process (``jobs`` 1), loky workers that end with
    this process, or the dask cluster of ``options.scheduler``."""
    if not jobs:
        return
    if options.backend == "dask":
        yield from _dask(jobs, options.scheduler)
    elif options.jobs <= 1 or len(jobs) == 1:
        for job in jobs:
            yield job()
    else:
        from skatelib.pipeline.build.sweep import in_workers

        yield from in_workers(jobs, options.jobs)


def _dask(jobs: Sequence[CertifyJob], scheduler: Any) -> Iterator[DrawResult]:
    try:
        from distributed import Client, as_completed
    except ImportError as e:
        raise ImportError("the dask backend needs dask.distributed: pip install 'skatelib[dask]'") from e
    from skatelib.pipeline.build.sweep import call_in_worker, tls_settings

    own = not isinstance(scheduler, Client)
    client = Client(scheduler, security=tls_settings() if str(scheduler).startswith("tls://") else None) if own \
        else scheduler
    futures = [client.submit(call_in_worker, job, None, True, pure=False) for job in jobs]
    try:
        for fut in as_completed(futures):
            yield fut.result()
    finally:
        client.cancel(futures)
        if own:
            client.close()


def merged(old: Certificate | None, new: Certificate) -> Certificate:
    """``new`` with the entries of ``old`` it did not ride, when ``old`` was drawn from the same
    table (N and seed too) by the same code; ``new`` alone otherwise (an ``--entry`` run adds to a
    certificate, never mixes two)."""
    if old is None or (old.spec_json, old.code) != (new.spec_json, new.code):
        return new
    return Certificate(new.spec_json, new.code, {**old.entries, **new.entries})


def store_certificate(path: Path, certificate: Certificate) -> Path:
    """Write ``certificate`` into the library at ``path`` (the file rewritten atomically)."""
    return amend_library(path, {schema.A_CERTIFICATE: certificate.to_json()}, {})


def check_writable(path: Path, options: CertifyOptions) -> None:
    """Refuse, before any ride, a library file that cannot take its certificate, and a dask
    backend without a reachable scheduler.

    Raises:
        OutputError: The file cannot be rewritten.
        SkatelibError: ``--backend dask`` without ``--scheduler``, or one nothing listens at; a
            scheduler without the dask backend.
    """
    check_amendable(path)
    if options.backend != "dask" and options.scheduler is not None:
        raise SkatelibError("--scheduler names the dask cluster the rides go to: add --backend dask")
    if options.backend == "dask" and not hasattr(options.scheduler, "submit"):  # an address, not a Client
        if options.scheduler is None:
            raise SkatelibError("--backend dask needs --scheduler tcp://HOST:PORT")
        from skatelib.pipeline.build.preflight import check_scheduler

        check_scheduler(options.scheduler)


def certify_plan(path: Path, keys: Sequence[str] | None, samples: int | None, seed: int | None,
                 config: Path | None) -> tuple[CertifySpec, list[str]]:
    """What a certification of the library at ``path`` rides: the ``[certify]`` table of ``config``
    (the library's own config when None) with ``samples`` and ``seed`` when given, and ``keys`` (every
    successful entry when None)."""
    import dataclasses

    from skatelib.pipeline.certify_spec import config_spec, library_spec
    from skatelib.proving.track import chosen_keys
    from skatelib.proving.twin.track import check_twin

    lib = check_twin(path, "")  # a quadruped's library, MuJoCo there: before anything is printed or ridden
    spec = config_spec(config) if config is not None else library_spec(lib)
    spec = dataclasses.replace(spec, samples=spec.samples if samples is None else samples,
                               seed=spec.seed if seed is None else seed)
    return spec, chosen_keys(lib, keys)


def certify_into(path: Path, spec: CertifySpec, keys: Sequence[str], options: CertifyOptions,
                 on_ride: Callable[[DrawResult, bool], None] | None = None) -> Certificate:
    """Certify ``keys`` (:func:`certify`) and store the certificate in the library, merged with the
    one it holds when both were drawn alike by the same code; returns the stored certificate."""
    from skatelib.runtime import MotionLibrary

    cert = merged(MotionLibrary.open(path).certificate, certify(path, spec, keys, options, on_ride))
    store_certificate(path, cert)
    return cert

