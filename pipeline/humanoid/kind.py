"""The humanoid as a robot kind (:class:`skatelib.pipeline.kinds.RobotKind`): its model summary, the
independent checks of a stored library, and the parts that build (:mod:`.builder`) and show it
(:mod:`.rerun`, :mod:`.plots`), imported when asked."""

from __future__ import annotations

import dataclasses
import json
import math
from typing import TYPE_CHECKING, Any

import numpy as np
from rich.markup import escape
from skatelib.library import schema
from skatelib.library.errors import LibraryFormatError, SkatelibError
from skatelib.pipeline.config import config_from_json
from skatelib.pipeline.humanoid.config import HumanoidConfig
from skatelib.pipeline.kinds import SubpackageKind
from skatelib.pipeline.views.console import console, parameter_table
from skatelib.runtime import MotionLibrary

if TYPE_CHECKING:
    from skatelib.pipeline.kinds import ReportFn



def print_model(cfg: HumanoidConfig) -> None:
    """The point-mass model and its LIP/DCM time constant."""
    h = cfg.humanoid
    omega = math.sqrt(h.gravity_mps2 / h.com_height_m)
    rows: list[tuple[str, Any]] = [(f.name, float(getattr(h, f.name))) for f in dataclasses.fields(h)
                                   if f.name != "source"]
    rows += [("LIP natural frequency omega = sqrt(g / z) [1/s]", omega), ("DCM time constant 1 / omega [s]", 1 / omega)]
    parameter_table(f"{cfg.meta.name}: humanoid point-mass model (Takasugi et al.)", rows, head="quantity")
    if h.source:
        console.print(escape(f"source: {h.source}"))


def validate_entries(lib: MotionLibrary, report: ReportFn) -> int:
    """Every step's GPM nodes against the plan stored with the entry, the arrays it serves a
    controller (:func:`.verify.served_failures`), and its whole body's checks when it has one;
    returns the failures."""
    from skatelib.pipeline.humanoid.motion import step_model, stored_plan
    from skatelib.pipeline.humanoid.served import Served
    from skatelib.pipeline.humanoid.verify import check_steps, failures, served_failures

    try:
        cfg = config_from_json(str(lib.attrs[schema.A_CONFIG_RESOLVED]), lib.path, None, HumanoidConfig)
    except SkatelibError as err:
        raise LibraryFormatError(lib.path, "/@config_resolved_json", f"stored config cannot be rebuilt: {err}") from err
    from skatelib.pipeline.humanoid.body import body_failures, stored_body
    from skatelib.pipeline.humanoid.wholebody import Humanoid

    robot = Humanoid(lib.urdf) if lib.urdf else None  # the description the whole bodies were solved on
    bad = 0
    for e in lib:
        if not e.success:
            report(e.key, "skipped", f"stored as failed ({e.attrs['status']}): skipped", {})
            continue
        plan = stored_plan(lib, e)  # as solved, not as today's code would plan it
        nodes = (e.arrays[schema.D_NODES_T], e.arrays[schema.D_NODES_STATE], e.arrays[schema.D_NODES_CONTROL])
        model = step_model(cfg)
        fails = failures(check_steps(plan, *nodes, model)) + served_failures(Served.of(e.arrays), plan, model.g)
        if schema.D_JOINTS in e.arrays:  # the whole body (format 1.3), by its own checks
            if robot is None:
                fails.append("whole body: the library stores no robot description (/model/robot_urdf) to check it on")
            else:
                body = stored_body(dict(e.arrays), dict(e.columns), json.loads(str(e.attrs[schema.A_WHOLEBODY])))
                half = cfg.humanoid.foot_length_m / 2
                deck = (cfg.board, cfg.humanoid.foot_width_m / 2) if cfg.board is not None else None
                fails += [f"whole body: {f}" for f in body_failures(robot, plan, np.asarray(e.t), body, half, deck)]
        bad += bool(fails)
        report(e.key, "failed" if fails else "ok", "ok" if not fails else "; ".join(fails), {})
    return bad


KIND = SubpackageKind("humanoid", HumanoidConfig, "skatelib.pipeline.humanoid", print_model, validate_entries)
