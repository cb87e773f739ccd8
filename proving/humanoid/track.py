"""``skatelib track HUMANOID_LIB --plant mujoco``: each entry of a humanoid library executed on the
twin under the stabilizer, as picklable jobs (one per entry) that return the entry's verdict."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

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
    """

    key: str
    motion: str
    label_mps: float
    verdict: HumanoidVerdict
    failures: tuple[str, ...]
    duration_s: float

    @property
    def passed(self) -> bool:
        return not self.failures

    def as_dict(self) -> dict[str, float | str | bool | None]:
        """The verdict as ``validate --closed-loop`` stores it (the quadruped's names where they
        mean the same: ``target_velocity_mps``, ``delivered_mps`` (a skate's board at the push's
        end), ``passed``, ``reasons``), with every figure of :class:`HumanoidVerdict`."""
        figures = {k: v for k, v in asdict(self.verdict).items() if k != "key"}
        return {"key": self.key, "motion": self.motion, "target_velocity_mps": self.label_mps,
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

    def __call__(self) -> HumanoidTrackResult:
        from skatelib.control.humanoid_stabilizer import StabilizerGains
        from skatelib.proving.humanoid.loop import RunOptions, run_entry
        from skatelib.proving.humanoid.verdict import verdict
        from skatelib.sim.humanoid.errors import parse_humanoid_perturbation

        lib = MotionLibrary.open(self.path)
        e = lib[self.key]
        errors = parse_humanoid_perturbation(self.perturb) if self.perturb else None
        run = run_entry(lib, self.key, errors, StabilizerGains(enabled=self.stabilizer), RunOptions(seed=self.seed))
        v = verdict(run, float(e.attrs[schema.A_TARGET_VELOCITY]))
        return HumanoidTrackResult(self.key, lib.humanoid_model.motion, float(e.attrs[schema.A_TARGET_VELOCITY]),
                                   v, tuple(v.failures()),
                                   float(run.t[-1]) if len(run.t) else 0.0)


def humanoid_jobs(path: Path, entries: Sequence[str] | None, perturb: str, stabilizer: bool = True,
                  seed: int = 0) -> list[HumanoidJob]:
    """One job per entry (``entries``, or every successful one).

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
    if perturb:
        parse_humanoid_perturbation(perturb)
    keys = list(entries) if entries else [e.key for e in lib if e.success]
    for k in keys:
        if not lib[k].success:
            raise SkatelibError(f"{path}: entry {k} is stored as failed (no motion to execute)")
    return [HumanoidJob(str(path), k, perturb, stabilizer, seed) for k in keys]
