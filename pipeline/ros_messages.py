"""The ROS 2 messages of an MCAP export (:mod:`skatelib.pipeline.exports`): their definitions (the
concatenated ``.msg`` texts a ROS 2 bag stores, as ``ros2 bag record`` writes them) and one
entry's messages as dictionaries for ``mcap_ros2``'s CDR writer."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np
from skatelib.library.channels import LEGS
from skatelib.library.compare import column_names
from skatelib.library.records import EntryRecord
from skatelib.library.rotations import board_rotations, rpy_matrices

_SEP = "=" * 80 + "\n"
_TIME = "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"
_HEADER = "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n"
_VECTOR3 = "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n"
_POINT = "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n"
_QUAT = "MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n"
_POSE = "MSG: geometry_msgs/Pose\ngeometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n"


def _definition(body: str, *deps: str) -> str:
    return body + "".join(_SEP + d for d in deps)


DEFINITIONS = {
    "geometry_msgs/PoseStamped": _definition("std_msgs/Header header\ngeometry_msgs/Pose pose\n", _HEADER, _TIME,
                                             _POSE, _POINT, _QUAT),
    "sensor_msgs/JointState": _definition(
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n",
        _HEADER, _TIME),
    "geometry_msgs/WrenchStamped": _definition(
        "std_msgs/Header header\ngeometry_msgs/Wrench wrench\n", _HEADER, _TIME,
        "MSG: geometry_msgs/Wrench\ngeometry_msgs/Vector3 force\ngeometry_msgs/Vector3 torque\n", _VECTOR3),
    "geometry_msgs/TwistStamped": _definition(
        "std_msgs/Header header\ngeometry_msgs/Twist twist\n", _HEADER, _TIME,
        "MSG: geometry_msgs/Twist\ngeometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n", _VECTOR3),
    "std_msgs/Float64MultiArray": _definition(
        "std_msgs/MultiArrayLayout layout\nfloat64[] data\n",
        "MSG: std_msgs/MultiArrayLayout\nstd_msgs/MultiArrayDimension[] dim\nuint32 data_offset\n",
        "MSG: std_msgs/MultiArrayDimension\nstring label\nuint32 size\nuint32 stride\n"),
}

Message = tuple[str, str, float, dict[str, Any]]  # topic, message type, time [s], fields


def _header(t: float) -> dict[str, Any]:
    sec, nanosec = divmod(round(t * 1e9), 1_000_000_000)
    return {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": "world"}


def _xyz(v: Sequence[float] | np.ndarray) -> dict[str, float]:
    return {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}


def quaternion_xyzw(R: np.ndarray) -> np.ndarray:
    """A rotation matrix's unit quaternion (x, y, z, w), w >= 0 (Shepperd's method)."""
    m = np.asarray(R, dtype=np.float64)
    tr = np.trace(m)
    if tr > 0:
        s = 2.0 * np.sqrt(tr + 1.0)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s]
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
        q = [0.0, 0.0, 0.0, (m[k, j] - m[j, k]) / s]
        q[i], q[j], q[k] = 0.25 * s, (m[j, i] + m[i, j]) / s, (m[k, i] + m[i, k]) / s
    out = np.array(q)
    return out if out[3] >= 0 else -out


def entry_messages(key: str, e: EntryRecord, kind: str, joints: Sequence[str]) -> Iterator[Message]:
    """Every message of one entry, knot by knot (module docstring of :mod:`.exports`)."""
    t = np.asarray(e.arrays["t"], dtype=np.float64)
    for name, a in sorted(e.arrays.items()):
        a = np.asarray(a, dtype=np.float64)
        if name == "t" or a.ndim == 0 or a.shape[0] not in (len(t), len(t) - 1):
            continue
        labels = column_names(name, a, e)[0]
        flat = a.reshape(len(a), -1)
        layout = {"dim": [{"label": ",".join(labels), "size": flat.shape[1], "stride": flat.shape[1]}],
                  "data_offset": 0}
        for k, row in enumerate(flat):
            yield f"/{key}/{name}", "std_msgs/Float64MultiArray", float(t[k]), {"layout": layout,
                                                                                 "data": row.tolist()}
    if kind == "quadruped":
        yield from _quadruped(key, e, t, joints)


def _quadruped(key: str, e: EntryRecord, t: np.ndarray, joints: Sequence[str]) -> Iterator[Message]:
    x = np.asarray(e.arrays["state"], dtype=np.float64)
    u = np.asarray(e.arrays["control"], dtype=np.float64)
    board = np.asarray(e.arrays["board_pos"], dtype=np.float64)
    names = list(joints) or list(e.columns["state"][12:24])
    trunk = rpy_matrices(x[:, 3:6])
    for k, tk in enumerate(t.tolist()):
        h = _header(tk)
        q = quaternion_xyzw(trunk[k])
        yield f"/{key}/base_pose", "geometry_msgs/PoseStamped", tk, {"header": h, "pose": {
            "position": _xyz(x[k, 0:3]), "orientation": dict(zip("xyzw", q.tolist(), strict=True))}}
        uk = u[min(k, len(u) - 1)]  # a control holds on [t_k, t_k+1): the last knot keeps the last one
        yield f"/{key}/joint_states", "sensor_msgs/JointState", tk, {
            "header": h, "name": names, "position": x[k, 12:24].tolist(), "velocity": uk[12:24].tolist(),
            "effort": []}
        for i, leg in enumerate(LEGS):
            yield f"/{key}/foot_force/{leg}", "geometry_msgs/WrenchStamped", tk, {
                "header": h, "wrench": {"force": _xyz(uk[3 * i:3 * i + 3]), "torque": _xyz((0.0, 0.0, 0.0))}}
        yaw, roll = board[k, 3], x[k, 26]
        qb = quaternion_xyzw(board_rotations(yaw, roll))
        yield f"/{key}/board_pose", "geometry_msgs/PoseStamped", tk, {"header": h, "pose": {
            "position": _xyz(board[k, 0:3]), "orientation": dict(zip("xyzw", qb.tolist(), strict=True))}}
        yield f"/{key}/board_twist", "geometry_msgs/TwistStamped", tk, {"header": h, "twist": {
            "linear": _xyz((x[k, 24], x[k, 25], 0.0)), "angular": _xyz((x[k, 27], 0.0, 0.0))}}
