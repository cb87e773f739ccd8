"""A humanoid run on the twin as a video (:mod:`skatelib.sim.video`, as the quadruped's): the
twin's configurations at 25 frames a second, the plan's pose beside it as a ghost (its waist and
joints where the plan has them, the board where the twin's is); on each frame the entry and the
model errors, the time, the contact ZMP's and the COM's distance from the plan's and, for a skate,
the board's speed beside the label; at the end the verdict (pass or fail, and why)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from skatelib.proving.humanoid.loop import STEPS_PER_TICK, HumanoidRun
from skatelib.sim.overlay import Caption
from skatelib.sim.render import View
from skatelib.sim.video import Footage

FPS = 25.0  # a README's GIF (every second frame) stays a few MB
# The camera: from the robot's right, a little ahead, far enough for a 1.5 m robot and its board.
CAMERA = View(distance_m=4.0, azimuth_deg=60.0, elevation_deg=-8.0, smooth_s=0.5, height_m=0.8, follow="waist")


def humanoid_footage(run: HumanoidRun, errors: str, passed: bool, reasons: str, label_mps: float | None,
                     timestep_s: float) -> Footage:
    """The footage of ``run`` (kept with its poses) judged ``passed`` (``reasons``: why not);
    ``label_mps``: a skate's board speed label (None: a walk); ``timestep_s``: the twin's step [s]."""
    if run.qpos is None or run.qpos_plan is None:
        raise ValueError("the run was made without its poses (RunOptions(keep_poses=True))")
    stride = max(1, round(1.0 / (FPS * STEPS_PER_TICK * timestep_s)))
    pick = np.arange(0, len(run.t), stride)
    ez = np.linalg.norm(run.zmp - run.zmp_ref, axis=1)
    ec = np.linalg.norm(run.com[:, 0:2] - run.com_ref[:, 0:2], axis=1)
    head = f"{run.key} on the MuJoCo twin, errors: {errors or 'none'}"
    captions = []
    for k in pick:
        zmp = "-" if np.isnan(ez[k]) else f"{100 * ez[k]:4.1f}"
        lines = [head, f"t = {run.t[k]:5.2f} s   (cyan ghost: the plan)",
                 f"ZMP {zmp} cm   COM {100 * ec[k]:4.1f} cm from the plan"]
        if label_mps is not None and run.deck_v is not None:
            lines.append(f"board {np.linalg.norm(run.deck_v[k, 0:2]):4.2f} m/s   label {label_mps:.2f} m/s")
        captions.append(Caption(tuple(lines)))
    text = "PASS: no fall, ZMP inside its polygon" if passed else f"FAIL: {reasons}"
    ending = Caption(captions[-1].lines, text, passed)
    return Footage(run.qpos[pick], 1.0 / (stride * STEPS_PER_TICK * timestep_s), tuple(captions),
                   run.qpos_plan[pick], ending, hold_s=2.0, camera=CAMERA)


def film_humanoid(m: object, run: HumanoidRun, how: tuple[str, bool, str, float | None], out: Path) -> str:
    """Write the video of ``run`` on the twin ``m`` (its ``MjModel``) to ``out`` (.mp4 or .gif);
    ``how``: the model errors' text, whether it passed, why not, a skate's label [m/s]. Returns the
    path written."""
    from skatelib.sim.video import write_run

    errors, passed, reasons, label = how
    footage = humanoid_footage(run, errors, passed, reasons, label, float(m.opt.timestep))  # type: ignore[attr-defined]
    return str(write_run(m, footage, out))
