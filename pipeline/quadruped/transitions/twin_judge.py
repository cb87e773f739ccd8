"""The physical twin as a build's judge of transitions (``[transitions] twin_judge``): a candidate
that passes the independent physics checks is ridden in closed loop on the MuJoCo twin
(:func:`skatelib.proving.twin.track.ride_twin`: the MPC over the whole-body controller, the
transfer and 1.5 s of riding) under each of the configured model-error sets, and judged as
``skatelib track --plant mujoco`` judges an entry (:func:`skatelib.proving.twin.verdict.twin_result`).
A stride count the twin refuses is not kept: the next is tried. The judge rides each error set once,
so a candidate must also keep its delivered speed within ``[transitions] twin_speed_share`` of the
verdict's tolerance (0.8: within 4 % of its label, a stop below 0.04 m/s): one that passes by less
passes on one draw of the closed loop, which amplifies even rounding (two rides differing only in
it end up to 0.7 points apart, docs/estimator.md).

Verdicts are cached beside the solves, under the candidate's cache key, the error sets, the twin's
code fingerprint (:mod:`skatelib.proving.twin.fingerprint`, which certificates store too) and a
hash of this judge's code: a changed controller or twin rides every candidate again."""

from __future__ import annotations

import functools
import hashlib
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from skatelib.library import schema
from skatelib.library.errors import ConfigError
from skatelib.pipeline.build.cache import cache_key, cached_or_solved

if TYPE_CHECKING:
    from skatelib.pipeline.quadruped.config import QuadrupedConfig
    from skatelib.pipeline.quadruped.problem.pushoff import SolveResult

FIELD = "transitions.twin_judge"
TWIN_REFUSED = "Twin_Refused"  # the status of a candidate the twin refused


def check_twin_judge(config: QuadrupedConfig) -> None:
    """Refuse, before any solve, a judge that cannot run: MuJoCo or the controller missing, or an
    error set that does not parse.

    Raises:
        ConfigError: Naming the config file and the field, and what to do.
    """
    sets = config.transitions.twin_judge
    if not sets:
        return
    try:
        from skatelib.sim.errors import parse_twin_perturbation
    except ImportError as e:
        raise ConfigError(config.path, FIELD, f"judging on the twin needs MuJoCo and the controller ({e}): "
                                              "pip install 'skatelib[control,sim]', or set twin_judge = []") from e
    from skatelib.pipeline.twin import twin_figures

    figures = twin_figures(config)  # what a plain number is divided by, as the rides will
    for text in sets:
        if not any(item.strip() for item in text.split(",")):
            raise ConfigError(config.path, FIELD, f"{text!r} names no model error: write 'none' for the board as it is")
        try:
            parse_twin_perturbation(_errors(text), figures)
        except ValueError as e:
            raise ConfigError(config.path, FIELD, f"{text!r}: {e}") from e


def _errors(text: str) -> str:
    """A model-error set as ``track --perturb`` reads it: 'none' is the plant as planned."""
    return "" if text == "none" else text


@functools.cache
def judge_fingerprint() -> str:
    """The twin's code fingerprint (:func:`skatelib.proving.twin.fingerprint.twin_fingerprint`) and
    a hash of this judge's source."""
    from skatelib.proving.twin.fingerprint import twin_fingerprint

    return twin_fingerprint() + hashlib.sha256(Path(__file__).read_bytes()).hexdigest()[:16]


def twin_refusals(config: QuadrupedConfig, result: SolveResult, solve_key: str, use_cache: bool) -> str:
    """Why the twin refuses ``result`` (the first error set of ``[transitions] twin_judge`` it fails
    under, and how; '' when it passes under every one); the verdict is cached under ``solve_key``."""
    sets, share = tuple(config.transitions.twin_judge), config.transitions.twin_speed_share
    key = cache_key("twin_judge", solve_key, sets, share, judge_fingerprint())
    payload, _, _ = cached_or_solved(key, ("reasons",), lambda: {"reasons": _ride(config, result, sets)}, use_cache)
    return str(payload["reasons"])


def speed_margin_refusal(verdict: Any, share: float) -> str:
    """Why a passing verdict's delivered speed is too near the verdict's bound for the judge (beyond
    ``share`` of its tolerance), or ''."""
    from skatelib.proving.verdict import SPEED_TOLERANCE, STOP_TOLERANCE_MPS

    v, delivered = verdict.target_velocity_mps, verdict.delivered_mps
    if v:
        limit = share * SPEED_TOLERANCE
        if abs(verdict.speed_error) > limit:
            return (f"delivered speed {delivered:.3f} m/s is {100 * verdict.speed_error:+.1f} % from the label "
                    f"{v:.2f}: within track's {100 * SPEED_TOLERANCE:.0f} %, beyond the judge's {100 * limit:.1f} % "
                    f"(twin_speed_share {share})")
    elif abs(delivered) > share * STOP_TOLERANCE_MPS:
        return (f"a stop still rides at {delivered:.3f} m/s: within track's {STOP_TOLERANCE_MPS} m/s, beyond the "
                f"judge's {share * STOP_TOLERANCE_MPS:.3f} (twin_speed_share {share})")
    return ""


def _ride(config: QuadrupedConfig, result: SolveResult, sets: Sequence[str]) -> str:
    """Ride ``result`` on the twin under each of ``sets`` in turn; the first that fails and its
    reasons ('' when none fails)."""
    from skatelib.control.mpc import MpcConfig
    from skatelib.control.settings import TrackSettings
    from skatelib.pipeline.quadruped.entries import entry_from_result, write_quadruped_library
    from skatelib.pipeline.quadruped.problem.problem import system_for
    from skatelib.proving.twin.track import ride_twin
    from skatelib.proving.twin.verdict import twin_result
    from skatelib.runtime import MotionLibrary

    key = schema.entry_key(result.target_velocity_mps, result.n_strides, result.from_velocity_mps)
    with tempfile.TemporaryDirectory() as tmp:
        path = write_quadruped_library(Path(tmp) / "candidate.h5", config, system_for(config),
                                       [entry_from_result(result)], result.ipopt_options)
        lib = MotionLibrary.open(path)
        for text in sets:
            run, _ = ride_twin(lib, key, _errors(text), (MpcConfig(), TrackSettings()))
            verdict: Any = twin_result(key, result.target_velocity_mps, run)
            why = verdict.reasons if not verdict.passed else speed_margin_refusal(
                verdict, config.transitions.twin_speed_share)
            if why:
                return f"{text}: {why}"
    return ""
