"""``skatelib build`` for every robot kind: config -> the kind's tasks -> parallel sweep (cache,
progress) -> verified, atomically written motion library.

The kind (:class:`skatelib.pipeline.kinds.RobotKind`) supplies what differs: ``check(cfg, opts)``
refuses its own options before anything runs, ``announce(cfg)``, ``tasks(cfg, ipopt)`` cuts the
build into picklable tasks (:class:`skatelib.pipeline.build.contract.BuildTask`), ``prepare(cfg,
opts)`` readies what the workers share, ``write(cfg, out, outcomes, opts)`` writes the library and
``summary(written)`` prints its table. The sweep, the entry cache, the progress events
(``on_entry``: the command line draws them as its progress bar, :mod:`skatelib.pipeline.cli.build_run`),
interruption and the exit code are the same for every kind; nothing here prints.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from skatelib.library.errors import SkatelibError
from skatelib.pipeline.build.contract import BuildOptions, Outcome, ProgressFn, Written
from skatelib.pipeline.build.profile import span
from skatelib.pipeline.build.sweep import run_sweep
from skatelib.pipeline.kinds import KindConfig, kind_of


@dataclass(frozen=True)
class BuildReport:
    """What a build produced: what the kind wrote (the file, its entries' outcomes in the library's
    order and what else it found: the quadruped's frontier, when asked) and the wall time."""

    written: Written
    wall_time_s: float

    @property
    def path(self) -> Path:
        return self.written.path

    @property
    def outcomes(self) -> Sequence[Outcome]:
        return self.written.outcomes

    @property
    def frontier(self) -> Any:
        return self.written.extra

    @property
    def failed(self) -> list[Outcome]:
        return [o for o in self.outcomes if not o.success]


def default_output(config: KindConfig) -> Path:
    return Path("out") / f"{config.meta.name}.h5"


def build_library(config: Any, out: Path | None = None, options: BuildOptions | None = None,
                  on_entry: ProgressFn | None = None, ipopt: tuple[tuple[str, Any], ...] = ()) -> BuildReport:
    """Solve every entry of ``config.sweep`` and write the library (failed entries included,
    marked ``success = false`` with their status). ``ipopt``: extra IPOPT options of every solve
    (the quadruped's; ``(("print_level", 5),)`` shows its log)."""
    t0 = time.perf_counter()
    out = out or default_output(config)
    options = options or BuildOptions()
    kind = kind_of(config)
    with span("build", jobs=options.jobs, backend=options.backend):
        with span("prepare"):
            kind.prepare(config, options)
        with span("sweep"):
            outcomes = run_sweep(kind.tasks(config, ipopt), options, on_entry)
        with span("write"):
            written: Written = kind.write(config, out, outcomes, options)
    return BuildReport(written, time.perf_counter() - t0)


def check_options(cfg: Any, opts: BuildOptions) -> None:
    """Refuse options that cannot work before anything runs: a dask backend without a reachable
    scheduler, an unwritable cache folder, and what the kind's ``check`` refuses."""
    from skatelib.pipeline.build.preflight import check_cache_dir, check_scheduler

    if opts.backend == "dask":
        if opts.scheduler is None:
            raise SkatelibError("--backend dask needs --scheduler tcp://HOST:PORT")
        check_scheduler(opts.scheduler)
    elif opts.scheduler is not None:
        raise SkatelibError("--scheduler names the dask cluster the build goes to: add --backend dask")
    kind_of(cfg).check(cfg, opts)
    if opts.cache:
        check_cache_dir()
