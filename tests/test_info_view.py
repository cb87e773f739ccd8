"""``skatelib info``'s closed-loop table reads a stored verdict whichever name its target speed was
stored under: ``target_velocity_mps`` now, ``label_mps`` in files written before the speeds had one
name each."""

from __future__ import annotations

import json
from typing import ClassVar

import pytest
from skatelib.library import schema
from skatelib.pipeline.views import info_view
from skatelib.pipeline.views.console import console


class _Entry:
    def __init__(self, verdict: dict[str, object]):
        self.key, self.attrs = "v0.30_s1", {schema.A_CLOSED_LOOP: json.dumps(verdict)}


class _Library(list):
    attrs: ClassVar[dict[str, str]] = {"closed_loop_plant": "none"}
    kind = "quadruped"


def _row(out: str) -> list[str]:
    line = next(x for x in out.splitlines() if "v0.30_s1" in x)
    return [c.strip() for c in line.split("│")[1:-1]]


@pytest.mark.parametrize("name", [schema.A_TARGET_VELOCITY, "label_mps"])
def test_a_stored_verdict_shows_its_target_under_either_name(name):
    """A verdict with its target stored as ``name`` shows the target (0.30) and the delivered speed's
    error against it (-1.0, in the "[%]" column); negative control: without a target the label is
    taken as 0 (a stop's), whose error has no percentage ("-"; the speed left is the delivered one)."""
    verdict = {name: 0.3, "delivered_mps": 0.297, "passed": True, "reasons": ""}
    with console.capture() as cap:
        info_view._closed_loop_summary(_Library([_Entry(verdict)]))
    out = cap.get()
    assert "error [%]" in out and _row(out)[1:4] == ["0.30", "0.297", "-1.0"], out
    with console.capture() as cap:
        info_view._closed_loop_summary(_Library([_Entry({"delivered_mps": 0.297, "passed": True})]))
    assert _row(cap.get())[1:4] == ["-", "0.297", "-"], cap.get()
