"""``skatelib info``'s default: a library in a few lines and one compact table (fits 100 columns):
what it is, how many entries of which kind and status, the speeds and stride counts it covers, the
stored closed-loop verdicts' pass counts, one row per entry."""

from __future__ import annotations

import json
import re
from collections import Counter
from typing import Any

from rich.markup import escape
from skatelib.library import schema
from skatelib.pipeline.views.console import console, count, label_error
from skatelib.pipeline.views.fitted import print_table

# The closed-loop verdicts `validate --closed-loop` stores: (name in `info`, entry attribute, where).
CLOSED_LOOP = (("closed_loop", schema.A_CLOSED_LOOP, "the model plant"),
               ("closed_loop_twin", schema.A_CLOSED_LOOP_TWIN, "the twin"))


MOVES = ("start-up", "speed-up", "slow-down", "stop")  # a quadruped's entries, in this order


def entry_kind(lib: Any, e: Any) -> str:
    """A quadruped entry's move (start-up, speed-up, slow-down, stop); a humanoid's motion."""
    if lib.kind == "humanoid":
        return str(e.attrs.get("motion", "motion"))
    v0, v = e.from_velocity_mps, e.target_velocity_mps
    return "stop" if v == 0 else "start-up" if v0 == 0 else "speed-up" if v > v0 else "slow-down"


def robot_name(lib: Any) -> str:
    """The robot's name in the library's URDF, or "?" when there is none."""
    found = re.search(r"<robot\b[^>]*\bname\s*=\s*[\"']([^\"']+)", str(getattr(lib, "urdf", "") or ""))
    return found.group(1) if found else "?"


def _verdicts(lib: Any, attr: str) -> dict[str, bool]:
    return {e.key: bool(json.loads(str(e.attrs[attr])).get("passed")) for e in lib if attr in e.attrs}


def summary_json(lib: Any) -> dict[str, Any]:
    """The figures of the summary: kinds, statuses, speeds, strides, verdicts' pass counts."""
    failed = {e.key: str(e.attrs[schema.A_STATUS]) for e in lib if not e.success}
    verdicts = {}
    for name, attr, _ in CLOSED_LOOP:
        stored = _verdicts(lib, attr)
        if stored:
            verdicts[name] = {"passed": sum(stored.values()), "stored": len(stored),
                              "plant": lib.attrs.get(f"{name}_plant", "?"), "utc": lib.attrs.get(f"{name}_utc", "?")}
    kinds = Counter(entry_kind(lib, e) for e in lib)
    order = [k for k in MOVES if k in kinds] + sorted(k for k in kinds if k not in MOVES)
    return {"robot": robot_name(lib), "entries": len(lib), "kinds": {k: kinds[k] for k in order},
            "solved": len(lib) - len(failed), "failed": failed,
            "target_speeds_mps": sorted({e.target_velocity_mps for e in lib}),
            "start_speeds_mps": sorted({e.from_velocity_mps for e in lib}),
            "strides": sorted({e.n_strides for e in lib}), "verdicts": verdicts}


def speed(v: float) -> str:
    """A speed [m/s] with 2 decimals, 3 where the third is not 0 (0.375)."""
    text = f"{v:.3f}"
    return text[:-1] if text.endswith("0") else text


def _speeds(values: list[float]) -> str:
    return ", ".join(speed(v) for v in values)


def summary_lines(lib: Any, path: Any) -> list[str]:
    """The summary's lines (plain text)."""
    s, a = summary_json(lib), lib.attrs
    kinds = ", ".join(count(n, k) for k, n in s["kinds"].items())
    failed = "; ".join(f"{k} ({status})" for k, status in s["failed"].items())
    lines = [f"{path}: {a.get(schema.A_NAME, '?')}, a {lib.kind} library of {s['robot']}, format "
             f"{a[schema.A_FORMAT_VERSION]}",
             f"{count(s['entries'], 'entry')}: {kinds}; {s['solved']} solved"
             + (f", {len(s['failed'])} failed: {failed}" if failed else ""),
             f"target speeds [m/s]: {_speeds(s['target_speeds_mps'])}"
             + (f"; start speeds [m/s]: {_speeds(s['start_speeds_mps'])}" if lib.kind == "quadruped" else "")
             + f"; strides: {', '.join(str(n) for n in s['strides'])}"]
    for name, _, where in CLOSED_LOOP:
        v = s["verdicts"].get(name)
        if v is None and lib.kind != "quadruped":
            continue  # validate --closed-loop rides a quadruped's entries
        lines.append(f"closed loop on {where}: {v['passed']} of {count(v['stored'], 'stored verdict')} pass "
                     f"(plant errors {v['plant']}, {v['utc']})" if v else
                     f"closed loop on {where}: no verdict stored (skatelib validate LIB --closed-loop"
                     f"{' --plant mujoco' if name.endswith('twin') else ''})")
    return lines


def compact_table(lib: Any) -> None:
    """One row per entry: its speeds, strides, whether it was solved, the figures a user checks
    first (the quadruped's momentum speed, the humanoid's ZMP) and its stored verdicts."""
    stored = [(name, _verdicts(lib, attr)) for name, attr, _ in CLOSED_LOOP]
    stored = [(name, v) for name, v in stored if v]
    quadruped = lib.kind == "quadruped"
    heads = ["entry", *(["from [m/s]"] if quadruped else []), "to [m/s]", "strides", "solved",
             *(["momentum [m/s]", "off label [%]"] if quadruped else ["ZMP RMS [cm]", "COM moved [cm]"]),
             *("closed loop" if name == "closed_loop" else "on twin" for name, _ in stored)]
    rows = []
    for e in lib:
        if quadruped:
            momentum = json.loads(str(e.attrs.get(schema.A_PHYSICS, "{}"))).get("momentum_speed_mps")
            figures = ["-" if momentum is None else f"{momentum:.3f}", label_error(e.target_velocity_mps, momentum, 2)]
        else:
            body = json.loads(str(e.attrs.get(schema.A_WHOLEBODY, "{}")))
            figures = [f"{100 * body[k]:.2f}" if k in body else "-" for k in ("zmp_rms_m", "com_shift_max_m")]
        passed = ["-" if e.key not in v else "[green]pass[/]" if v[e.key] else "[red]FAIL[/]" for _, v in stored]
        rows.append([escape(e.key), *([speed(e.from_velocity_mps)] if quadruped else []),
                     speed(e.target_velocity_mps), str(e.n_strides), "yes" if e.success else "[red]no[/]",
                     *figures, *passed])
    legend = ("momentum: the speed robot and board ride at together when the entry ends; off label: it against "
              "the label (a stop's: see momentum)" if quadruped else
              "ZMP RMS: the whole body's ZMP against the plan's; COM moved: the dynamics filter's largest correction")
    print_table(console, count(len(lib), "entry"), heads, rows, legend)


def library_summary(lib: Any, path: Any) -> None:
    """``skatelib info``: the summary's lines, the compact entry table, a quadruped's transitions."""
    from skatelib.pipeline.views.certificate_view import certificate_summary
    from skatelib.pipeline.views.transitions_view import transitions_summary

    for line in summary_lines(lib, path):
        console.print(escape(line))
    compact_table(lib)
    if lib.kind == "quadruped":
        transitions_summary(lib, stops=False)
    certificate_summary(lib)
    console.print("more: --wide (provenance, the model, every figure and verdict), --json (all of it, for scripts)")
