"""The build tasks of the transitions (``[transitions]``): the slow-downs (and the stop) from one
riding speed, nearest target first, and the speed-ups to one speed, nearest start first; each
transition with the fewest strides that pass the independent physics checks (``[transitions]
strides`` tried in order) and, with ``[transitions] twin_judge``, the closed loop on the physical
twin (:mod:`skatelib.pipeline.quadruped.transitions.twin_judge`); warm-started from the last success
of the same stride count and knot window in the task. The knot window follows the faster speed and
whether the planted foot pushes or brakes, so the slow-downs from a speed that brake share theirs
(a slight one may push), and so do the speed-ups to one (a window's kept constraint rows, and so the
multipliers a warm start carries, differ from another's). A cell that passes with no stride count
is stored as the failure of the last count tried, with its status."""

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
    """A chain of transitions ``(from, to)`` solved in order: the slow-downs from one riding speed,
    or the speed-ups to one."""

    config: QuadrupedConfig
    pairs: tuple[tuple[float, float], ...]
    ipopt: tuple[tuple[str, Any], ...] = ()

    @property
    def n_entries(self) -> int:
        return len(self.pairs)

    @property
    def weight(self) -> float:
        """Its rough cost in seconds of one core, to start the longest tasks first: about 3.3 s a
        transition (a candidate's solve and twin rides), more the farther it goes (more strides,
        more candidates refused)."""
        return sum(3.3 * (1.0 + 3.0 * abs(b - a)) for a, b in self.pairs)

    def run(self, use_cache: bool, events: EventSink | None) -> list[EntryOutcome]:
        warm: dict[tuple[int, Window], tuple[WarmStart, str]] = {}
        out = []
        for v0, v in self.pairs:
            cell = f"v{v0:.2f}-{v:.2f}"  # the progress display's name: the strides are known at the end
            if events is not None:
                events.put(EntryEvent(cell, done=False))
            outcome = self._fewest_strides(v0, v, warm, use_cache)
            out.append(outcome)
            if events is not None:
                r = outcome.result
                events.put(EntryEvent(cell, True, f"{r.status} ({r.n_strides} strides)", r.success, outcome.cached))
        return out

    def _fewest_strides(self, v0: float, v: float, warm: dict[tuple[int, Window], tuple[WarmStart, str]],
                        use_cache: bool) -> EntryOutcome:
        outcome = None
        refused: list[str] = []
        for n in self.config.transitions.strides:
            with span("candidate", key=schema.entry_key(v, n, v0)) as fields:
                outcome = self._candidate(v0, v, n, warm, use_cache, refused)
                fields["accepted"] = outcome.success
            if outcome.success:
                break
        assert outcome is not None  # strides is never empty (config check)
        return outcome

    def _candidate(self, v0: float, v: float, n: int, warm: dict[tuple[int, Window], tuple[WarmStart, str]],
                   use_cache: bool, refused: list[str]) -> EntryOutcome:
        """The transition from ``v0`` to ``v`` in ``n`` strides: solved (or read from the cache), judged
        by the physics checks and, when they pass, by the twin; a refusal is added to ``refused``."""
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
    """The slow-downs from each riding speed (with its stop), nearest target first, and the speed-ups
    to each, nearest start first; fastest speed first within each kind."""
    pairs = config.transitions.pairs()

    def chain(chosen: list[tuple[float, float]]) -> TransitionTask:
        return TransitionTask(config, tuple(sorted(chosen, key=lambda ab: (abs(ab[1] - ab[0]), ab[0], ab[1]))), ipopt)

    downs = sorted({a for a, b in pairs if b < a}, reverse=True)
    ups = sorted({b for a, b in pairs if b > a}, reverse=True)
    return ([chain([(a, b) for a, b in pairs if a == start and b < a]) for start in downs]
            + [chain([(a, b) for a, b in pairs if b == end and a < b]) for end in ups])
