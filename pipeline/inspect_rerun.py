"""Log motion libraries to Rerun: columns over time (``send_columns``), a static scene, and a
saved default blueprint. Imported only by ``skatelib inspect``.

Quadruped entries: the robot's URDF shapes posed by pinocchio at every knot, the board as a box
that moves and rolls, contact forces as arrows (blue on the board, orange on the ground), and
plots of board speed against the target, deck roll, normal forces, joint angles and the
friction and torque margins. Humanoid entries: COM, ZMP, the representative contact point and
the soles, with plots of COM height and speed and the ZMP.
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin
import rerun as rr
import rerun.blueprint as rrb
from skatelib.library.atomic import atomic_path
from skatelib.library.channels import BOARD, GROUND, LEGS
from skatelib.library.errors import LibraryFormatError
from skatelib.library.margins import board_rotations, friction_margins, rpy_matrices
from skatelib.runtime import Entry, MotionLibrary

BOARD_COLOR, GROUND_COLOR, SWING_COLOR = (40, 110, 255), (255, 140, 0), (160, 160, 160)
FORCE_SCALE_M_PER_N = 0.004
SPACING_M = 1.2  # side-by-side entries are this far apart along y
DECK_THICKNESS_M = 0.02
WHEEL_RADIUS_M = 0.03  # drawn only: the paper gives the deck height with wheels (0.11 m), not the wheels
WHEEL_WIDTH_M = 0.035
GROUND_HALF_WIDTH_M = 0.45


def _time(t: np.ndarray) -> list[rr.TimeColumn]:
    return [rr.TimeColumn("time", duration=np.asarray(t, dtype=float))]


def _series(rec: rr.RecordingStream, root: str, path: str, t: np.ndarray, values: np.ndarray, name: str) -> None:
    """One plotted series with its legend name (units included); a run beside its reference
    (``/<key>/closed_loop``) says which it is."""
    role = [r.replace("_", " ") for r in root.strip("/").split("/")[1:]]
    rec.log(f"{root}/plots/{path}", rr.SeriesLines(names=" ".join([*role, name])), static=True)
    rec.send_columns(f"{root}/plots/{path}", indexes=_time(t), columns=rr.Scalars.columns(scalars=values))


class _Robot:
    """Pinocchio model and visual shapes from the URDF stored in the library."""

    def __init__(self, urdf_text: str):
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "robot.urdf"
            path.write_text(urdf_text)
            self.model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
            self.geoms = pin.buildGeomFromUrdf(self.model, str(path), pin.GeometryType.VISUAL)
        self.data = self.model.createData()
        self.gdata = pin.GeometryData(self.geoms)
        self.q_idx = np.array([self.model.joints[j].idx_q for j in range(2, self.model.njoints)])
        feet = [f.name for f in self.model.frames if f.name.endswith("_foot")]
        self.foot_ids = [self.model.getFrameId(f"{leg}_foot") for leg in LEGS] if len(feet) >= 4 else []

    def shape(self, g: Any) -> Any:
        geo = g.geometry
        name = type(geo).__name__
        if name == "Box":
            return rr.Boxes3D(half_sizes=[geo.halfSide], colors=[(90, 90, 100)])
        if name == "Cylinder":
            return rr.Cylinders3D(lengths=[2 * geo.halfLength], radii=[geo.radius], colors=[(120, 120, 130)])
        if name == "Sphere":
            return rr.Ellipsoids3D(half_sizes=[[geo.radius] * 3], colors=[(30, 30, 30)], fill_mode="solid")
        return None

    def poses(self, base_pos: np.ndarray, base_rot: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, ...]:
        """Per knot and shape: translations (K, G, 3) and xyzw quaternions (K, G, 4); per knot and
        leg the feet's translational Jacobians over the leg's joints (K, 4, 3, 3) (zeros without
        foot frames)."""
        K, G = len(q), len(self.geoms.geometryObjects)
        trans, quats = np.zeros((K, G, 3)), np.zeros((K, G, 4))
        tau = np.zeros((K, 4, 3, 3))
        qp = pin.neutral(self.model)
        for k in range(K):
            qp[:3] = base_pos[k]
            qp[3:7] = pin.Quaternion(base_rot[k]).coeffs()
            qp[self.q_idx] = q[k]
            pin.forwardKinematics(self.model, self.data, qp)
            pin.updateGeometryPlacements(self.model, self.data, self.geoms, self.gdata)
            for i in range(G):
                M = self.gdata.oMg[i]
                trans[k, i] = M.translation
                quats[k, i] = pin.Quaternion(M.rotation).coeffs()
            if self.foot_ids:
                pin.computeJointJacobians(self.model, self.data, qp)
                pin.updateFramePlacements(self.model, self.data)
                for leg, fid in enumerate(self.foot_ids):
                    J = pin.getFrameJacobian(self.model, self.data, fid, pin.LOCAL_WORLD_ALIGNED)[:3, 6:]
                    tau[k, leg] = J[:, 3 * leg: 3 * leg + 3]  # this leg's columns: d foot / d q_leg
        return trans, quats, tau


def _quat_rows(R: np.ndarray) -> np.ndarray:
    return np.array([pin.Quaternion(Ri).coeffs() for Ri in R])


def log_quadruped_entry(rec: rr.RecordingStream, lib: MotionLibrary, e: Entry, robot: _Robot, root: str,
                        offset: np.ndarray) -> None:
    t, x, u = e.t, e.state, e.control
    assert e.contact is not None and e.foot_pos is not None and e.board_pos is not None
    K = len(t)
    R = rpy_matrices(x[:, 3:6])
    com_off = lib.model_arrays.get("robot_com_offset_m", np.zeros(3))
    trunk = x[:, 0:3] - np.einsum("kij,j->ki", R, com_off) + offset
    trans, quats, jac = robot.poses(trunk, R, x[:, 12:24])
    for i, g in enumerate(robot.geoms.geometryObjects):
        path = f"{root}/robot/{g.name}"
        shape = robot.shape(g)
        if shape is not None:
            rec.log(path, shape, static=True)
        rec.send_columns(path, indexes=_time(t),
                         columns=rr.Transform3D.columns(translation=trans[:, i], quaternion=quats[:, i]))
    # Paths: the board's on the ground, each foot's trail, and where the push foot stood on the ground.
    rec.log(f"{root}/board_path", rr.LineStrips3D([e.board_pos[:, 0:3] * [1, 1, 0] + offset], colors=[(160, 110, 60)]),
            static=True)
    trails = [e.foot_pos[:, i] + offset for i in range(len(LEGS))]  # where each foot went
    rec.log(f"{root}/foot_trails", rr.LineStrips3D(trails, colors=[(120, 120, 120)], radii=0.002), static=True)
    stood = e.contact == GROUND
    if np.any(stood):
        steps = np.unique(np.round(e.foot_pos[stood], 3), axis=0)
        rec.log(f"{root}/footholds", rr.Points3D(steps + offset, radii=0.012, colors=[(230, 120, 30)]), static=True)
    _log_board(rec, lib.model, e, root, offset)
    _log_ground(rec, root, e.board_pos[:, :2] + offset[:2], float(lib.model["board_deck_length_m"]))
    # Contact forces at the knots where a control acts.
    forces = u[:, :12].reshape(-1, 4, 3)
    for i, leg in enumerate(LEGS):
        c = e.contact[:-1, i]
        colors = np.array([BOARD_COLOR if ci == BOARD else GROUND_COLOR if ci == GROUND else SWING_COLOR for ci in c],
                          dtype=np.uint8)
        rec.send_columns(f"{root}/forces/{leg}", indexes=_time(t[:-1]),
                         columns=rr.Arrows3D.columns(origins=e.foot_pos[:-1, i] + offset,
                                                     vectors=forces[:, i] * FORCE_SCALE_M_PER_N, colors=colors))
    # Plots.
    v_fwd = np.cos(x[:, 5]) * x[:, 24] + np.sin(x[:, 5]) * x[:, 25]
    _series(rec, root, "board_speed/actual", t, v_fwd, "board speed [m/s]")
    _series(rec, root, "board_speed/target", t, np.full(K, e.target_velocity_mps), "label [m/s]")
    _series(rec, root, "board_roll", t, x[:, 26], "deck roll [rad]")
    for i, leg in enumerate(LEGS):
        _series(rec, root, f"normal_force/{leg}", t[:-1], forces[:, i, 2], f"{leg} normal force [N]")
    names = e.columns["state"][12:24]
    for j, name in enumerate(names):
        _series(rec, root, f"joints/{name}", t, x[:, 12 + j], f"{name.removeprefix('q_').replace('_', ' ')} [rad]")
    m = lib.model
    tau_max = float(m.get("torque_limit_Nm", np.inf))
    fric, _ = friction_margins(x, u, e.contact, float(m["friction_mu"]))
    touching = np.isin(e.contact[:-1], (BOARD, GROUND))
    tau = np.abs(np.einsum("klji,klj->kli", jac[:-1], forces)).max(axis=2)  # |J^T f| per leg
    torque = np.where(touching, tau_max - tau, np.inf).min(axis=1)
    _series(rec, root, "margins/friction_N", t[:-1], fric, "Coulomb margin mu f_n - |f_t| [N]")
    _series(rec, root, "margins/torque_Nm", t[:-1], torque, "torque margin [N m]")


def _log_board(rec: rr.RecordingStream, m: dict[str, Any], e: Entry, root: str, offset: np.ndarray) -> None:
    """The board: the deck rolls about its x axis on two trucks that stay on the ground, four
    wheels on the trucks' axles; all of it moves and yaws with the board (``board_pos``: the deck
    top's centre, the deck roll)."""
    assert e.board_pos is not None
    t, yaw = e.t, e.state[:, 26]
    height = float(m["board_deck_height_m"])  # deck top above the ground, wheels included
    base = e.board_pos[:, :3] * [1.0, 1.0, 0.0] + offset
    heading = _quat_rows(board_rotations(0 * yaw, yaw))
    rec.send_columns(f"{root}/board", indexes=_time(t),
                     columns=rr.Transform3D.columns(translation=base, quaternion=heading))
    half = [m["board_deck_length_m"] / 2, m["board_deck_width_m"] / 2, DECK_THICKNESS_M / 2]
    rec.log(f"{root}/board/deck", rr.Boxes3D(half_sizes=[half], centers=[[0, 0, -DECK_THICKNESS_M / 2]],
                                             colors=[(160, 110, 60)], fill_mode="solid"), static=True)
    roll = board_rotations(e.board_pos[:, 3], 0 * yaw)
    rec.send_columns(f"{root}/board/deck", indexes=_time(t),
                     columns=rr.Transform3D.columns(translation=np.tile([0.0, 0.0, height], (len(t), 1)),
                                                    quaternion=_quat_rows(roll)))
    axles = [float(m["board_l_front_m"]), -float(m["board_l_rear_m"])]
    half_track = float(m.get("board_truck_width_m", m["board_deck_width_m"])) / 2
    hanger = height - DECK_THICKNESS_M - WHEEL_RADIUS_M
    rec.log(f"{root}/board/trucks", rr.Boxes3D(
        centers=[[x, 0.0, WHEEL_RADIUS_M + hanger / 2] for x in axles],
        half_sizes=[[0.02, half_track - WHEEL_WIDTH_M / 2, hanger / 2]] * 2, colors=[(150, 150, 160)],
        fill_mode="solid"), static=True)
    rec.log(f"{root}/board/wheels", rr.Cylinders3D(
        centers=[[x, side * half_track, WHEEL_RADIUS_M] for x in axles for side in (-1.0, 1.0)],
        lengths=[WHEEL_WIDTH_M] * 4, radii=[WHEEL_RADIUS_M] * 4, colors=[(235, 235, 225)],
        rotation_axis_angles=[rr.RotationAxisAngle(axis=[1.0, 0.0, 0.0], degrees=90.0)] * 4), static=True)


def _log_ground(rec: rr.RecordingStream, root: str, path_xy: np.ndarray, margin_m: float) -> None:
    """A ground strip under the entry's path (its own, so that a view of one entry shows it), with
    this view's axes (z up)."""
    rec.log(root, rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    border = np.array([margin_m, GROUND_HALF_WIDTH_M])
    lo = path_xy.min(axis=0) - border
    hi = path_xy.max(axis=0) + border
    rec.log(f"{root}/ground", rr.Boxes3D(mins=[[lo[0], lo[1], -0.002]], sizes=[[*(hi - lo), 0.002]],
                                         colors=[(215, 215, 210)], fill_mode="solid"), static=True)


def log_humanoid_entry(rec: rr.RecordingStream, lib: MotionLibrary, e: Entry, root: str, offset: np.ndarray) -> None:
    t, x = e.t, e.state
    zmp = e.arrays["zmp"]
    cp = e.arrays["contact_point"]
    m = lib.model
    rec.send_columns(f"{root}/com", indexes=_time(t),
                     columns=rr.Points3D.columns(positions=x[:, 0:3] + offset, radii=np.full(len(t), 0.03)))
    rec.log(f"{root}/com_path", rr.LineStrips3D([x[:, 0:3] + offset], colors=[(200, 40, 40)]), static=True)
    _log_ground(rec, root, x[:, 0:2] + offset[:2], 0.5)
    zmp3 = np.column_stack([zmp, np.zeros(len(zmp))]) + offset
    green = np.tile(np.array([[20, 160, 60]], dtype=np.uint8), (len(t), 1))
    rec.send_columns(f"{root}/zmp", indexes=_time(t),
                     columns=rr.Points3D.columns(positions=zmp3, radii=np.full(len(t), 0.02), colors=green))
    rec.send_columns(f"{root}/contact_point", indexes=_time(t),
                     columns=rr.Points3D.columns(positions=cp + offset, radii=np.full(len(t), 0.015)))
    # Soles under the contact point (the footprints of the plan), static.
    feet = np.unique(np.round(cp[:, :2], 4), axis=0)
    half = [m["foot_length_m"] / 2, m["foot_width_m"] / 2, 0.005]
    rec.log(f"{root}/soles", rr.Boxes3D(centers=np.column_stack([feet, np.zeros(len(feet))]) + offset,
                                        half_sizes=[half] * len(feet), colors=[(120, 120, 200)]), static=True)
    _log_support_polygons(rec, lib, e, root, offset)
    for name, col, label in (("com_z", x[:, 2], "COM height [m]"), ("com_vx", x[:, 3], "COM speed [m/s]"),
                             ("zmp_x", zmp[:, 0], "ZMP x [m]"), ("zmp_y", zmp[:, 1], "ZMP y [m]")):
        _series(rec, root, name, t, col, label)


def _log_support_polygons(rec: rr.RecordingStream, lib: MotionLibrary, e: Entry, root: str,
                          offset: np.ndarray) -> None:
    """The support polygon of each contact segment of the entry's stored plan, on the ground where it starts."""
    from skatelib.pipeline.humanoid.motion import stored_plan

    plan = stored_plan(lib, e)
    strips = []
    for spec in plan:
        for _, sup in spec.segments:
            poly = np.asarray(sup.polygon) + np.asarray(sup.p0)[:2]
            ring = np.vstack([poly, poly[:1]])
            strips.append(np.column_stack([ring, np.full(len(ring), 0.002)]) + offset)
    rec.log(f"{root}/support_polygons", rr.LineStrips3D(strips, colors=[(60, 60, 200)]), static=True)


def blueprint(lib: MotionLibrary, roots: list[str]) -> rrb.Blueprint:
    """One tab per entry: its own 3D view (the others out of it) beside its summary and plots (a
    closed-loop run shares its entry's tab with the reference), so that nothing mixes entries; a
    last tab shows all entries side by side."""
    if lib.kind == "quadruped":
        panels = [("board speed vs target", "board_speed"), ("deck roll", "board_roll"),
                  ("normal forces", "normal_force"), ("joint angles", "joints"), ("margins", "margins")]
    else:
        panels = [("COM height", "com_z"), ("COM speed", "com_vx"), ("ZMP x", "zmp_x"), ("ZMP y", "zmp_y")]
    groups: dict[str, list[str]] = {}
    for r in roots:
        groups.setdefault(r.strip("/").split("/")[0], []).append(r)

    def plots(members: list[str]) -> list[rrb.TimeSeriesView]:
        return [rrb.TimeSeriesView(name=title, contents=[f"{r}/plots/{p}/**" for r in members] + [
            f"{r}/plots/{p}" for r in members]) for title, p in panels]

    tabs = [rrb.Horizontal(
        rrb.Spatial3DView(name=f"{key} 3D", origin=f"/{key}"),
        rrb.Vertical(rrb.TextDocumentView(origin=f"{members[0]}/summary", name="entry"), *plots(members),
                     row_shares=[2] + [5] * len(panels)),
        name=key, column_shares=[3, 2]) for key, members in groups.items()]
    overview = rrb.Spatial3DView(name=f"all {len(groups)} entries", origin="/")
    return rrb.Blueprint(rrb.Tabs(*tabs, overview), collapse_panels=True)


def _log_summary(rec: rr.RecordingStream, root: str, e: Entry) -> None:
    """A short text at ``<root>/summary`` saying which entry this is and how it did."""
    a = e.attrs
    parts = [f"{e.target_velocity_mps:.2f} m/s x {e.n_strides}", f"{a['status']}" + ("" if e.success else " (failed)")]
    if "iterations" in a:
        parts[-1] += f", {a['iterations']} iterations"
    ph = json.loads(str(a.get("physics_json", "{}")))
    for key, fmt in (("momentum_speed_mps", "rides at {:.3f} m/s"),
                     ("min_friction_margin_N", "Coulomb margin {:.2f} N"),
                     ("max_torque_rigid_legs_Nm", "torque {:.1f} N m"), ("max_defect", "defect {:.0e}")):
        if key in ph:
            parts.append(fmt.format(ph[key]))
    if "closed_loop_json" in a:
        cl = json.loads(str(a["closed_loop_json"]))
        parts.append(f"closed loop {'pass' if cl['passed'] else 'FAIL'} ({cl['delivered_mps']:.3f} m/s)")
    text = f"**{e.key}**: " + "; ".join(parts)
    rec.log(f"{root}/summary", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN), static=True)


def log_library(lib: MotionLibrary, rec: rr.RecordingStream, keys: list[str] | None = None,
                overlay: bool = False) -> list[str]:
    """Log entries (all by default) side by side (or overlaid); returns their entity roots."""
    entries = [lib[k] for k in keys] if keys else list(lib)
    robot = _Robot(lib.urdf) if lib.kind == "quadruped" else None
    roots = []
    rec.log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    for n, e in enumerate(entries):
        root = f"/{e.key}"
        offset = np.zeros(3) if overlay else np.array([0.0, SPACING_M * n, 0.0])
        if robot is not None:
            log_quadruped_entry(rec, lib, e, robot, root, offset)
        else:
            log_humanoid_entry(rec, lib, e, root, offset)
        _log_summary(rec, root, e)
        roots.append(root)
    rec.send_blueprint(blueprint(lib, roots))
    return roots


def save_closed_loop(lib: MotionLibrary, runs: list[tuple[str, Entry]], save: Path) -> list[str]:
    """Each entry's reference beside its closed-loop run (``skatelib track --save``), with the views
    of ``inspect``: the reference at ``/<key>/reference``, the run 0.6 m beside it at
    ``/<key>/closed_loop``. Written atomically."""
    robot = _Robot(lib.urdf)
    rec = rr.RecordingStream(f"skatelib-track-{lib.path.stem}")
    roots = []
    with atomic_path(save) as tmp:
        rec.save(str(tmp))
        rec.log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        for n, (key, run) in enumerate(runs):
            offset = np.array([0.0, 2 * SPACING_M * n, 0.0])
            rec.log(f"/{key}", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)  # its tab's 3D view
            log_quadruped_entry(rec, lib, lib[key], robot, f"/{key}/reference", offset)
            _log_summary(rec, f"/{key}/reference", lib[key])
            beside = offset + np.array([0.0, SPACING_M / 2, 0.0])
            log_quadruped_entry(rec, lib, run, robot, f"/{key}/closed_loop", beside)
            roots += [f"/{key}/reference", f"/{key}/closed_loop"]
        rec.send_blueprint(blueprint(lib, roots))
        rec.flush()
        rec.disconnect()
    return roots


def put_viewer_on_path() -> None:
    """The SDK spawns the viewer found on PATH; the one installed with it sits beside this Python
    (``.venv/bin/rerun``), which is not on PATH when the venv is not activated."""
    here = str(Path(sys.executable).parent)
    parts = os.environ.get("PATH", "").split(os.pathsep)
    if here not in parts:
        os.environ["PATH"] = os.pathsep.join([here, *parts])


def inspect_library(path: Path, keys: list[str] | None, save: Path | None, spawn: bool, overlay: bool) -> list[str]:
    """Open a library and log it to a file (written atomically) and/or a spawned viewer."""
    lib = MotionLibrary.open(path)
    if lib.kind == "quadruped" and not lib.urdf:
        raise LibraryFormatError(path, "/model/robot_urdf", "the library carries no robot description; rebuild it")
    for k in keys or []:
        lib[k]  # raises EntryNotFound with the valid keys before anything is written
    rec = rr.RecordingStream(f"skatelib-{path.stem}")
    with contextlib.ExitStack() as stack:
        if save is not None:
            rec.save(str(stack.enter_context(atomic_path(save))))  # moved into place only on success
        if spawn:
            put_viewer_on_path()
            rec.spawn()
        roots = log_library(lib, rec, keys, overlay)
        rec.flush()
        rec.disconnect()
    return roots
