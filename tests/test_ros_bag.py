"""The ROS 2 bag of ``skatelib export --format mcap`` as ROS 2 and Foxglove see it: opened with the
MCAP reader and mcap-ros2-support's decoder, every topic name checked against ROS 2's naming rules
(a validator written here from design.ros2.org's "Topic and Service names", not the exporter's
sanitizer), every schema against ROS 2's message definitions (written here field by field), the
entries one after another, ``/robot_description`` latched, every URDF joint in ``/tf`` or
``/joint_states``, and the ``/tf`` chain against pinocchio's forward kinematics."""

from __future__ import annotations

import json
import string
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from skatelib.library.reader import read_library

from tests.helpers import run_cli

reader = pytest.importorskip("mcap.reader")
decoder = pytest.importorskip("mcap_ros2.decoder")
pin = pytest.importorskip("pinocchio")

REFERENCE = Path(__file__).parent / "data" / "tiny-reference.h5"  # two solved quadruped entries
_ALLOWED = set(string.ascii_letters + string.digits + "_/")


def ros2_topic_problems(name: str) -> list[str]:
    """What makes ``name`` no valid fully qualified ROS 2 topic name (empty: valid). The rules of
    design.ros2.org/articles/topic_and_service_names.html, for a name as a bag stores it (expanded:
    no ``~`` or ``{}`` substitutions left): not empty; starts with ``/``; only letters, digits,
    ``_`` and ``/``; no token starting with a digit; no trailing ``/``; no repeated ``/``; no
    repeated ``_``; at most 256 characters on DDS with its ``rt`` prefix."""
    problems = []
    if not name:
        return ["empty"]
    if name[0] != "/":
        problems.append("not fully qualified (no leading /)")
    if set(name) - _ALLOWED:
        problems.append(f"characters {''.join(sorted(set(name) - _ALLOWED))!r} not allowed")
    if len(name) > 1 and name[-1] == "/":
        problems.append("ends with /")
    if "//" in name:
        problems.append("repeated /")
    if "__" in name:
        problems.append("repeated _")
    if any(tok[:1].isdigit() for tok in name.split("/")):
        problems.append("a token starts with a digit")
    if len("rt" + name) > 256:
        problems.append("longer than DDS allows")
    return problems


def test_the_validator_refuses_what_ros2_refuses():
    """Negative control: the old export's names and each broken rule are refused; ordinary names pass."""
    for bad in ("/v0.20_s2/board_pos", "/v0.20_s2/foot_force/FL", "/0.5/tf", "/a/2b", "tf", "/a/", "/a//b",
                "/a__b", "/a-b", "/a b", "/~/x", "/{ns}/x", "", "/" + "a" * 300):
        assert ros2_topic_problems(bad), bad
    for good in ("/tf", "/tf_static", "/robot_description", "/joint_states", "/skatelib/arrays/foot_pos",
                 "/skatelib/foot_force/FL", "/_private/x1", "/a_b/c2"):
        assert ros2_topic_problems(good) == [], good


@given(st.lists(st.text(max_size=12), min_size=1, max_size=3))
def test_any_array_name_makes_a_valid_topic(parts):
    """The exporter's topic of any short array name (dots, digits first, dashes, unicode, empty) is valid."""
    from skatelib.pipeline.ros_bag import topic

    assert ros2_topic_problems(topic(*parts)) == []


# ROS 2's definitions (common_interfaces, geometry2, rcl_interfaces), field by field.
OFFICIAL = {
    "builtin_interfaces/Time": ["int32 sec", "uint32 nanosec"],
    "std_msgs/Header": ["builtin_interfaces/Time stamp", "string frame_id"],
    "std_msgs/String": ["string data"],
    "std_msgs/Float64MultiArray": ["MultiArrayLayout layout", "float64[] data"],
    "std_msgs/MultiArrayLayout": ["MultiArrayDimension[] dim", "uint32 data_offset"],
    "std_msgs/MultiArrayDimension": ["string label", "uint32 size", "uint32 stride"],
    "geometry_msgs/Vector3": ["float64 x", "float64 y", "float64 z"],
    "geometry_msgs/Point": ["float64 x", "float64 y", "float64 z"],
    "geometry_msgs/Quaternion": ["float64 x 0", "float64 y 0", "float64 z 0", "float64 w 1"],
    "geometry_msgs/Pose": ["Point position", "Quaternion orientation"],
    "geometry_msgs/PoseStamped": ["std_msgs/Header header", "Pose pose"],
    "geometry_msgs/Transform": ["Vector3 translation", "Quaternion rotation"],
    "geometry_msgs/TransformStamped": ["std_msgs/Header header", "string child_frame_id", "Transform transform"],
    "geometry_msgs/Wrench": ["Vector3 force", "Vector3 torque"],
    "geometry_msgs/WrenchStamped": ["std_msgs/Header header", "Wrench wrench"],
    "geometry_msgs/Twist": ["Vector3 linear", "Vector3 angular"],
    "geometry_msgs/TwistStamped": ["std_msgs/Header header", "Twist twist"],
    "sensor_msgs/JointState": ["std_msgs/Header header", "string[] name", "float64[] position",
                               "float64[] velocity", "float64[] effort"],
    "tf2_msgs/TFMessage": ["geometry_msgs/TransformStamped[] transforms"],
}


def _fields(line_type: str, package: str) -> str:
    """A field's type as its package names it (``Point`` in geometry_msgs is geometry_msgs/Point)."""
    base = line_type.removesuffix("[]")
    if "/" in base or base in ("int32", "uint32", "float64", "string"):
        return line_type
    return f"{package}/{line_type}"


def schema_problems(name: str, text: str) -> list[str]:
    """How a bag's schema (a ``.msg`` text with its dependencies) differs from ROS 2's definitions."""
    main = name.replace("/msg/", "/")
    sections = [(main, text.split("=" * 80)[0])]
    for part in text.split("=" * 80)[1:]:
        head, _, body = part.strip("\n").partition("\n")
        sections.append((head.removeprefix("MSG: ").strip(), body))
    problems = []
    for typ, body in sections:
        got = [" ".join(line.split()) for line in body.splitlines() if line.strip() and not line.startswith("#")]
        package = typ.split("/")[0]
        want = [" ".join([_fields(f.split()[0], package), *f.split()[1:]]) for f in OFFICIAL.get(typ, ["?"])]
        got = [" ".join([_fields(f.split()[0], package), *f.split()[1:]]) for f in got]
        if got != want:
            problems.append(f"{typ}: {got} != ROS 2's {want}")
    return problems


def test_the_schema_check_catches_a_wrong_definition():
    """Negative control: a JointState without ``effort`` and a Time with a float ``sec`` are refused."""
    from skatelib.pipeline import ros_messages as msg

    assert schema_problems(msg.JOINTS, msg.DEFINITIONS[msg.JOINTS]) == []
    assert schema_problems(msg.JOINTS, msg.DEFINITIONS[msg.JOINTS].replace("float64[] effort\n", ""))
    assert schema_problems(msg.TF, msg.DEFINITIONS[msg.TF].replace("int32 sec", "float64 sec"))


def read_bag(path: Path) -> tuple[dict[str, list[tuple[int, Any]]], dict[str, Any], dict[str, dict[str, str]]]:
    """Every message decoded (topic -> [(log time [ns], message)]), the channels by topic, and the
    metadata records."""
    got: dict[str, list[tuple[int, Any]]] = {}
    with open(path, "rb") as f:
        r = reader.make_reader(f, decoder_factories=[decoder.DecoderFactory()])
        for _, channel, message, m in r.iter_decoded_messages(log_time_order=True):
            got.setdefault(channel.topic, []).append((message.log_time, m))
    with open(path, "rb") as f:
        r = reader.make_reader(f)
        summary = r.get_summary()
        channels = {c.topic: (c, summary.schemas[c.schema_id]) for c in summary.channels.values()}
        metadata = {m.name: m.metadata for m in r.iter_metadata()}
    return got, channels, metadata


@pytest.fixture(scope="module")
def bag(tmp_path_factory):
    out = tmp_path_factory.mktemp("bag") / "reference.mcap"
    r = run_cli(["export", str(REFERENCE), "-f", "mcap", "-o", str(out)])
    assert r.returncode == 0, r.stdout + r.stderr
    return read_bag(out)


def test_every_topic_and_schema_is_ros2s(bag):
    """Every topic name passes the ROS 2 rules; every schema is ROS 2's definition, named
    ``package/msg/Type``; every message decodes (the reader decodes them all in :func:`read_bag`)."""
    got, channels, _ = bag
    assert {t: ros2_topic_problems(t) for t in channels if ros2_topic_problems(t)} == {}
    for topic, (channel, schema) in channels.items():
        assert channel.message_encoding == "cdr" and schema.encoding == "ros2msg"
        assert schema.name.count("/msg/") == 1, schema.name
        assert schema_problems(schema.name, schema.data.decode()) == [], topic
        assert got[topic], topic


def test_the_robot_description_is_latched_and_the_librarys(bag):
    """``/robot_description`` (std_msgs/String) holds the library's URDF, sent once at the bag's
    start with a transient-local QoS (latched: a late subscriber and Foxglove get it), as is
    ``/tf_static``; ``/tf`` is volatile; the QoS in the form rosbag2's MCAP reader decodes."""
    got, channels, _ = bag
    urdf = read_library(REFERENCE).model_text["robot_urdf"]
    assert [m.data for _, m in got["/robot_description"]] == [urdf]
    first = min(ns for msgs in got.values() for ns, _ in msgs)
    for topic in ("/robot_description", "/tf_static"):
        channel, _ = channels[topic]
        assert "durability: 1" in channel.metadata["offered_qos_profiles"]  # rmw: 1 transient local
        assert got[topic][0][0] == first
    assert channels["/robot_description"][1].name == "std_msgs/msg/String"
    assert "durability: 2" in channels["/tf"][0].metadata["offered_qos_profiles"]  # rmw: 2 volatile
    # rosbag2 reads these integer QoS values only from a bag with a "rosbag2" record without
    # serialized_metadata (metadata version 8); without it, Jazzy and later expect policy names.
    _, _, metadata = bag
    assert "ROS_DISTRO" in metadata["rosbag2"] and "serialized_metadata" not in metadata["rosbag2"]


def test_entries_play_one_after_another(bag):
    """``/skatelib/entry`` names each solved entry once, in file order, at its start; the index
    record gives the same times; each entry's /tf messages lie in its own window, the windows do
    not overlap, and its /joint_states carry its joint angles."""
    got, _, metadata = bag
    data = read_library(REFERENCE)
    keys = list(data.entries)
    assert [m.data for _, m in got["/skatelib/entry"]] == keys
    index = {k: json.loads(v) for k, v in metadata["skatelib.entries"].items()}
    assert list(index) == keys
    starts = [ns for ns, _ in got["/skatelib/entry"]]
    assert starts == [round(index[k]["start_s"] * 1e9) for k in keys]
    tf_times = np.array([ns for ns, _ in got["/tf"]])
    joints = got["/joint_states"]
    for k, key in enumerate(keys):
        t = data.entries[key].arrays["t"]
        lo, hi = round(index[key]["start_s"] * 1e9), round(index[key]["end_s"] * 1e9)
        inside = (tf_times >= lo) & (tf_times <= hi)
        assert inside.sum() == len(t)
        if k:
            assert lo > round(index[keys[k - 1]]["end_s"] * 1e9)
        mine = [m for ns, m in joints if lo <= ns <= hi]
        np.testing.assert_array_equal([list(m.position) for m in mine], data.entries[key].arrays["state"][:, 12:24])
        np.testing.assert_allclose(np.array([ns for ns, _ in joints if lo <= ns <= hi]) - lo, t * 1e9, atol=1.0)


def joints_missing(urdf: str, tf_children: set[str], joint_names: set[str]) -> list[str]:
    """The URDF's joints (read here with ElementTree) whose child link is no child frame of /tf or
    /tf_static and whose name is not in /joint_states."""
    missing = []
    for j in ET.fromstring(urdf).iter("joint"):
        child = j.find("child")
        if (child is None or child.get("link") not in tf_children) and j.get("name") not in joint_names:
            missing.append(j.get("name", ""))
    return missing


def test_every_joint_of_the_urdf_is_in_the_bag(bag):
    """Foxglove's check: /tf and /tf_static give every URDF link a pose (each joint's child link
    is a child frame, the root link's parent is ``world``), and /joint_states names the URDF's
    moving joints; negative control: a URDF with one more joint is reported."""
    got, _, _ = bag
    urdf = got["/robot_description"][0][1].data
    children = {t.child_frame_id for _, m in got["/tf"] + got["/tf_static"] for t in m.transforms}
    names = {n for _, m in got["/joint_states"] for n in m.name}
    assert joints_missing(urdf, children, names) == []
    moving = {j.get("name") for j in ET.fromstring(urdf).iter("joint") if j.get("type") != "fixed"}
    assert names == moving and len(moving) == 12
    world = {t.child_frame_id for _, m in got["/tf"] for t in m.transforms if t.header.frame_id == "world"}
    assert world == {"trunk", "board"}
    extra = urdf.replace("</robot>", '<link name="x"/><joint name="extra" type="fixed"><parent link="trunk"/>'
                         '<child link="x"/></joint></robot>')
    assert joints_missing(extra, children, names) == ["extra"]


def _matrix(t: Any) -> np.ndarray:
    q, p = t.transform.rotation, t.transform.translation
    M = np.eye(4)
    M[:3, :3] = pin.Quaternion(q.w, q.x, q.y, q.z).toRotationMatrix()
    M[:3, 3] = [p.x, p.y, p.z]
    return M


def chained(tf: list[Any], static: list[Any], frame: str) -> np.ndarray:
    """``world`` -> ``frame`` by composing the bag's transforms of one knot, as tf2 would."""
    parent = {t.child_frame_id: (t.header.frame_id, _matrix(t)) for t in [*static, *tf]}
    M = np.eye(4)
    while frame != "world":
        frame, step = parent[frame][0], parent[frame][1]
        M = step @ M
    return M


def fk_deviation(got: dict[str, list[tuple[int, Any]]], urdf_for_pinocchio: str) -> float:
    """The largest distance [m] over the second entry's knots between each foot and calf frame
    chained from /tf and pinocchio's forward kinematics of ``urdf_for_pinocchio`` at the entry's
    joint angles, the trunk placed as ``skatelib inspect`` places it (state COM minus the
    rotated COM offset of the library's /model)."""
    from skatelib.library.rotations import rpy_matrices
    from skatelib.runtime import MotionLibrary

    lib = MotionLibrary.open(REFERENCE)
    e = list(lib)[1]
    model = pin.buildModelFromXML(urdf_for_pinocchio, pin.JointModelFreeFlyer())
    data = model.createData()
    com_off = lib.quadruped_model.arrays.robot_com_offset_m
    names = ["FL_abad", "FL_hip", "FL_knee", "FR_abad", "FR_hip", "FR_knee", "RL_abad", "RL_hip", "RL_knee",
             "RR_abad", "RR_hip", "RR_knee"]
    idx = [model.joints[model.getJointId(n)].idx_q for n in names]
    lo = next(ns for ns, m in got["/skatelib/entry"] if m.data == e.key)
    tfs = [m.transforms for ns, m in got["/tf"] if ns >= lo]
    static = got["/tf_static"][0][1].transforms
    worst = 0.0
    for k in range(len(e.t)):
        R = rpy_matrices(e.state[k:k + 1, 3:6])[0]
        q = pin.neutral(model)
        q[:3] = e.state[k, 0:3] - R @ com_off
        q[3:7] = pin.Quaternion(R).coeffs()
        q[idx] = e.state[k, 12:24]
        pin.framesForwardKinematics(model, data, q)
        for leg in ("FL", "FR", "RL", "RR"):
            for frame in (f"{leg}_foot", f"{leg}_calf"):
                want = data.oMf[model.getFrameId(frame)]
                M = chained(tfs[k], static, frame)
                worst = max(worst, float(np.linalg.norm(M[:3, 3] - want.translation)),
                            float(np.abs(M[:3, :3] - want.rotation).max()))
    return worst


def test_tf_matches_pinocchio(bag):
    """At every knot of the second entry, each foot and calf chained from /tf (world -> trunk ->
    abad -> thigh -> calf, + the static foot) is pinocchio's forward kinematics to 1e-12;
    negative control: pinocchio of a URDF whose FL knee turns the other way disagrees by cm."""
    got, _, _ = bag
    urdf = got["/robot_description"][0][1].data
    assert fk_deviation(got, urdf) < 1e-12
    flipped = urdf.replace('<joint name="FL_knee" type="revolute">', '<joint name="FL_knee" type="revolute">'
                           '<axis xyz="0 1 0"/>', 1)
    root = ET.fromstring(flipped)
    for j in root.iter("joint"):  # the original axis element goes: one axis per joint
        axes = j.findall("axis")
        for extra in axes[1:]:
            j.remove(extra)
    assert fk_deviation(got, ET.tostring(root, encoding="unicode")) > 0.01


def test_an_mcap_without_the_extension_is_refused(tmp_path):
    """``-o exp_mcap``: exit 2 naming the file and the .mcap it needs; nothing written."""
    r = run_cli(["export", str(REFERENCE), "-f", "mcap", "-o", str(tmp_path / "exp_mcap")])
    assert r.returncode == 2, r.stdout + r.stderr
    assert "exp_mcap" in r.stderr and "ending in .mcap" in r.stderr and "exp_mcap.mcap" in r.stderr
    assert list(tmp_path.iterdir()) == []


def humanoid_bag_problems(library: Path, out: Path) -> tuple[list[str], float]:
    """Export a humanoid library and return what is wrong with its bag (invalid topic names, URDF
    joints missing) and the largest deviation of its soles, shanks, thighs and torso chained from
    /tf from pinocchio's forward kinematics at the stored waist pose and joint angles."""
    from skatelib.library import schema
    from skatelib.pipeline.exports import export

    export(library, "mcap", out)
    got, channels, _ = read_bag(out)
    problems = [f"{t}: {p}" for t in channels for p in ros2_topic_problems(t)]
    data = read_library(library)
    urdf = data.model_text["robot_urdf"]
    children = {t.child_frame_id for _, m in got["/tf"] + got["/tf_static"] for t in m.transforms}
    problems += joints_missing(urdf, children, {n for _, m in got["/joint_states"] for n in m.name})
    model = pin.buildModelFromXML(urdf, pin.JointModelFreeFlyer())
    pdata = model.createData()
    tf = dict(got["/tf"])
    static = got["/tf_static"][0][1].transforms
    starts = {m.data: ns for ns, m in got["/skatelib/entry"]}
    worst = 0.0
    for key, e in data.entries.items():
        base, angles, t = e.arrays[schema.D_BASE_POSE], e.arrays[schema.D_JOINTS], e.arrays["t"]
        idx = [model.joints[model.getJointId(n)].idx_q for n in e.columns[schema.D_JOINTS]]
        for k in range(0, len(t), max(1, len(t) // 25)):
            q = pin.neutral(model)
            q[:7], q[idx] = base[k], angles[k]  # position, quaternion x y z w: pinocchio's order
            pin.framesForwardKinematics(model, pdata, q)
            knot = tf[starts[key] + round((t[k] - t[0]) * 1e9)].transforms
            for frame in ("L_sole", "R_sole", "L_shank", "R_thigh", "torso"):
                want, M = pdata.oMf[model.getFrameId(frame)], chained(knot, static, frame)
                worst = max(worst, float(np.abs(M[:3, 3] - want.translation).max()),
                            float(np.abs(M[:3, :3] - want.rotation).max()))
    return problems, worst


def test_the_humanoids_bag(hrp2_walk_path, tmp_path):
    """The HRP-2 walk's bag: valid names, every joint of its URDF, /tf on pinocchio to 1e-12."""
    problems, worst = humanoid_bag_problems(hrp2_walk_path, tmp_path / "walk.mcap")
    assert problems == [] and worst < 1e-12, (problems, worst)
