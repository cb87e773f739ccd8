"""The build tasks of the transitions (``[transitions]``): one per start speed, its targets solved
from the nearest outwards, each with the fewest strides that pass the independent physics checks
(``[transitions] strides`` tried in order) and, with ``[transitions] twin_judge``, the closed
loop on the physical twin (:mod:`skatelib.pipeline.quadruped.transitions.twin_judge`); warm-started from the
last success of the same stride count and knot window in the task (the transitions from the
fastest speed share one window; a window's kept constraint rows, and so the multipliers a warm
start carries, differ from another's). A cell that passes with no stride count is stored as the
failure of the last count tried, with its status."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from skatelib.library import schema
from skatelib.pipeline.build.contract import EntryEvent, EventSink
from skatelib.pipeline.build.profile import span
from skatelib.pipeline.quadruped.checks.verify import judge
from skatelib.pipeline.quadruped.config import QuadrupedConfig
from skatelib.pipeline.quadruped.problem.problem import Window
from skatelib.pipeline.quadruped.problem.pushoff import PushoffSpec, WarmStart
from skatelib.pipeline.quadruped.tasks import EntryOutcome, cached_solve, entry_key
from skatelib.pipeline.quadruped.transitions.twin_judge import TWIN_REFUSED, twin_refusals
from skatelib.pipeline.views.console import count


@dataclass(frozen=True)
class TransitionTask:
    """The transitions from one riding speed: speed-ups, slow-downs and the stop."""

    config: QuadrupedConfig
    from_velocity_mps: float
    targets: tuple[float, ...]
    ipopt: tuple[tuple[str, Any], ...] = ()

    @property
    def n_entries(self) -> int:
        return len(self.targets)

    def run(self, use_cache: bool, events: EventSink | None) -> list[EntryOutcome]:
        v0 = self.from_velocity_mps
        warm: dict[tuple[int, Window], tuple[WarmStart, str]] = {}
        out = []
        for v in sorted(self.targets, key=lambda t: (abs(t - v0), t)):
            cell = f"v{v0:.2f}-{v:.2f}"  # the progress display's name: the strides are known at the end
            if events is not None:
                events.put(EntryEvent(cell, done=False))
            outcome = self._fewest_strides(v, warm, use_cache)
            out.append(outcome)
            if events is not None:
                r = outcome.result
                events.put(EntryEvent(cell, True, f"{r.status} ({r.n_strides} strides)", r.success, outcome.cached))
        return out

    def _fewest_strides(self, v: float, warm: dict[tuple[int, Window], tuple[WarmStart, str]], use_cache: bool
                        ) -> EntryOutcome:
        outcome = None
        v0 = self.from_velocity_mps
        refused: list[str] = []
        for n in self.config.transitions.strides:
            with span("candidate", key=schema.entry_key(v, n, v0)) as fields:
                outcome = self._candidate(v, n, warm, use_cache, refused)
                fields["accepted"] = outcome.success
            if outcome.success:
                break
        assert outcome is not None  # strides is never empty (config check)
        return outcome

    def _candidate(self, v: float, n: int, warm: dict[tuple[int, Window], tuple[WarmStart, str]], use_cache: bool,
                   refused: list[str]) -> EntryOutcome:
        """The transition to ``v`` in ``n`` strides: solved (or read from the cache), judged by the
        physics checks and, when they pass, by the twin; a refusal is added to ``refused``."""
        v0 = self.from_velocity_mps
        entry = schema.entry_key(v, n, v0)
        spec = PushoffSpec(self.config, v, n, ipopt=self.ipopt, from_velocity_mps=v0)
        cell = (n, spec.window)
        start, start_key = warm.get(cell, (None, None)) if self.config.sweep.warm_start else (None, None)
        spec = replace(spec, warm=start)
        key = entry_key(spec, start_key)
        payload, cached, note = cached_solve(spec, key, use_cache)
        result = payload["result"]
        if result.success and result.warm is not None:
            warm[cell] = (result.warm, key)
        with span("checks", key=entry):
            judged, physics = judge(self.config, result)
        if judged.success and self.config.transitions.twin_judge:
            with span("twin", key=entry) as fields:
                reasons = twin_refusals(self.config, judged, key, use_cache)
                fields["refused"] = bool(reasons)
            if reasons:
                judged = replace(judged, success=False, status=f"{TWIN_REFUSED}: {reasons}")
                refused.append(f"v{v0:.2f}-{v:.2f}: the twin refused {count(n, 'stride')} ({reasons})")
        return EntryOutcome(replace(judged, warm=None), payload["attempts"], cached, physics, key,
                            "; ".join(filter(None, [note, *refused])))


def transition_tasks(config: QuadrupedConfig, ipopt: tuple[tuple[str, Any], ...] = ()) -> list[TransitionTask]:
    """One task per start speed of ``[transitions]`` (fastest first: its speed-ups need the most strides)."""
    pairs = config.transitions.pairs()
    starts = sorted({a for a, _ in pairs}, reverse=True)
    return [TransitionTask(config, a, tuple(b for a2, b in pairs if a2 == a), ipopt) for a in starts]
