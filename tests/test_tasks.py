"""The quadruped's warm-start chains: solved from a third of the way up the speeds outwards, and a
failed entry passes its turn to the nearest success towards that start."""

from __future__ import annotations

import dataclasses
from typing import Any

import pytest
from skatelib.pipeline.config import load_config
from skatelib.pipeline.quadruped import tasks

from tests.helpers import TINY


def test_solve_order_starts_cold_a_third_of_the_way_up_and_walks_outwards():
    assert tasks.solve_order([1.0, 0.2, 0.85, 0.5, 0.3, 0.7]) == [
        (0.3, None), (0.2, 0.3), (0.5, 0.3), (0.7, 0.5), (0.85, 0.7), (1.0, 0.85)]
    assert tasks.solve_order([0.4]) == [(0.4, None)]
    assert tasks.solve_order([0.7, 0.4]) == [(0.4, None), (0.7, 0.4)]
    assert tasks.solve_order([]) == []


@dataclasses.dataclass(frozen=True)
class _Result:
    target_velocity_mps: float
    n_strides: int
    success: bool
    status: str
    warm: Any


def test_a_failed_entry_hands_its_turn_to_the_nearest_success_towards_the_start(monkeypatch):
    """0.5 and 0.85 fail: 0.7 starts from 0.3's solution, 1.0 from 0.7's; every solve is keyed on
    the entry that really warm-started it."""
    failing = {0.5, 0.85}
    started_from: dict[float, Any] = {}
    keyed_on: dict[float, Any] = {}

    def solve(spec):
        v = spec.target_velocity_mps
        started_from[v] = spec.warm
        return _Result(v, spec.n_strides, v not in failing, "fake", f"solution {v}"), 1

    def key(spec, predecessor):
        keyed_on[spec.target_velocity_mps] = predecessor
        return f"key {spec.target_velocity_mps}"

    monkeypatch.setattr(tasks, "solve_with_retries", solve)
    monkeypatch.setattr(tasks, "entry_key", key)
    monkeypatch.setattr(tasks, "judge", lambda config, result: (result, {}))
    chain = tasks.BuildTask(load_config(TINY), 1, (0.2, 0.3, 0.5, 0.7, 0.85, 1.0))
    out = chain.run(use_cache=False, events=None)

    assert [o.result.target_velocity_mps for o in out] == [0.3, 0.2, 0.5, 0.7, 0.85, 1.0]
    assert started_from == {0.3: None, 0.2: "solution 0.3", 0.5: "solution 0.3", 0.7: "solution 0.3",
                            0.85: "solution 0.7", 1.0: "solution 0.7"}
    assert keyed_on == {0.3: None, 0.2: "key 0.3", 0.5: "key 0.3", 0.7: "key 0.3", 0.85: "key 0.7",
                        1.0: "key 0.7"}


def test_an_entrys_time_is_every_attempt(monkeypatch):
    """A solve that fails twice and converges on the third try reports 3 attempts and the sum of
    their build and solve times (the build table's row is the entry's own time, not its last try's)."""
    from dataclasses import dataclass

    from skatelib.pipeline.quadruped.problem import attempts

    @dataclass(frozen=True)
    class Timed:
        success: bool
        build_time_s: float
        solve_time_s: float

    times = iter([(False, 0.1, 1.0), (False, 0.2, 2.0), (True, 0.4, 4.0), (True, 9.0, 9.0)])
    monkeypatch.setattr(attempts, "solve", lambda spec: Timed(*next(times)))
    monkeypatch.setattr(attempts, "retry_ladder", lambda spec: [spec] * 4)
    result, n = attempts.solve_with_retries(object())
    assert n == 3 and result.success
    assert result.solve_time_s == pytest.approx(7.0) and result.build_time_s == pytest.approx(0.7)
