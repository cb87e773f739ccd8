"""The quadruped's build size from its config alone (:mod:`skatelib.pipeline.build.size`): every
solve's knots (the lead-in of a transition, then strides x the period, at ``dt_s``) times the
decision variables per knot (28 states and 24 controls)."""

from __future__ import annotations

import math
from collections.abc import Sequence

from skatelib.library.channels import CONTROL_NAMES, STATE_NAMES
from skatelib.pipeline.build.size import BuildSize
from skatelib.pipeline.quadruped.config import QuadrupedConfig

VARIABLES_PER_KNOT = len(STATE_NAMES) + len(CONTROL_NAMES)


def knots(cfg: QuadrupedConfig, strides: int, lead_s: float = 0.0) -> int:
    """The knots of one solve: ``strides`` periods after a lead-in of ``lead_s`` [s]."""
    dt = cfg.optimization.dt_s
    return round(lead_s / dt) + strides * round(cfg.schedule.period_s / dt) + 1


def sized(entries: int, solves: Sequence[int]) -> BuildSize:
    """The size of ``entries`` entries whose solves have these knot counts."""
    return BuildSize(entries, max(solves, default=0), VARIABLES_PER_KNOT, sum(solves) * VARIABLES_PER_KNOT)


def build_size(cfg: QuadrupedConfig) -> BuildSize:
    """Every start-up of the sweep, and every transition at each stride count it may try."""
    start_ups = [knots(cfg, s) for _ in cfg.sweep.velocities_mps for s in cfg.sweep.strides]
    pairs = cfg.transitions.pairs()
    tried = [knots(cfg, s, cfg.transitions.touchdown_s) for _ in pairs for s in cfg.transitions.strides]
    return sized(len(start_ups) + len(pairs), start_ups + tried)


def frontier_size(cfg: QuadrupedConfig, searches: Sequence[tuple[bool, int]], probes: int) -> BuildSize:
    """Searches of (whether from riding, strides), each of up to ``probes`` solves."""
    solves = [knots(cfg, n, cfg.transitions.touchdown_s if riding else 0.0) for riding, n in searches]
    return sized(len(searches), [k for k in solves for _ in range(probes)])


def probes(start_mps: float, step_mps: float, resolution_mps: float, max_mps: float) -> int:
    """The most solves of one frontier search: the climb from ``start_mps`` to ``max_mps``, then the
    bisection of one step down to ``resolution_mps``."""
    climb = math.ceil(max(max_mps - start_mps, 0.0) / step_mps) + 1
    return climb + max(math.ceil(math.log2(step_mps / resolution_mps)), 0)
