"""``skatelib track --report OUT.html``: per entry, the plan against the closed loop (the board's
speed, its heading, the deck's roll, the smallest Coulomb margin of the feet in contact) and the
verdict with its reasons, in one HTML file with the figures embedded (matplotlib), written
atomically.

Each margin is taken in the cone its forces had to keep to: the plan's in the planning cone
(``friction_mu_plan``), the closed loop's in the plant's, after its model errors (the mu the
verdict's slip test uses), so the figure and the verdict agree."""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from skatelib.library import schema
from skatelib.library.atomic import write_atomic
from skatelib.library.channels import GROUND, I_BOARD_ROLL
from skatelib.library.rotations import board_rotations
from skatelib.runtime import Entry, MotionLibrary

LOADED_N = 1.0  # a foot carrying more than this normal force is in contact for the margin


@dataclass(frozen=True)
class Cone:
    """The friction coefficients a margin is taken with: of a foot on the deck and on the floor
    (the twin's deck keeps the library's mu when the floor's changes)."""

    deck: float
    floor: float

    def label(self) -> str:
        if round(self.deck, 2) == round(self.floor, 2):
            return f"mu {self.deck:.2f}"
        return f"mu {self.deck:.2f} on the deck, {self.floor:.2f} on the floor"


def plan_cone(lib: MotionLibrary) -> Cone:
    """The cone the optimization planned in (``friction_mu_plan``)."""
    mu = lib.quadruped_model.mu_plan
    return Cone(mu, mu)


def plant_cone(lib: MotionLibrary, result: Any, errors: str) -> Cone:
    """The cone of the plant ``result`` was judged on, under ``errors`` (the --perturb text; "none":
    as planned): the model plant's mu (its slip test's) on deck and floor alike when ``result`` is
    the model plant's verdict, else the twin's (MuJoCo takes the larger of two geoms' coefficients:
    the deck's is the library's, the feet's and the floor's the perturbed floor's)."""
    from skatelib.control.params import SkateParams
    from skatelib.proving.verdict import TrackResult

    nominal = SkateParams.from_library(lib)
    text = "" if errors == "none" else errors
    if isinstance(result, TrackResult):
        from skatelib.proving.perturb import parse_perturbation

        mu = parse_perturbation(text, nominal)[0].mu
        return Cone(mu, mu)
    from skatelib.sim.errors import parse_twin_perturbation
    from skatelib.sim.figures import TwinFigures

    floor = parse_twin_perturbation(text, TwinFigures.from_library(lib)).floor_mu  # read as the rides read it
    return Cone(nominal.mu, nominal.mu) if floor is None else Cone(max(nominal.mu, floor), floor)


def board_speed(e: Entry) -> np.ndarray:
    """The board's speed over the floor [m/s] at each of the entry's times."""
    return np.hypot(e.channel("board_vx"), e.channel("board_vy"))


def coulomb_margin(e: Entry, mu: Cone | float) -> np.ndarray:
    """The smallest mu f_n - |f_t| [N] over the feet carrying more than LOADED_N, per control row
    (NaN where no foot does), as the plant's cone takes it: a foot on the floor about the vertical
    with the floor's mu, any other about the deck's normal (its yaw and roll) with the deck's."""
    cone = mu if isinstance(mu, Cone) else Cone(mu, mu)
    f = np.asarray(e.control)[:, :12].reshape(-1, 4, 3)
    n = len(f)
    state = np.asarray(e.state)[:n]
    yaw = np.asarray(e.board_pos)[:n, 3] if e.board_pos is not None else state[:, 5]
    deck = np.broadcast_to(board_rotations(yaw, state[:, I_BOARD_ROLL])[:, None, :, 2], f.shape)
    on_floor = np.asarray(e.contact)[:n] == GROUND if e.contact is not None else np.zeros((n, 4), dtype=bool)
    normal = np.where(on_floor[..., None], np.array([0.0, 0.0, 1.0]), deck)
    fn = np.sum(f * normal, axis=-1)
    ft = np.linalg.norm(f - fn[..., None] * normal, axis=-1)
    margin = np.where(fn > LOADED_N, np.where(on_floor, cone.floor, cone.deck) * fn - ft, np.inf)
    worst = margin.min(axis=1)
    return np.where(np.isfinite(worst), worst, np.nan)


@dataclass(frozen=True)
class Margins:
    """What the margin panel draws: the plan's cone, the closed loop's, and the verdict's own
    smallest margin of a commanded force [N] (the model plant's, over every plant step; None on
    the twin, whose verdict takes none)."""

    plan: Cone
    plant: Cone
    verdict_N: float | None = None


def figure(plan: Entry, run: Entry | None, margins: Margins, title: str) -> Any:
    """The four panels of one entry (a matplotlib figure; the caller closes it)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(4, 1, figsize=(8, 8), sharex=True)
    panels = (("board speed [m/s]", board_speed), ("board heading [rad]", lambda e: np.asarray(e.board_pos)[:, 3]),
              ("deck roll [rad]", lambda e: e.channel("board_roll")))
    for ax, (name, value) in zip(axes[:3], panels, strict=True):
        for e, style, label in ((plan, "--", "plan"), (run, "-", "closed loop")):
            if e is not None:
                ax.plot(np.asarray(e.t), value(e), style, label=label)
        ax.set_ylabel(name)
    ax = axes[3]
    for e, style, cone, label in ((plan, "--", margins.plan, "plan"), (run, "-", margins.plant, "closed loop")):
        if e is not None:
            y = coulomb_margin(e, cone)
            ax.plot(np.asarray(e.t)[:len(y)], y, style, label=f"{label}, {cone.label()}")
    if margins.verdict_N is not None and np.isfinite(margins.verdict_N):
        ax.axhline(margins.verdict_N, color="red", ls=":", lw=1.0,
                   label=f"verdict: smallest of a commanded force, {margins.verdict_N:.2f} N")
    ax.axhline(0.0, color="grey", lw=0.8)
    ax.set_ylabel("Coulomb margin [N]")
    ax.legend(loc="best", fontsize="small")
    for a in axes:
        a.grid(alpha=0.3)
    axes[0].axhline(float(plan.attrs[schema.A_TARGET_VELOCITY]), color="grey", lw=0.8, label="label")
    axes[0].legend(loc="lower right")
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def _png(fig: Any) -> bytes:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    plt.close(fig)
    return buf.getvalue()


def _margin_note(margins: Margins, on_model: bool) -> str:
    """The header's sentence on what the margin panel shows."""
    run = ("the forces the model plant applied, once per MPC update (inside its cone: a clipped force, a slip, "
           "shows 0; the dotted line is the verdict's smallest margin of a commanded force over every plant step)"
           if on_model else "the whole-body controller's forces, averaged over each MPC update")
    return (f"The Coulomb margin is the smallest mu f_n - |f_t| of a foot in contact, about its surface's normal: "
            f"the plan's forces in the planning cone ({margins.plan.label()}), the closed loop's in the plant's "
            f"({margins.plant.label()}): {run}.")


def report_html(lib: MotionLibrary, runs: Sequence[tuple[Any, Entry | None]], heading: str, errors: str) -> str:
    """The report's HTML: ``runs`` are each entry's verdict (``key``, ``passed``, ``reasons``,
    ``delivered_mps``, ``target_velocity_mps``) and its closed-loop run as an entry (None: not kept),
    all on one plant under ``errors`` (the --perturb text, whose mu the closed loop's margin takes)."""
    from skatelib.proving.verdict import TrackResult

    plan = plan_cone(lib)
    plant = plant_cone(lib, runs[0][0], errors) if runs else plan
    on_model = bool(runs) and isinstance(runs[0][0], TrackResult)
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(heading)}</title></head>"
             f"<body style='font-family:sans-serif'><h1>{html.escape(heading)}</h1>"
             f"<p>{sum(r.passed for r, _ in runs)} of {len(runs)} passed; {html.escape(str(lib.path))}. "
             f"Dashed: the plan; solid: the closed loop. {html.escape(_margin_note(Margins(plan, plant), on_model))}"
             "</p>"]
    for result, run in runs:
        verdict = "pass" if result.passed else f"FAIL: {result.reasons}"
        title = (f"{result.key}: delivered {result.delivered_mps:.3f} m/s, label "
                 f"{result.target_velocity_mps:.2f} m/s")
        margins = Margins(plan, plant, result.min_friction_margin_N if on_model else None)
        png = base64.b64encode(_png(figure(lib[result.key], run, margins, title))).decode()
        colour = "green" if result.passed else "red"
        parts.append(f"<h2 id='{html.escape(result.key)}'>{html.escape(result.key)}</h2>"
                     f"<p style='color:{colour}'>{html.escape(verdict)}</p>"
                     f"<img alt='{html.escape(title)}' src='data:image/png;base64,{png}'>")
    parts.append("</body></html>")
    return "".join(parts)


def write_report(out: Path, lib: MotionLibrary, runs: Sequence[tuple[Any, Entry | None]], heading: str,
                 errors: str) -> Path:
    """Write :func:`report_html` to ``out`` (a temporary file moved into place); ``errors``: the
    runs' --perturb text (the plant's mu the closed loop's margin is drawn with)."""
    return write_atomic(out, report_html(lib, runs, heading, errors).encode())
