"""``skatelib track --report OUT.html``: per entry, the plan against the closed loop (the board's
speed, its heading, the deck's roll, the smallest Coulomb margin of the feet in contact) and the
verdict with its reasons, in one HTML file with the figures embedded (matplotlib), written
atomically."""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from skatelib.library import schema
from skatelib.library.atomic import write_atomic
from skatelib.runtime import Entry, MotionLibrary

LOADED_N = 1.0  # a foot carrying more than this normal force is in contact for the margin


def board_speed(e: Entry) -> np.ndarray:
    """The board's speed over the floor [m/s] at each of the entry's times."""
    return np.hypot(e.channel("board_vx"), e.channel("board_vy"))


def coulomb_margin(e: Entry, mu: float) -> np.ndarray:
    """The smallest mu f_n - |f_t| [N] over the feet carrying more than LOADED_N, per control row
    (NaN where no foot does)."""
    f = np.asarray(e.control)[:, :12].reshape(-1, 4, 3)
    margin = np.where(f[..., 2] > LOADED_N, mu * f[..., 2] - np.hypot(f[..., 0], f[..., 1]), np.inf)
    worst = margin.min(axis=1)
    return np.where(np.isfinite(worst), worst, np.nan)


def _figure(plan: Entry, run: Entry | None, mu: float, title: str) -> bytes:
    """The four panels of one entry as PNG bytes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(4, 1, figsize=(8, 8), sharex=True)
    panels = (("board speed [m/s]", board_speed, False), ("board heading [rad]",
                                                          lambda e: np.asarray(e.board_pos)[:, 3], False),
              ("deck roll [rad]", lambda e: e.channel("board_roll"), False),
              ("Coulomb margin [N]", lambda e: coulomb_margin(e, mu), True))
    for ax, (name, value, on_controls) in zip(axes, panels, strict=True):
        for e, style, label in ((plan, "--", "plan"), (run, "-", "closed loop")):
            if e is None:
                continue
            t = np.asarray(e.t)
            y = value(e)
            ax.plot(t[:len(y)] if on_controls else t, y, style, label=label)
        ax.set_ylabel(name)
        ax.grid(alpha=0.3)
    axes[0].axhline(float(plan.attrs[schema.A_TARGET_VELOCITY]), color="grey", lw=0.8, label="label")
    axes[0].legend(loc="lower right")
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(title)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    plt.close(fig)
    return buf.getvalue()


def report_html(lib: MotionLibrary, runs: Sequence[tuple[Any, Entry | None]], heading: str) -> str:
    """The report's HTML: ``runs`` are each entry's verdict (``key``, ``passed``, ``reasons``,
    ``delivered_mps``, ``target_velocity_mps``) and its closed-loop run as an entry (None: not kept)."""
    mu = lib.quadruped_model.friction_mu
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(heading)}</title></head>"
             f"<body style='font-family:sans-serif'><h1>{html.escape(heading)}</h1>"
             f"<p>{sum(r.passed for r, _ in runs)} of {len(runs)} passed; {html.escape(str(lib.path))}. "
             "Dashed: the plan; solid: the closed loop; the margin is over the feet in contact "
             f"(mu = {mu:g}).</p>"]
    for result, run in runs:
        verdict = "pass" if result.passed else f"FAIL: {result.reasons}"
        title = (f"{result.key}: delivered {result.delivered_mps:.3f} m/s, label "
                 f"{result.target_velocity_mps:.2f} m/s")
        png = base64.b64encode(_figure(lib[result.key], run, mu, title)).decode()
        colour = "green" if result.passed else "red"
        parts.append(f"<h2 id='{html.escape(result.key)}'>{html.escape(result.key)}</h2>"
                     f"<p style='color:{colour}'>{html.escape(verdict)}</p>"
                     f"<img alt='{html.escape(title)}' src='data:image/png;base64,{png}'>")
    parts.append("</body></html>")
    return "".join(parts)


def write_report(out: Path, lib: MotionLibrary, runs: Sequence[tuple[Any, Entry | None]], heading: str) -> Path:
    """Write :func:`report_html` to ``out`` (a temporary file moved into place)."""
    return write_atomic(out, report_html(lib, runs, heading).encode())
