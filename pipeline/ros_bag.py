"""A motion library as one ROS 2 bag (MCAP, CDR) that Foxglove draws and ``ros2 bag play`` plays.

One bag, the entries one after another in time (file order, :data:`GAP_S` apart): a library's
entries share one robot, so one ``/robot_description`` and one set of topics serve them all, a
viewer opens one file and scrubs from entry to entry, and ``ros2 bag play`` replays the whole
library as a robot would ride it. Which entry plays when: ``/skatelib/entry``
(``std_msgs/String``, the key, once at each entry's first knot) and the metadata record
:data:`INDEX` (each key -> ``{"start_s", "end_s"}`` on the bag's clock).

Topics, every name valid under ROS 2's rules (:func:`topic`):

* ``/robot_description`` (``std_msgs/String``): the library's URDF, latched (transient local).
* ``/tf_static`` (latched): the URDF's fixed joints; ``/tf`` (``tf2_msgs/TFMessage``) at every
  knot: ``world`` -> the URDF's root link (the trunk), each moving joint's parent -> child link at
  the entry's joint angles (:mod:`.urdf_kinematics`), and for the quadruped ``world`` -> ``board``.
* ``/joint_states`` (``sensor_msgs/JointState``): the URDF's joint names, angles and rates.
* ``/skatelib/arrays/<array>`` (``std_msgs/Float64MultiArray``): every per-knot array.
* The quadruped's ``/skatelib/base_pose``, ``foot_force/<leg>``, ``board_pose``, ``board_twist``.
"""

from __future__ import annotations

import io
import json
import re
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any, Final

import numpy as np
from skatelib.library import schema
from skatelib.library.channels import I_BOARD_ROLL, S_Q, S_RPY
from skatelib.library.errors import ModelError, SkatelibError
from skatelib.library.reader import LibraryData
from skatelib.library.records import EntryRecord
from skatelib.library.rotations import board_rotations, quaternion_matrices, rpy_matrices
from skatelib.pipeline import ros_messages as msg
from skatelib.pipeline.urdf_kinematics import joint_transforms, root_link, urdf_joints
from skatelib.runtime import MotionLibrary

GAP_S: Final = 1.0  # from one entry's last knot to the next one's first [s]
NAMESPACE: Final = "skatelib"
ENTRY_TOPIC: Final = f"/{NAMESPACE}/entry"
INDEX: Final = "skatelib.entries"  # the MCAP metadata record of the entries' times
BOARD_FRAME: Final = "board"
# The QoS rosbag2 records for a topic (YAML, the integer enums of rmw): reliable, keep last; a
# latched topic (transient local, depth 1) reaches a subscriber that joins after it was sent, as
# /robot_description and /tf_static do from robot_state_publisher. rosbag2's MCAP reader decodes
# the integer form (Humble's) when the bag has a "rosbag2" metadata record without
# "serialized_metadata" (it then reads the bag as metadata version 8); without that record it
# expects the names of later distributions.
ROSBAG2_RECORD: Final = ("rosbag2", {"ROS_DISTRO": "humble"})
_QOS = ("- history: 1\n  depth: {depth}\n  reliability: 1\n  durability: {durability}\n"
        "  deadline:\n    sec: 0\n    nsec: 0\n  lifespan:\n    sec: 0\n    nsec: 0\n  liveliness: 1\n"
        "  liveliness_lease_duration:\n    sec: 0\n    nsec: 0\n  avoid_ros_namespace_conventions: false\n")
LATCHED_QOS: Final = _QOS.format(depth=1, durability=1)
VOLATILE_QOS: Final = _QOS.format(depth=10, durability=2)


def topic_token(name: str) -> str:
    """A ROS 2 name token for ``name``: characters other than letters, digits and ``_`` become
    ``_``, runs of ``_`` one, and a token starting with a digit gets a leading ``_``."""
    token = re.sub(r"_+", "_", re.sub(r"[^A-Za-z0-9_]", "_", name)) or "_"
    return "_" + token if token[0].isdigit() else token


def topic(*parts: str) -> str:
    """The fully qualified topic ``/<namespace>/<part>/...``, each part made a token
    (:func:`topic_token`)."""
    return "/" + "/".join(topic_token(p) for p in (NAMESPACE, *parts))


def timeline(entries: dict[str, EntryRecord]) -> dict[str, tuple[float, float]]:
    """Each entry's (start, end) on the bag's clock [s]: the first at 0, each next one
    :data:`GAP_S` after the previous one's last knot."""
    out, start = {}, 0.0
    for key, e in entries.items():
        t = np.asarray(e.arrays["t"], dtype=np.float64)
        out[key] = (start, start + float(t[-1] - t[0]))
        start = out[key][1] + GAP_S
    return out


@dataclass(frozen=True)
class RobotMotion:
    """An entry's floating base and joints at its knots."""

    base: np.ndarray  # (K, 4, 4) world -> the URDF's root link
    names: list[str]  # the joints, the URDF's names
    q: np.ndarray  # (K, n) their angles [rad]
    dq: np.ndarray | None  # (K, n) their rates [rad/s] (None: not stored)


def robot_motion(lib: MotionLibrary, e: EntryRecord) -> RobotMotion | None:
    """The entry's :class:`RobotMotion`; None for an entry without joint angles (a humanoid plan
    without its whole body)."""
    base = np.tile(np.eye(4), (len(e.arrays["t"]), 1, 1))
    if lib.kind == "quadruped":
        x, u = (np.asarray(e.arrays[n], dtype=np.float64) for n in ("state", "control"))
        R = rpy_matrices(x[:, S_RPY])
        base[:, :3, :3] = R
        base[:, :3, 3] = x[:, 0:3] - R @ lib.quadruped_model.arrays.robot_com_offset_m  # the state's COM
        config = json.loads(str(lib.attrs.get(schema.A_CONFIG_RESOLVED, "{}")))
        names = config.get("robot", {}).get("joint_names") or [c.removeprefix("q_") for c in e.columns["state"][S_Q]]
        dq = u[np.minimum(np.arange(len(x)), len(u) - 1), S_Q]  # a control holds on [t_k, t_k+1)
        return RobotMotion(base, list(names), x[:, S_Q], dq)
    if schema.D_JOINTS not in e.arrays or schema.D_BASE_POSE not in e.arrays:
        return None
    pose = np.asarray(e.arrays[schema.D_BASE_POSE], dtype=np.float64)
    base[:, :3, :3] = quaternion_matrices(pose[:, 3:7])
    base[:, :3, 3] = pose[:, 0:3]
    rates = e.arrays.get(schema.D_JOINT_VELOCITIES)
    return RobotMotion(base, list(e.columns[schema.D_JOINTS]), np.asarray(e.arrays[schema.D_JOINTS], dtype=np.float64),
                       None if rates is None else np.asarray(rates, dtype=np.float64))


def _robot_messages(urdf: str, e: EntryRecord, lib: MotionLibrary,
                    times: np.ndarray) -> Iterator[tuple[str, str, float, Any]]:
    """``/tf`` and ``/joint_states`` of one entry, knot by knot (module docstring)."""
    motion = robot_motion(lib, e)
    if motion is None:
        return
    base, names, q = motion.base, motion.names, motion.q
    column = {n: i for i, n in enumerate(names)}
    chain = []
    for j in (j for j in urdf_joints(urdf) if j.moves):
        if j.name not in column:
            raise ModelError(f"the robot description's joint {j.name!r} has no angles in entry {e.key} "
                             f"(its joints: {', '.join(names)}); the URDF and the library disagree: rebuild it")
        chain.append((j.parent, j.child, joint_transforms(j, q[:, column[j.name]])))
    root = root_link(urdf)
    board = None
    if lib.kind == "quadruped":
        b, x = np.asarray(e.arrays["board_pos"], dtype=np.float64), np.asarray(e.arrays["state"], dtype=np.float64)
        board = np.tile(np.eye(4), (len(b), 1, 1))
        board[:, :3, :3] = board_rotations(b[:, 3], x[:, I_BOARD_ROLL])
        board[:, :3, 3] = b[:, 0:3]
    for k, tk in enumerate(times.tolist()):
        s = msg.stamp(tk)
        tf = [msg.transform(s, msg.WORLD, root, base[k])]
        tf += [msg.transform(s, parent, child, M[k]) for parent, child, M in chain]
        if board is not None:
            tf.append(msg.transform(s, msg.WORLD, BOARD_FRAME, board[k]))
        yield "/tf", msg.TF, tk, {"transforms": tf}
        yield "/joint_states", msg.JOINTS, tk, {"name": names, "position": q[k].tolist(), "effort": [],
                                                "velocity": [] if motion.dq is None else motion.dq[k].tolist(),
                   "header": {"stamp": s, "frame_id": ""}}


def bag_messages(lib: MotionLibrary, entries: dict[str, EntryRecord]) -> Iterator[tuple[str, str, float, Any]]:
    """Every message of the bag as (topic, type, time [s], fields), the latched ones first."""
    urdf = lib.urdf
    if urdf:
        yield "/robot_description", msg.STRING, 0.0, {"data": urdf}
        fixed = [msg.transform(msg.stamp(0.0), j.parent, j.child, j.origin) for j in urdf_joints(urdf) if not j.moves]
        yield "/tf_static", msg.TF, 0.0, {"transforms": fixed}
    for key, (start, _) in timeline(entries).items():
        e = entries[key]
        t = np.asarray(e.arrays["t"], dtype=np.float64)
        times = start + (t - t[0])
        yield ENTRY_TOPIC, msg.STRING, start, {"data": key}
        if urdf:
            yield from _robot_messages(urdf, e, lib, times)
        for name, tk, fields in msg.arrays(e, times):
            yield topic("arrays", name), msg.ARRAY, tk, fields
        if lib.kind == "quadruped":
            for name, kind, tk, fields in msg.quadruped(e, times):
                yield topic(*name.split("/")), kind, tk, fields


def write_bag(data: LibraryData, entries: dict[str, EntryRecord]) -> bytes:
    """The bag's bytes (module docstring) of ``entries`` of the library ``data``.

    Raises:
        ModelError: The library's URDF cannot be read or names a joint the entries lack.
        SkatelibError: Two arrays whose names make one topic.
    """
    from mcap.writer import Writer
    from mcap_ros2._dynamic import serialize_dynamic  # mcap_ros2's CDR encoder of a .msg text

    lib = MotionLibrary(data)
    buffer = io.BytesIO()
    writer = Writer(buffer)
    writer.start(profile="ros2", library="skatelib")
    schemas: dict[str, tuple[int, Any]] = {}
    channels: dict[str, tuple[int, str]] = {}
    for name, text in msg.DEFINITIONS.items():
        schemas[name] = (writer.register_schema(name, "ros2msg", text.encode()), serialize_dynamic(name, text)[name])
    _check_topics(entries)
    for topic_name, kind, t, fields in bag_messages(lib, entries):
        if topic_name not in channels:
            qos = LATCHED_QOS if topic_name in ("/robot_description", "/tf_static") else VOLATILE_QOS
            channels[topic_name] = (writer.register_channel(topic_name, "cdr", schemas[kind][0],
                                                            {"offered_qos_profiles": qos}), kind)
        channel, _ = channels[topic_name]
        ns = round(t * 1e9)
        writer.add_message(channel, log_time=ns, publish_time=ns, data=schemas[kind][1](fields))
    writer.add_metadata(*ROSBAG2_RECORD)
    writer.add_metadata(INDEX, {k: json.dumps({"start_s": round(a, 9), "end_s": round(b, 9)})
                                for k, (a, b) in timeline(entries).items()})
    writer.finish()
    return buffer.getvalue()


def _check_topics(entries: dict[str, EntryRecord]) -> None:
    """Refuse two arrays whose names make one topic (``a.b`` and ``a_b``) rather than mix them."""
    seen: dict[str, str] = {}
    for e in entries.values():
        for name in e.arrays:
            other = seen.setdefault(topic("arrays", name), name)
            if other != name:
                raise SkatelibError(f"entry {e.key}: arrays {other!r} and {name!r} make one ROS 2 topic "
                                    f"{topic('arrays', name)}; rename one of them")

