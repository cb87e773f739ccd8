"""Figures of a quadruped motion library (``skatelib plot``), from the file alone.

* ``speeds``: board speed and the momentum speed (m_R v_R + m_B v_B) / (m_R + m_B) over time, one
  panel per stride count, one colour per label (the paper's Fig. 6);
* ``deck_roll``: the deck roll over time, the same panels, with the wheel-collision limit;
* ``push_forces``: per entry, the ground foot's tangential force |f_t| against Coulomb's limit
  mu f_n (and the planning limit mu_plan f_n) while it pushes;
* ``frontier``: per search (start-ups, speed-ups, stops) and stride count, the labels tried by the
  frontier search (converged and passing the physics checks, or not) and the fastest that passes;
  from the library's ``frontier_json`` (``build --frontier``) or a ``skatelib frontier -o`` file.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from skatelib.library import schema
from skatelib.library.channels import GROUND
from skatelib.library.errors import SkatelibError
from skatelib.library.margins import forward_speed, momentum_speed
from skatelib.pipeline.views.console import console
from skatelib.pipeline.views.figures import by_panel, library_name, panel_label, panels, solved
from skatelib.runtime import Entry, MotionLibrary


def figures(lib: MotionLibrary, plt: Any, frontier_file: Path | None) -> dict[str, Any]:
    """The figures by file stem; the frontier's from ``frontier_file`` or the library's stored one.

    Raises:
        SkatelibError: A frontier file that is not one.
    """
    out = {"speeds": plot_speeds(lib, plt), "deck_roll": plot_deck_roll(lib, plt),
           "push_forces": plot_push_forces(lib, plt)}
    frontier = _frontier(lib, frontier_file)
    if frontier is not None:
        out["frontier"] = plot_frontier(frontier, library_name(lib), plt)
    else:
        console.print("no frontier in the library (build --frontier, or pass --frontier F.json "
                      "from skatelib frontier -o)")
    return out


def plot_speeds(lib: MotionLibrary, plt: Any) -> Any:
    """Board speed (solid) and momentum speed (dashed) against time, per panel (start-ups by strides,
    transitions by start speed)."""
    m = lib.quadruped_model
    groups = by_panel(lib)
    fig, axes = panels(plt, len(groups), f"{library_name(lib)}: board speed (solid) and momentum speed (dashed)")
    cmap = plt.get_cmap("viridis")
    speeds = sorted({e.target_velocity_mps for e in solved(lib)})
    for ax, (title, entries) in zip(axes, groups.items(), strict=True):
        for e in entries:
            c = cmap(speeds.index(e.target_velocity_mps) / max(1, len(speeds) - 1))
            ax.plot(e.t, forward_speed(e.state), color=c, label=panel_label(e))
            ax.plot(e.t, momentum_speed(e.state, m.robot_mass_kg, m.board.mass_kg), "--", color=c, lw=1)
            ax.axhline(e.target_velocity_mps, color=c, lw=0.5, alpha=0.5)
        ax.set_title(title, fontsize=10)
        ax.set_ylabel("speed [m/s]")
        ax.grid(alpha=0.3)
        ax.legend(title="label", fontsize=7, ncols=2, loc="center right")
    axes[-1].set_xlabel("time [s]")
    return fig


def plot_deck_roll(lib: MotionLibrary, plt: Any) -> Any:
    """Deck roll against time, per panel (start-ups by strides, transitions by start speed), with the
    wheel-collision limit."""
    limit = lib.quadruped_model.board.roll_limit_rad
    groups = by_panel(lib)
    fig, axes = panels(plt, len(groups), f"{library_name(lib)}: deck roll")
    for ax, (title, entries) in zip(axes, groups.items(), strict=True):
        for e in entries:
            ax.plot(e.t, e.channel("board_roll"), label=panel_label(e))
        for sign in (-1, 1):
            ax.axhline(sign * limit, color="red", lw=0.8, ls=":")
        ax.set_title(f"{title} (dotted: wheel-collision limit)", fontsize=10)
        ax.set_ylabel("roll [rad]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncols=3)
    axes[-1].set_xlabel("time [s]")
    return fig


def push_foot_forces(e: Entry, mu: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Knot times, |f_t| and mu f_n [N] of the feet on the ground (NaN where no foot is)."""
    assert e.contact is not None
    f = e.control[:, :12].reshape(-1, 4, 3)
    on_ground = e.contact[:-1] == GROUND
    tangential = np.where(on_ground, np.hypot(f[..., 0], f[..., 1]), -np.inf).max(axis=1)
    limit = np.where(on_ground, mu * f[..., 2], np.inf).min(axis=1)
    pushing = on_ground.any(axis=1)
    return e.t[:-1], np.where(pushing, tangential, np.nan), np.where(pushing, limit, np.nan)


def plot_push_forces(lib: MotionLibrary, plt: Any) -> Any:
    """Per entry, the pushing foot's |f_t| against Coulomb's mu f_n and the plan's mu_plan f_n."""
    mu, mu_plan = lib.quadruped_model.friction_mu, lib.quadruped_model.mu_plan
    entries = solved(lib)
    cols = 3
    rows = -(-len(entries) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(11, 2.2 * rows), squeeze=False, layout="constrained")
    fig.suptitle(f"{library_name(lib)}: push foot on the ground, |f_t| (solid) against mu f_n = {mu} f_n (red) "
                 f"and the plan's {mu_plan:.2f} f_n (orange dotted)")
    for ax, e in zip(axes.flat, entries, strict=False):
        t, ft, limit = push_foot_forces(e, mu)
        ax.plot(t, ft, color="C0", lw=1.2)
        ax.plot(t, limit, color="red", lw=1)
        ax.plot(t, limit * mu_plan / mu, color="orange", lw=1.2, ls=":")
        ax.set_title(e.key, fontsize=9)
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=7)
    for ax in axes.flat[len(entries):]:
        ax.set_visible(False)
    for ax in axes[:, 0]:
        ax.set_ylabel("force [N]", fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]", fontsize=8)
    return fig


def plot_frontier(frontier: dict[str, Any], name: str, plt: Any) -> Any:
    """Tried labels per search and stride count (dot: passes, cross: fails) and the fastest that
    passes (a stop: the start speed)."""
    from skatelib.pipeline.quadruped.frontier import Lane

    points = frontier["points"]
    fig, ax = plt.subplots(figsize=(7, 1.5 + 0.5 * len(points)), layout="constrained")
    ticks = []
    for y, p in enumerate(points):
        lane = Lane(p.get("from_mps", 0.0), p.get("stop", False))  # files of start-ups only lack them
        strides = p[schema.A_N_STRIDES]
        ticks.append(f"{strides}" if lane.start_up else f"{lane.label}, {strides}")
        ok = [q["velocity_mps"] for q in p["probes"] if q["ok"]]
        bad = [q["velocity_mps"] for q in p["probes"] if not q["ok"]]
        ax.scatter(ok, [y] * len(ok), marker="o", color="C2", s=18, zorder=3)
        ax.scatter(bad, [y] * len(bad), marker="x", color="C3", s=22, zorder=3)
        if p["fastest_mps"] is not None:
            ax.barh(y, p["fastest_mps"], height=0.5, color="C0", alpha=0.35)
            ax.annotate(f"{p['fastest_mps']:.3f} m/s", (p["fastest_mps"], y), xytext=(4, 6),
                        textcoords="offset points", fontsize=8)
    ax.set_xlabel("label [m/s] (a stop: the speed it stops from)")
    ax.set_ylabel("strides" if all(t.isdigit() for t in ticks) else "search, strides")
    ax.set_yticks(range(len(points)), ticks, fontsize=8)
    ax.set_title(f"{name}: reachable-speed frontier\n(bar: fastest label that passes; o passes, x fails)",
                 fontsize=10)
    ax.grid(axis="x", alpha=0.3)
    return fig


def _frontier_file(path: Path) -> dict[str, Any]:
    """A file of ``skatelib frontier -o``, or the error that names what is wrong with it."""
    advice = "give a file written by `skatelib frontier -o`"
    if path.is_dir():
        raise SkatelibError(f"--frontier {path}: is a folder; {advice}")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except OSError as e:
        raise SkatelibError(f"--frontier {path}: cannot be read ({e.strerror}); {advice}") from e
    except ValueError as e:  # not UTF-8, or not JSON
        raise SkatelibError(f"--frontier {path}: not JSON ({e}); {advice}") from e
    points = data.get("points") if isinstance(data, dict) else None
    if not isinstance(points, list) or not points or not all(isinstance(p, dict) and "probes" in p for p in points):
        raise SkatelibError(f"--frontier {path}: its 'points' are missing or are not the frontier's (a list of "
                            f"points with their 'probes'); {advice}")
    return dict(data)


def _frontier(lib: MotionLibrary, frontier_file: Path | None) -> dict[str, Any] | None:
    if frontier_file is not None:
        return _frontier_file(frontier_file)
    stored = lib.attrs.get(schema.A_FRONTIER)
    return json.loads(str(stored)) if stored else None
