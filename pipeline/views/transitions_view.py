"""``skatelib info``'s transitions (format 1.4): which start speed reaches which target in how many
strides, the fastest speed-up from each start speed and how long and how far each stop takes."""

from __future__ import annotations

from typing import Any

import numpy as np
from rich.markup import escape
from skatelib.library import schema
from skatelib.library.margins import momentum_speed
from skatelib.pipeline.views.console import console
from skatelib.pipeline.views.fitted import print_table

STOPPED_MPS = 0.05  # a stop counts as done below this momentum speed


def stop_figures(lib: Any, e: Any) -> dict[str, float]:
    """How long and how far (along the heading) a stop entry rides until robot and board move slower
    than 0.05 m/s together (momentum speed), and the entry's whole duration."""
    m = lib.quadruped_model
    v = momentum_speed(np.asarray(e.state), m.robot_mass_kg, m.board.mass_kg)
    k = int(np.argmax(v < STOPPED_MPS)) if np.any(v < STOPPED_MPS) else len(v) - 1
    board = np.asarray(e.board_pos)
    heading = np.array([np.cos(board[0, 3]), np.sin(board[0, 3])])
    return {"stop_time_s": float(e.t[k] - e.t[0]), "stop_distance_m": float((board[k, 0:2] - board[0, 0:2]) @ heading),
            "duration_s": float(e.duration_s), schema.A_FROM_VELOCITY: e.from_velocity_mps,
            schema.A_N_STRIDES: e.n_strides}


def transitions_json(lib: Any) -> dict[str, Any]:
    """The transitions of a quadruped library: every cell (from, to) with its strides or its failure,
    the fastest speed-up per start speed and each stop's time and distance; empty without transitions."""
    moves = [e for e in lib if e.from_velocity_mps > 0]
    if not moves:
        return {}
    cells = [{"from_mps": e.from_velocity_mps, "to_mps": e.target_velocity_mps, "key": e.key, "success": e.success,
              schema.A_N_STRIDES: e.n_strides} for e in moves]
    starts = sorted({e.from_velocity_mps for e in moves})
    fastest = {}
    for v0 in starts:
        ups = [e for e in moves if e.success and e.from_velocity_mps == v0 and e.target_velocity_mps > v0]
        if ups:
            best = max(ups, key=lambda e: (e.target_velocity_mps, -e.n_strides))
            fastest[f"{v0:.2f}"] = {"to_mps": best.target_velocity_mps, schema.A_N_STRIDES: best.n_strides,
                                    "key": best.key}
    stops = {e.key: stop_figures(lib, e) for e in moves if e.success and e.target_velocity_mps == 0}
    return {"cells": cells, "fastest_speed_up": fastest, "stops": stops}


def transitions_summary(lib: Any, stops: bool = True) -> None:
    """The transition table (rows: from, columns: to; strides of the stored entry, FAIL for a cell
    stored as failed) and, with ``stops``, the stops' times and distances."""
    data = transitions_json(lib)
    if not data:
        return
    targets = sorted({c["to_mps"] for c in data["cells"]}, reverse=True)
    rows = []
    for v0 in sorted({c["from_mps"] for c in data["cells"]}):
        row = {c["to_mps"]: c for c in data["cells"] if c["from_mps"] == v0}
        cell = {v: str(c[schema.A_N_STRIDES]) if c[schema.A_SUCCESS] else "FAIL" for v, c in row.items()}
        rows.append([f"{v0:.2f}", *(cell.get(v, "-") for v in targets)])
    print_table(console, "transitions (strides of each entry; rows: from, columns: to)",
                ("from \\ to [m/s]", *(f"{v:.2f}" for v in targets)), rows)
    if not stops or not data["stops"]:
        return
    print_table(console, f"stops (until robot and board ride slower than {STOPPED_MPS} m/s together)",
                ("entry", "from [m/s]", "strides", "time [s]", "distance [m]"),
                [[escape(key), f"{f[schema.A_FROM_VELOCITY]:.2f}", str(f[schema.A_N_STRIDES]),
                  f"{f['stop_time_s']:.2f}", f"{f['stop_distance_m']:.2f}"] for key, f in data["stops"].items()])
