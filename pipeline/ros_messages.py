"""The ROS 2 messages of an MCAP export (:mod:`skatelib.pipeline.ros_bag`): their definitions (the
concatenated ``.msg`` texts a ROS 2 bag stores, named ``package/msg/Type`` as ``ros2 bag record``
writes them) and messages as dictionaries for ``mcap_ros2``'s CDR writer."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np
from skatelib.library.channel_diff import column_names
from skatelib.library.channels import LEGS
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


_TRANSFORM = "MSG: geometry_msgs/Transform\ngeometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n"
_TRANSFORM_STAMPED = ("MSG: geometry_msgs/TransformStamped\nstd_msgs/Header header\nstring child_frame_id\n"
                      "geometry_msgs/Transform transform\n")

POSE, JOINTS, WRENCH, TWIST, ARRAY = ("geometry_msgs/msg/PoseStamped", "sensor_msgs/msg/JointState",
                                      "geometry_msgs/msg/WrenchStamped", "geometry_msgs/msg/TwistStamped",
                                      "std_msgs/msg/Float64MultiArray")
TF, STRING = "tf2_msgs/msg/TFMessage", "std_msgs/msg/String"
DEFINITIONS = {
    POSE: _definition("std_msgs/Header header\ngeometry_msgs/Pose pose\n", _HEADER, _TIME, _POSE, _POINT, _QUAT),
    JOINTS: _definition(
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n",
        _HEADER, _TIME),
    WRENCH: _definition(
        "std_msgs/Header header\ngeometry_msgs/Wrench wrench\n", _HEADER, _TIME,
        "MSG: geometry_msgs/Wrench\ngeometry_msgs/Vector3 force\ngeometry_msgs/Vector3 torque\n", _VECTOR3),
    TWIST: _definition(
        "std_msgs/Header header\ngeometry_msgs/Twist twist\n", _HEADER, _TIME,
        "MSG: geometry_msgs/Twist\ngeometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n", _VECTOR3),
    ARRAY: _definition(
        "std_msgs/MultiArrayLayout layout\nfloat64[] data\n",
        "MSG: std_msgs/MultiArrayLayout\nstd_msgs/MultiArrayDimension[] dim\nuint32 data_offset\n",
        "MSG: std_msgs/MultiArrayDimension\nstring label\nuint32 size\nuint32 stride\n"),
    TF: _definition("geometry_msgs/TransformStamped[] transforms\n", _TRANSFORM_STAMPED, _HEADER, _TIME,
                    _TRANSFORM, _VECTOR3, _QUAT),
    STRING: "string data\n",
}

WORLD = "world"  # the fixed frame of every pose, force and transform


def _header(t: float) -> dict[str, Any]:
    return {"stamp": stamp(t), "frame_id": WORLD}


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


def transform(stamp: dict[str, Any], parent: str, child: str, M: np.ndarray) -> dict[str, Any]:
    """A ``geometry_msgs/TransformStamped``: the pose of ``child`` in ``parent`` (a 4x4 transform)."""
    q = quaternion_xyzw(M[:3, :3])
    return {"header": {"stamp": stamp, "frame_id": parent}, "child_frame_id": child,
            "transform": {"translation": _xyz(M[:3, 3]), "rotation": dict(zip("xyzw", q.tolist(), strict=True))}}


def stamp(t: float) -> dict[str, int]:
    """A ``builtin_interfaces/Time`` of ``t`` [s] >= 0."""
    sec, nanosec = divmod(round(t * 1e9), 1_000_000_000)
    return {"sec": sec, "nanosec": nanosec}


def arrays(e: EntryRecord, times: np.ndarray) -> Iterator[tuple[str, float, dict[str, Any]]]:
    """Each per-knot array of the entry, knot by knot: (array name, time [s], a
    ``std_msgs/Float64MultiArray`` with its dimension labelled by the column names)."""
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
            yield name, float(times[k]), {"layout": layout, "data": row.tolist()}


def quadruped(e: EntryRecord, times: np.ndarray) -> Iterator[tuple[str, str, float, dict[str, Any]]]:
    """The quadruped's own messages, knot by knot: (topic under ``/skatelib/``, type, time [s],
    fields): ``base_pose``, ``foot_force/<leg>``, ``board_pose``, ``board_twist`` (module
    docstring of :mod:`.ros_bag`)."""
    x = np.asarray(e.arrays["state"], dtype=np.float64)
    u = np.asarray(e.arrays["control"], dtype=np.float64)
    board = np.asarray(e.arrays["board_pos"], dtype=np.float64)
    trunk = rpy_matrices(x[:, 3:6])
    for k, tk in enumerate(times.tolist()):
        h = _header(tk)
        q = quaternion_xyzw(trunk[k])
        yield "base_pose", POSE, tk, {"header": h, "pose": {
            "position": _xyz(x[k, 0:3]), "orientation": dict(zip("xyzw", q.tolist(), strict=True))}}
        uk = u[min(k, len(u) - 1)]  # a control holds on [t_k, t_k+1): the last knot keeps the last one
        for i, leg in enumerate(LEGS):
            yield f"foot_force/{leg}", WRENCH, tk, {
                "header": h, "wrench": {"force": _xyz(uk[3 * i:3 * i + 3]), "torque": _xyz((0.0, 0.0, 0.0))}}
        yaw, roll = board[k, 3], x[k, 26]
        qb = quaternion_xyzw(board_rotations(yaw, roll))
        yield "board_pose", POSE, tk, {"header": h, "pose": {
            "position": _xyz(board[k, 0:3]), "orientation": dict(zip("xyzw", qb.tolist(), strict=True))}}
        yield "board_twist", TWIST, tk, {"header": h, "twist": {
            "linear": _xyz((x[k, 24], x[k, 25], 0.0)), "angular": _xyz((x[k, 27], 0.0, 0.0))}}
