"""The command ``certify``: a library's entries each ridden N times on the twin under model errors
and a shove drawn from the config's ``[certify]`` table, the certificate stored in the file."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer
from rich.markup import escape
from skatelib.library.errors import Interrupted
from skatelib.pipeline.cli.build_commands import Backend, BackendOpt, JobsOpt, ProgressOpt, SchedulerOpt
from skatelib.pipeline.cli.library_commands import LibArg
from skatelib.pipeline.cli.option_checks import MAX_SEED
from skatelib.pipeline.views.console import console, count


class _Rates:
    """The progress bar's text: rides passed so far, overall and of the entry last heard from."""

    def __init__(self, bar: Any, task: Any):
        self.bar, self.task = bar, task
        self.passed: dict[str, list[int]] = {}

    def __call__(self, r: Any, cached: bool) -> None:
        ok, n = self.passed.setdefault(r.key, [0, 0])
        self.passed[r.key] = [ok + r.passed, n + 1]
        total_ok = sum(v[0] for v in self.passed.values())
        total = sum(v[1] for v in self.passed.values())
        e_ok, e_n = self.passed[r.key]
        text = (f"certifying: {total_ok}/{total} passed ({100 * total_ok / total:.0f} %); {r.key} {e_ok}/{e_n}"
                f"{' (cached)' if cached else ''}")
        self.bar.update(self.task, advance=1, description=escape(text))


def certify(
    library: LibArg,
    entry: Annotated[list[str] | None,
                     typer.Option("--entry", "-e", help="Entry key (repeatable); all successful ones by default.")
                     ] = None,
    samples: Annotated[int | None, typer.Option(
        min=1, max=100_000, help="Rides per entry; default: the [certify] table's samples.")] = None,
    seed: Annotated[int | None, typer.Option(min=0, max=MAX_SEED, help="Seed of the draws; default: the table's.")
                    ] = None,
    config: Annotated[Path | None, typer.Option(
        help="A quadruped config whose [certify] table to draw from; default: the one the library was built from.")
                      ] = None,
    jobs: JobsOpt = 2,
    backend: BackendOpt = Backend.loky,
    scheduler: SchedulerOpt = None,
    progress: ProgressOpt = True,
    cache: Annotated[bool, typer.Option("--cache/--no-cache", help="Reuse finished rides (resume).")] = True,
) -> None:
    """Ride each entry N times on the twin (the MPC over the whole-body controller), each ride under
    model errors and a shove drawn from the [certify] table, judged as track --plant mujoco judges
    it; store per entry the success rate, its 95 % Wilson interval, the failure modes and the shove
    margin in the library (docs/certify.md)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
    from skatelib.pipeline.certify_run import CertifyOptions, certify_into, certify_plan, check_writable
    from skatelib.pipeline.certify_spec import stale_reasons
    from skatelib.pipeline.views.certificate_view import certificate_table
    from skatelib.runtime import MotionLibrary

    spec, keys = certify_plan(library, entry, samples, seed, config)
    options = CertifyOptions(jobs, backend.value, scheduler, cache)
    check_writable(library, options)
    total = len(keys) * spec.samples  # what a --entry names is checked before any ride
    console.print(escape(f"certifying {count(len(keys), 'entry')} of {library}: {spec.samples} rides each on the twin"))
    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=console, disable=not progress) as bar:
        rates = _Rates(bar, bar.add_task("certifying", total=total))
        try:
            cert = certify_into(library, spec, keys, options, rates)
        except KeyboardInterrupt:
            done = sum(v[1] for v in rates.passed.values())
            kept = (f"{done} of {total} rides are cached; the library is unchanged. Run the same command to resume"
                    if cache else "nothing is cached (--no-cache); the library is unchanged")
            raise Interrupted(f"interrupted: {kept}.") from None
    certificate_table(cert, str(library), stale_reasons(MotionLibrary.open(library), cert))
    console.print(escape(f"wrote the certificate into {library}"))


COMMANDS = (certify,)
