"""``skatelib track LIB --ride FROM:TO,...``: a chained ride through a quadruped library's entries,
on the model plant or the twin."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
from rich.markup import escape
from skatelib.library.errors import SkatelibError
from skatelib.pipeline.cli.track_outputs import recording
from skatelib.pipeline.views.console import console, viewer_hint


def track_ride(library: Path, text: str, errors: tuple[str, str], controller: tuple[Any, Any],
               outputs: tuple[Path | None, Path | None], how: tuple[bool, bool]) -> None:
    """A chained ride (:mod:`skatelib.proving.ride`), its stages' table. ``errors``: the plant's
    perturbation and its name; ``controller``: the MPC's and the run's settings; ``outputs``: a
    recording and a video (the twin's) to write; ``how``: no option that rides something else (the
    steering maneuver, entries), and whether on the twin."""
    alone, on_twin = how
    save, video = outputs
    if not alone:
        raise SkatelibError("--ride rides its stages: leave out --maneuver and --entry")
    if video is not None and not on_twin:
        raise SkatelibError("--video renders runs on the twin: add --plant mujoco")
    (plant_error, perturb), (mpc, settings) = errors, controller
    from skatelib.pipeline.views.verdict_tables import ride_table
    from skatelib.proving.ride import parse_ride, ride
    from skatelib.proving.track import JobSpec, _quadruped

    try:
        stages = parse_ride(text)
    except ValueError as e:
        raise typer.BadParameter(str(e), param_hint="--ride") from None
    save_closed_loop = recording(library, save)
    if video is not None:
        from skatelib.pipeline.build.preflight import check_output

        check_output(video, [library], what="video")
    if on_twin:
        from skatelib.proving.twin.ride import twin_ride
        from skatelib.runtime import MotionLibrary

        lib = MotionLibrary.open(library)
        result = twin_ride(library, stages, plant_error, mpc, settings, (save is not None, video))
        perturb = f"{perturb} (MuJoCo twin, whole-body controller)"
    else:
        lib = _quadruped(library, plant_error, "a ride")
        result = ride(lib, stages, JobSpec(str(library), plant_error, mpc, settings).loop(lib),
                      keep_trace=save is not None)
    if save is not None and save_closed_loop is not None and result.entry is not None:
        save_closed_loop(lib, [(result.run.key, result.entry)], save, {result.run.key: result.reference})
        console.print(escape(f"wrote {save}; {viewer_hint(save)}"))
    if video is not None:
        console.print(escape(f"wrote {video}"))
    if not ride_table(result, perturb):
        raise typer.Exit(1)
