"""The URDF's joints chained by :mod:`skatelib.pipeline.urdf_kinematics` (what the ROS 2 bag's /tf
carries) equal pinocchio's forward kinematics of the same text: the robots' URDFs at random
angles, and random chains whose origins have every rpy and whose joints every axis and type."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skatelib.library.errors import ModelError
from skatelib.pipeline.config import CONFIG_DIR
from skatelib.pipeline.urdf_kinematics import joint_transforms, root_link, urdf_joints

pin = pytest.importorskip("pinocchio")


def chained_poses(urdf: str, q: dict[str, float]) -> dict[str, np.ndarray]:
    """Each link's pose in its root link's frame, composing :func:`joint_transforms` down the tree."""
    joints = urdf_joints(urdf)
    poses = {root_link(urdf): np.eye(4)}
    while len(poses) <= len(joints):
        for j in joints:
            if j.parent in poses and j.child not in poses:
                poses[j.child] = poses[j.parent] @ joint_transforms(j, np.array([q.get(j.name, 0.0)]))[0]
    return poses


def deviation(urdf: str, q: dict[str, float]) -> float:
    """The largest difference between the chained poses and pinocchio's (fixed base) of every link."""
    model = pin.buildModelFromXML(urdf)
    data = model.createData()
    qp = pin.neutral(model)
    for name, value in q.items():
        j = model.joints[model.getJointId(name)]
        if j.nq == 2:  # a continuous joint: pinocchio stores (cos, sin)
            qp[j.idx_q:j.idx_q + 2] = np.cos(value), np.sin(value)
        else:
            qp[j.idx_q] = value
    pin.framesForwardKinematics(model, data, qp)
    worst = 0.0
    for link, M in chained_poses(urdf, q).items():
        want = data.oMf[model.getFrameId(link, pin.FrameType.BODY)]
        worst = max(worst, float(np.abs(M[:3, :3] - want.rotation).max()),
                    float(np.abs(M[:3, 3] - want.translation).max()))
    return worst


@pytest.mark.parametrize("robot", ["cyberdog2.urdf", "hrp2_class.urdf"])
def test_the_robots_match_pinocchio(robot):
    """Every link of each robot's URDF at 20 random joint angles."""
    urdf = (CONFIG_DIR / "robots" / robot).read_text()
    moving = [j.name for j in urdf_joints(urdf) if j.moves]
    rng = np.random.default_rng(0)
    for _ in range(20):
        assert deviation(urdf, dict(zip(moving, rng.uniform(-2.0, 2.0, len(moving)), strict=True))) < 1e-12


_LIMIT = '<limit lower="-5" upper="5" effort="1" velocity="1"/>'


def _chain(rpys: list[list[float]], axes: list[list[float]], kinds: list[str]) -> str:
    links = "".join(f'<link name="l{i}"/>' for i in range(len(kinds) + 1))
    joints = "".join(
        f'<joint name="j{i}" type="{k}"><parent link="l{i}"/><child link="l{i + 1}"/>'
        f'<origin xyz="0.1 {0.02 * i} -0.05" rpy="{r[0]} {r[1]} {r[2]}"/><axis xyz="{a[0]} {a[1]} {a[2]}"/>'
        + (_LIMIT if k in ("revolute", "prismatic") else "") + "</joint>"
        for i, (r, a, k) in enumerate(zip(rpys, axes, kinds, strict=True)))
    return f'<robot name="chain">{links}{joints}</robot>'


angle = st.floats(-3.1, 3.1)
axis = st.lists(st.floats(-1, 1), min_size=3, max_size=3).filter(lambda a: np.linalg.norm(a) > 0.1)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.lists(angle, min_size=3, max_size=3), axis,
                          st.sampled_from(["revolute", "continuous", "prismatic", "fixed"]), angle),
                min_size=1, max_size=4))
def test_random_chains_match_pinocchio(links):
    """Origins with any rpy (fixed axes x, y, z), any axis, each joint type, any position."""
    urdf = _chain([r for r, _, _, _ in links], [a for _, a, _, _ in links], [k for _, _, k, _ in links])
    q = {f"j{i}": v for i, (_, _, k, v) in enumerate(links) if k != "fixed"}
    assert deviation(urdf, q) < 1e-9


def test_a_wrong_rpy_convention_would_be_caught(monkeypatch):
    """Negative control: the chain's rpy read as the inverse rotation is off pinocchio."""
    from skatelib.pipeline import urdf_kinematics as uk

    urdf = _chain([[0.4, -0.7, 1.1]], [[0.0, 0.0, 1.0]], ["fixed"])
    assert deviation(urdf, {}) < 1e-12
    true_rpy = uk.rpy_matrix
    monkeypatch.setattr(uk, "rpy_matrix", lambda rpy: true_rpy(rpy).T)
    assert deviation(urdf, {}) > 0.1


def test_bad_urdfs_are_refused_with_the_joint_named():
    """A joint of an unknown type, one without a child, an origin of two numbers, two roots."""
    ok = '<robot name="r"><link name="a"/><link name="b"/>'
    for body, words in [
        ('<joint name="j" type="floating"><parent link="a"/><child link="b"/></joint>', "'j' is of type 'floating'"),
        ('<joint name="j" type="fixed"><parent link="a"/></joint>', "'j' lacks"),
        ('<joint name="j" type="fixed"><parent link="a"/><child link="b"/><origin xyz="1 2"/></joint>',
         "'j' <origin> xyz is not three numbers"),
    ]:
        with pytest.raises(ModelError, match=words):
            urdf_joints(ok + body + "</robot>")
    with pytest.raises(ModelError, match="2 root links"):
        root_link(ok + "</robot>")
