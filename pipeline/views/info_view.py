"""``skatelib info``: the compact summary by default (:mod:`.info_summary`); ``--wide``: the
library's provenance, model and entries with the figures stored beside them (closed-loop verdicts,
a humanoid's whole body) in full tables; ``--json``: all of it as one JSON document."""

from __future__ import annotations

import json
from typing import Any

from rich.markup import escape
from skatelib.library import schema
from skatelib.pipeline.views.certificate_view import certificate_json, certificate_summary
from skatelib.pipeline.views.console import console, count, fmt, label_error
from skatelib.pipeline.views.fitted import Col, print_table
from skatelib.pipeline.views.info_summary import CLOSED_LOOP, summary_json
from skatelib.pipeline.views.transitions_view import transitions_json, transitions_summary

PROVENANCE = ("name", "format_version", "skatelib_version", "created_utc", "git_commit", "git_dirty",
              "casadi_version", "ipopt_version", "pinocchio_version")
# The JSON attributes `info --json` opens: the closed-loop verdicts and a humanoid's whole body.
STORED_FIGURES = (*((name, attr) for name, attr, _ in CLOSED_LOOP), ("wholebody", schema.A_WHOLEBODY))


def library_json(lib: Any, path: Any) -> dict[str, Any]:
    """``skatelib info --json``: provenance, model and one record per entry."""
    entries = [{"key": e.key, schema.A_TARGET_VELOCITY: e.target_velocity_mps, schema.A_N_STRIDES: e.n_strides,
                schema.A_FROM_VELOCITY: e.from_velocity_mps,
                "success": e.success, "status": str(e.attrs[schema.A_STATUS]),
                "iterations": int(e.attrs[schema.A_ITERATIONS]), "knots": len(e.t), "duration_s": e.duration_s,
                schema.A_SOLVE_TIME: e.attrs.get(schema.A_SOLVE_TIME),
                "physics": json.loads(str(e.attrs.get(schema.A_PHYSICS, "{}"))),
                **{name: json.loads(str(e.attrs[attr])) for name, attr in STORED_FIGURES if attr in e.attrs}}
               for e in lib]
    provenance = {k: lib.attrs[k] for k in PROVENANCE if k in lib.attrs}
    provenance |= {f"{name}_{k}": lib.attrs[f"{name}_{k}"] for name, _, _ in CLOSED_LOOP for k in ("plant", "utc")
                   if f"{name}_{k}" in lib.attrs}
    transitions = transitions_json(lib) if lib.kind == "quadruped" else {}
    return {"library": str(path), schema.A_KIND: lib.kind, **provenance, schema.A_CHECKSUM: lib.content_sha256,
            "summary": summary_json(lib), "model": dict(lib.model), "entries": entries,
            **({"transitions": transitions} if transitions else {}), **certificate_json(lib)}


def library_wide(lib: Any, path: Any) -> None:
    """``skatelib info --wide``: provenance, the model's parameters, every entry's figures, the
    transitions and stops, a humanoid's whole body, the stored closed-loop verdicts."""
    a = lib.attrs
    console.print(escape(f"{path}: {a.get('name', '?')} ({lib.kind}), format {a[schema.A_FORMAT_VERSION]}, "
                         f"skatelib {a[schema.A_SKATELIB_VERSION]}, created {a[schema.A_CREATED]}"))
    console.print(escape(f"git {a[schema.A_GIT_COMMIT][:12]}{' (dirty)' if a[schema.A_GIT_DIRTY] else ''}; casadi "
                         f"{a[schema.A_CASADI]}, ipopt {a[schema.A_IPOPT]}, pinocchio {a[schema.A_PINOCCHIO]}"))
    console.print(escape(f"content sha256 {lib.content_sha256}"))
    print_table(console, "model (each parameter's unit ends its name: _kg, _m, _rad, _N, _s...)",
                ("parameter", "value"),
                [[escape(str(k)), f"{v:.6g}" if isinstance(v, float) else escape(str(v))]
                 for k, v in sorted(lib.model.items()) if not str(k).endswith("_source")])
    rows = []
    for e in lib:
        ph = json.loads(str(e.attrs.get(schema.A_PHYSICS, "{}")))
        rows.append([escape(e.key), f"{e.target_velocity_mps:.2f}", str(e.n_strides), str(e.success),
                     escape(str(e.attrs[schema.A_STATUS])), str(e.attrs[schema.A_ITERATIONS]), str(len(e.t)),
                     f"{e.duration_s:.2f}", fmt(e.attrs, schema.A_SOLVE_TIME, "{:.2f}"),
                     fmt(ph, "momentum_speed_mps", "{:.3f}"),
                     label_error(e.target_velocity_mps, ph.get("momentum_speed_mps"), 2),
                     fmt(ph, "min_friction_margin_N", "{:.3f}"), fmt(ph, "max_defect", "{:.1e}")])
    print_table(console, count(len(lib), "entry"),
                ("entry", "v [m/s]", "strides", "success", Col("status", text=True), "iter", "knots", "duration [s]",
                 "solve [s]", "momentum [m/s]", "off label [%]", "Coulomb margin [N]", "defect [SI]"), rows,
                "momentum: the speed robot and board ride at together when the entry ends; off label: it against the "
                "label (a stop's: see momentum); Coulomb margin: the smallest mu f_n - |f_t| over the feet in contact; "
                "defect: the largest mismatch between a knot and a fine re-integration from the one before, in the "
                "state's SI units (m, rad, m/s, rad/s)")
    if lib.kind == "quadruped":
        transitions_summary(lib)
    _wholebody_summary(lib)
    _closed_loop_summary(lib)
    certificate_summary(lib)


def _wholebody_summary(lib: Any) -> None:
    """A humanoid's whole body per entry (format 1.3): the multibody ZMP against the plan's before
    and after the dynamics filter, the filter's COM correction, inverse kinematics' residuals."""
    rows = [(e.key, json.loads(str(e.attrs[schema.A_WHOLEBODY]))) for e in lib if schema.A_WHOLEBODY in e.attrs]
    if not rows:
        return
    print_table(console, "whole body (multibody ZMP against the planned ZMP)",
                ("entry", "ZMP RMS unfiltered [cm]", "ZMP RMS [cm]", "ZMP max [cm]", "COM moved [cm]", "IK COM [m]",
                 "IK soles [m]", "IK + filter [s]"),
                [[escape(key), f"{f['zmp_rms_unfiltered_m'] * 100:.2f}", f"{f['zmp_rms_m'] * 100:.2f}",
                  f"{f['zmp_max_m'] * 100:.2f}", f"{f['com_shift_max_m'] * 100:.2f}", f"{f['com_error_max_m']:.1e}",
                  f"{f['feet_error_max_m']:.1e}", f"{f['ik_and_filter_s']:.2f}"] for key, f in rows])


def _closed_loop_summary(lib: Any) -> None:
    """The closed-loop verdicts stored by ``validate --closed-loop`` (model plant, twin), if any."""
    for name, attr, _ in CLOSED_LOOP:
        stored = {e.key: json.loads(str(e.attrs[attr])) for e in lib if attr in e.attrs}
        if not stored:
            continue
        plant, when = lib.attrs.get(f"{name}_plant", "?"), lib.attrs.get(f"{name}_utc", "?")
        if lib.kind == "humanoid":
            _humanoid_twin_summary(stored, plant, when)
            continue
        where = "the twin (MuJoCo, whole-body controller)" if name.endswith("twin") else "the model plant"
        rows = []
        for key, v in stored.items():
            target = schema.A_TARGET_VELOCITY if schema.A_TARGET_VELOCITY in v else "label_mps"  # (older files)
            rows.append([escape(key), fmt(v, target, "{:.2f}"), fmt(v, "delivered_mps", "{:.3f}"),
                         label_error(v.get(target, 0.0), v.get("delivered_mps")),
                         "[green]pass[/]" if v.get("passed") else "[red]FAIL[/]", escape(str(v.get("reasons") or ""))])
        print_table(console, f"closed loop on {where}, plant errors {plant} ({when})",
                    ("entry", "label [m/s]", "delivered [m/s]", "error [%]", "verdict", Col("why", text=True)), rows)


def _humanoid_twin_summary(stored: dict[str, Any], plant: str, when: str) -> None:
    """A humanoid's verdicts on its twin: the fall, the ZMP and COM against the plan, the board's
    speed at the push's end for a skate (the figures of ``track HUMANOID_LIB --plant mujoco``)."""
    def cm(v: dict[str, Any], a: str, b: str) -> str:
        return f"{100 * v[a]:.1f}/{100 * v[b]:.1f}" if a in v and b in v else "-"

    def board(v: dict[str, Any]) -> list[str]:  # a walk has none
        if v.get("delivered_mps") is None:
            return ["-", "-"]
        return [f"{v['delivered_mps']:.3f}", label_error(v.get(schema.A_TARGET_VELOCITY, 0.0), v["delivered_mps"])]

    rows = [[escape(key), escape(str(v.get("fell") or "no")), fmt(v, schema.A_TARGET_VELOCITY, "{:.3f}"), *board(v),
             f"{100 * v['zmp_outside_m']:.1f}" if "zmp_outside_m" in v else "-", cm(v, "zmp_rms_m", "zmp_max_m"),
             cm(v, "com_rms_m", "com_max_m"),
             "[green]pass[/]" if v.get("passed") else "[red]FAIL[/]", escape(str(v.get("reasons") or ""))]
            for key, v in stored.items()]
    print_table(console, f"closed loop on the twin (MuJoCo, balance stabilizer), errors {plant} ({when})",
                ("entry", Col("fell", text=True), "label [m/s]", "board at push end [m/s]", "error [%]",
                 "ZMP out [cm]", "ZMP err RMS/max [cm]", "COM err RMS/max [cm]", "verdict", Col("why", text=True)),
                rows)
