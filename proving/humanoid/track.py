"""``skatelib track HUMANOID_LIB --plant mujoco``: each entry of a humanoid library executed on the
twin under the stabilizer, as picklable jobs (one per entry) that return the entry's verdict."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from skatelib.library import schema
from skatelib.library.errors import SkatelibError
from skatelib.proving.humanoid.verdict import HumanoidVerdict
from skatelib.runtime import MotionLibrary


@dataclass(frozen=True)
class HumanoidTrackResult:
    """One entry's run on the twin.

    Attributes:
        motion: ``walk`` or ``skate``.
        label_mps: The entry's target speed (the board's at the push's end for a skate) [m/s].
        failures: What failed (empty: passed).
        video: The video written of the run (None: none asked for).
        run: The run itself, with its poses, when kept for a recording (else None).
    """

    key: str
    motion: str
    label_mps: float
    verdict: HumanoidVerdict
    failures: tuple[str, ...]
    duration_s: float
    video: str | None = None
    run: Any = field(default=None, repr=False, compare=False)

    @property
    def passed(self) -> bool:
        return not self.failures

    def as_dict(self) -> dict[str, float | str | bool | None]:
        """The verdict as ``validate --closed-loop`` stores it (the quadruped's names where they
        mean the same: ``target_velocity_mps``, ``delivered_mps`` (a skate's board at the push's
        end), ``passed``, ``reasons``), with every figure of :class:`HumanoidVerdict`."""
        figures = {k: v for k, v in asdict(self.verdict).items() if k != "key"}
        return {"key": self.key, "motion": self.motion, schema.A_TARGET_VELOCITY: self.label_mps,
                "delivered_mps": self.verdict.board_mps, "passed": self.passed, "reasons": "; ".join(self.failures),
                "duration_s": self.duration_s, **figures}


@dataclass(frozen=True)
class HumanoidJob:
    """One entry on the twin (picklable: the library's path, the entry, the errors as text)."""

    path: str
    key: str
    perturb: str
    stabilizer: bool = True
    seed: int = 0
    video: str | None = None  # render the run to this .mp4 or .gif
    keep_run: bool = False  # return the run with its poses (a recording)

    def __call__(self) -> HumanoidTrackResult:
        from skatelib.control.humanoid_stabilizer import StabilizerGains
        from skatelib.proving.humanoid.loop import RunOptions, run_entry
        from skatelib.proving.humanoid.verdict import verdict
        from skatelib.sim.humanoid.errors import parse_humanoid_perturbation

        lib = MotionLibrary.open(self.path)
        e = lib[self.key]
        errors = parse_humanoid_perturbation(self.perturb) if self.perturb else None
        poses = self.keep_run or self.video is not None
        run = run_entry(lib, self.key, errors, StabilizerGains(enabled=self.stabilizer),
                        RunOptions(seed=self.seed, keep_poses=poses))
        label = float(e.attrs[schema.A_TARGET_VELOCITY])
        v = verdict(run, label)
        failures = tuple(v.failures())
        written = None
        if self.video is not None:
            from skatelib.proving.humanoid.footage import film_humanoid
            from skatelib.proving.humanoid.loop import figures_for
            from skatelib.sim.humanoid.plant import HumanoidPlant

            m = HumanoidPlant(figures_for(lib, self.key), errors, self.seed).m
            written = film_humanoid(m, run, (self.perturb, not failures, "; ".join(failures),
                                             label if v.label_mps is not None else None), Path(self.video))
        return HumanoidTrackResult(self.key, lib.humanoid_model.motion, label, v, failures,
                                   float(run.t[-1]) if len(run.t) else 0.0, written, run if self.keep_run else None)


def _shove_in_run(errors: Any, entry: Any) -> None:
    """A shove that the run of ``entry`` would end before: refused, not silently left out.

    Raises:
        HumanoidPerturbationError: ``shove_t`` at or after the run's end (the entry and the hold).
    """
    from skatelib.proving.humanoid.loop import HOLD_S
    from skatelib.sim.humanoid.errors import HumanoidPerturbationError

    if errors is None or errors.shove_N == 0.0:
        return
    end = float(entry.duration_s) + HOLD_S
    if errors.shove_t_s >= end:
        raise HumanoidPerturbationError(f"shove_t={errors.shove_t_s:g} s: the run of {entry.key} ends at {end:.2f} s "
                                        f"({entry.duration_s:.2f} s of motion and {HOLD_S:g} s of hold); shove earlier")


def humanoid_jobs(path: Path, entries: Sequence[str] | None, perturb: str, stabilizer: bool = True,
                  seed: int = 0, outputs: tuple[Path | None, bool] = (None, False)) -> list[HumanoidJob]:
    """One job per entry (``entries``, or every successful one); ``outputs``: a video to render
    each run to (with several entries ``NAME-<key>.EXT``), and whether to keep the runs for a
    recording.

    Raises:
        SkatelibError: Not a humanoid library, a skate library planned without a board, an entry it
            does not hold or one stored as failed, or MuJoCo missing (with the install hint).
        HumanoidPerturbationError: A bad ``perturb`` (before any run).
    """
    from skatelib.proving.twin.track import twin_library

    lib = twin_library(path, "humanoid", "the humanoid twin runs humanoid libraries; this one is ",
                       ("mujoco", "skatelib.control.humanoid_stabilizer"))
    from skatelib.sim.humanoid.errors import parse_humanoid_perturbation

    if lib.humanoid_model.motion == "skate" and lib.humanoid_model.board is None:
        raise SkatelibError(f"{path}: a skate library planned without a board (both soles on the ground, no deck "
                            "height): the twin cannot ride it on a deck; rebuild it from a config with a [board] "
                            "table (configs/hrp2_skate.toml)")
    errors = parse_humanoid_perturbation(perturb) if perturb else None
    keys = list(entries) if entries else [e.key for e in lib if e.success]
    for k in keys:
        if not lib[k].success:
            raise SkatelibError(f"{path}: entry {k} is stored as failed (no motion to execute)")
        _shove_in_run(errors, lib[k])
    video, keep = outputs
    if video is not None:
        from skatelib.proving.twin.track import video_path
        from skatelib.sim.video import FORMATS

        if video.suffix.lower() not in FORMATS:
            raise SkatelibError(f"--video {video}: give a file ending in {' or '.join(FORMATS)}")
    return [HumanoidJob(str(path), k, perturb, stabilizer, seed,
                        None if video is None else str(video_path(video, k, len(keys) > 1)), keep) for k in keys]
