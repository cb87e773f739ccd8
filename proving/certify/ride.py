"""One ride of a certificate: an entry on the twin under one draw's errors and shove
(:mod:`skatelib.proving.certify.draw`), judged as ``skatelib track --plant mujoco`` judges an
entry (:func:`skatelib.proving.twin.verdict.twin_result`), its failure modes named."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from skatelib.control.mpc_config import MpcConfig
from skatelib.control.settings import TrackSettings
from skatelib.proving.certify.draw import make_draw
from skatelib.proving.certify.spec import CertifySpec

# The failure modes a certificate counts, in the verdict's order (a failed ride may have several).
MODES = ("fall", "speed", "slip", "floor", "wheel_lift", "heading", "lateral")


@dataclass(frozen=True)
class DrawResult:
    """One ride's outcome: the entry, the draw's seed, whether it passed, its failure modes
    (:data:`MODES`), the shove's size [N s] and the verdict's reasons."""

    key: str
    seed: int
    passed: bool
    modes: tuple[str, ...]
    shove_Ns: float
    reasons: str


def failure_modes(result: Any) -> tuple[str, ...]:
    """The modes of a :class:`skatelib.proving.twin.verdict.TwinResult` (empty: it passed)."""
    from skatelib.proving.twin.verdict import HEADING_LIMIT_RAD, LATERAL_LIMIT_M, SLIP_LIMIT_M
    from skatelib.proving.verdict import speed_verdict

    r = result
    found = {
        "fall": bool(r.fall),
        "speed": bool(speed_verdict(r.target_velocity_mps, r.delivered_mps)[1]),
        "slip": r.max_slip_m > SLIP_LIMIT_M,
        "floor": r.floor_touch_ticks > 0,
        "wheel_lift": r.wheel_lift_ticks > 0,
        "heading": not abs(r.heading_error_rad) <= HEADING_LIMIT_RAD,
        "lateral": not abs(r.lateral_drift_m) <= LATERAL_LIMIT_M,
    }
    return tuple(m for m in MODES if found[m])


def ride_draw(path: str | Path, key: str, spec: CertifySpec, seed: int, mpc: MpcConfig | None = None,
              video: Path | None = None) -> tuple[DrawResult, Any]:
    """Ride entry ``key`` of the library at ``path`` under the draw of ``seed``; with ``video`` the
    ride rendered to it. Returns the outcome and the verdict
    (:class:`skatelib.proving.twin.verdict.TwinResult`)."""
    from skatelib.library import schema
    from skatelib.proving.twin.loop import Shove
    from skatelib.proving.twin.track import ride_twin
    from skatelib.proving.twin.verdict import twin_result
    from skatelib.runtime import MotionLibrary

    lib = MotionLibrary.open(path)
    entry = lib[key]
    draw = make_draw(spec, seed)
    t0, t_end = float(entry.t[0]), float(entry.t[-1])
    shove = Shove(t0 + draw.shove_at * (t_end - t0), draw.impulse())
    settings = TrackSettings(seed=draw.noise_seed, state=spec.state)
    run, plant = ride_twin(lib, key, draw.errors, (mpc or MpcConfig(), settings), keep=video is not None,
                           shove=shove)
    verdict = twin_result(key, float(entry.attrs[schema.A_TARGET_VELOCITY]), run)
    if video is not None:
        from skatelib.proving.twin.footage import film_run

        film_run(lib, entry, (run, plant.m), verdict, (f"draw {seed}", settings.transfer_s, ()), video)
    modes = failure_modes(verdict)
    return DrawResult(key, seed, not modes, modes, draw.shove_Ns, verdict.reasons), verdict


@dataclass(frozen=True)
class CertifyJob:
    """A picklable ride of one draw (for the parallel runner)."""

    path: str
    key: str
    spec: CertifySpec
    seed: int

    def __call__(self) -> DrawResult:
        return ride_draw(self.path, self.key, self.spec, self.seed)[0]
