"""``skatelib track HUMANOID_LIB --plant mujoco``: the humanoid library's entries executed on its
twin under the balance stabilizer (dispatched from ``track`` by the library's kind)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
from rich.markup import escape
from skatelib.library.errors import SkatelibError
from skatelib.pipeline.cli.option_checks import exit_if_nothing_solved
from skatelib.pipeline.cli.track_outputs import recording
from skatelib.pipeline.views.console import console, count, run_with_progress, viewer_hint


def is_humanoid(library: Path) -> bool:
    """Whether the library at ``library`` is a humanoid's."""
    from skatelib.runtime import MotionLibrary

    return bool(MotionLibrary.open(library).kind == "humanoid")


def track_humanoid(library: Path, entry: list[str] | None, perturb: str | None, how: tuple[bool, bool],
                   runner: tuple[int, bool, int], outputs: tuple[Path | None, Path | None] = (None, None)) -> None:
    """Run the jobs, print the table, exit 1 if any entry failed. ``perturb``: the errors' text
    (``none``: as planned; None: the humanoid's default set); ``how``: on the twin, and whether an
    option of the quadruped's alone was given; ``runner``: parallel jobs, progress, the noise seed;
    ``outputs``: a Rerun recording and a video to write (checked before any run)."""
    on_twin, quadruped_only = how
    if quadruped_only:
        raise SkatelibError("a humanoid library's track executes its entries under the balance stabilizer, fed by "
                            "its sensors: --ride, --maneuver, --report, --draw, --state, --solver and --mpc-mu are "
                            "the quadruped's")
    if not on_twin:
        raise SkatelibError("a humanoid library is executed on its physical twin: add --plant mujoco")
    if not entry:
        exit_if_nothing_solved(library, "track")
    save, video = outputs
    save_runs = _outputs_checked(library, save, video)
    from skatelib.pipeline.views.humanoid_table import humanoid_table
    from skatelib.proving.humanoid.track import humanoid_jobs
    from skatelib.sim.humanoid.errors import DEFAULT_HUMANOID_PERTURBATION, HumanoidPerturbationError

    perturb = DEFAULT_HUMANOID_PERTURBATION if perturb is None else perturb

    jobs, progress, seed = runner
    try:
        calls = humanoid_jobs(library, entry, "" if perturb == "none" else perturb, seed=seed,
                              outputs=(video, save is not None))
    except HumanoidPerturbationError as e:
        raise typer.BadParameter(str(e), param_hint="--perturb") from None
    results = run_with_progress(calls, jobs, "executing on the humanoid twin", progress)
    for r in results:
        if r.video is not None:
            console.print(escape(f"wrote {r.video}"))
    if save is not None and save_runs is not None:
        from skatelib.runtime import MotionLibrary

        save_runs(MotionLibrary.open(library), [r.run for r in results if r.run is not None], save)
        console.print(escape(f"wrote {save}; {viewer_hint(save)}"))
    failed = humanoid_table(results, perturb)
    if failed:
        console.print(escape(f"{failed} of {count(len(results), 'entry')} failed on the twin"))
        raise typer.Exit(1)


def _outputs_checked(library: Path, save: Path | None, video: Path | None) -> Any:
    """The recording's and the video's paths checked before any run; returns the recording's writer
    (None: no recording asked for)."""
    from skatelib.pipeline.build.preflight import check_output

    if video is not None:
        check_output(video, [library], what="video")
    return recording(library, save, _humanoid_writer)


def _humanoid_writer() -> Any:
    from skatelib.pipeline.views.rerun_humanoid_twin import save_humanoid_runs

    return save_humanoid_runs
