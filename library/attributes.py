"""Which of an entry's attributes two libraries are compared on (:mod:`skatelib.library.compare`):
label-level figures, with JSON attributes opened into theirs; solver effort (reported, not
counted); what differs between two builds of one problem anyway (left out); provenance."""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

from skatelib.library.records import jsonable, text

VOLATILE = frozenset({"created_utc", "solve_time_s", "build_time_s", "cache_key", "content_sha256", "config_toml",
                      "format", "closed_loop_utc", "closed_loop_twin_utc"})  # the *_utc: when the verdicts were made
EFFORT = frozenset({"iterations", "attempts"})  # reported, not counted
# Figures inside the JSON attributes that measure the build rather than the motion: reported, not counted.
EFFORT_FIGURES = frozenset({"wholebody.feet_s", "wholebody.ik_and_filter_s", "wholebody.ik_iterations_max"})
# The controller's solve times in any closed-loop verdict (the model plant's, the twin's, a maneuver's):
# the machine's speed, not the motion's.
TIMINGS = frozenset({"mpc_median_ms", "mpc_max_ms", "wbc_median_ms"})
PROVENANCE = frozenset({"git_commit", "git_dirty", "skatelib_version", "casadi_version", "ipopt_version",
                        "pinocchio_version", "format_version", "name", "solver_options_json", "ipopt_options_json"})


def _json(v: Any) -> Any:
    try:
        return json.loads(text(v)) if v is not None else {}
    except ValueError:
        return text(v)


def _flat(v: Any, prefix: str = "") -> dict[str, Any]:
    """A JSON value as dotted keys -> scalars (lists of objects by index, lists of scalars kept
    whole)."""
    items: list[tuple[Any, Any]] | None = list(v.items()) if isinstance(v, dict) else None
    if isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
        items = [(str(i), x) for i, x in enumerate(v)]
    if items is None:
        return {prefix: v}
    out: dict[str, Any] = {}
    for k, x in items:
        out.update(_flat(x, f"{prefix}.{k}" if prefix else str(k)))
    return out


def json_figures(v: Any, prefix: str = "") -> dict[str, Any]:
    """A JSON attribute's figures as dotted keys (:func:`_flat`)."""
    return _flat(_json(v), prefix)


def split(figures: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """Opened figures as (counted, effort), the volatile ones (a step's solve time) left out."""
    counted: dict[str, Any] = {}
    effort: dict[str, Any] = {}
    for k, v in figures.items():
        last = k.rsplit(".", 1)[-1]
        if last not in VOLATILE:
            (effort if last in EFFORT | TIMINGS or k in EFFORT_FIGURES else counted)[k] = v
    return counted, effort


def expand(attrs: Mapping[str, Any]) -> dict[str, Any]:
    """Attributes with JSON objects (``physics_json``, the closed-loop verdicts) or lists of them (a
    humanoid's ``steps_json``) opened into their figures."""
    out: dict[str, Any] = {}
    for k, v in attrs.items():
        s = text(v) if isinstance(v, (str, bytes)) else None
        if s is not None and (s.startswith("{") or s.startswith("[{")):
            out.update(json_figures(s, k.removesuffix("_json")))
        else:
            out[k] = jsonable(v)
    return out
