"""A URDF's joint tree and the transform each joint makes at given angles, as
``robot_state_publisher`` publishes them on ``/tf``: parent link to child link, the joint's
``<origin>`` (its ``rpy``: fixed axes x, y, z) followed by its motion about (or along) ``<axis>``.

numpy and the standard library only (the MCAP export needs no pinocchio); a test compares the
chained transforms with pinocchio's forward kinematics of the same URDF.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np
from skatelib.library.errors import ModelError

MOVING = ("revolute", "continuous", "prismatic")


@dataclass(frozen=True)
class UrdfJoint:
    """One ``<joint>``: its name, type, parent and child link, origin (4x4) and unit axis."""

    name: str
    kind: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray

    @property
    def moves(self) -> bool:
        return self.kind in MOVING


def rpy_matrix(rpy: np.ndarray) -> np.ndarray:
    """The rotation of a URDF ``rpy`` (roll about x, then pitch about y, then yaw about z, all
    fixed axes): ``Rz(yaw) Ry(pitch) Rx(roll)``."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def _floats(text: str | None, default: str, where: str) -> np.ndarray:
    try:
        v = np.array([float(s) for s in (text or default).split()])
    except ValueError as e:
        raise ModelError(f"the robot description (URDF): {where} is not three numbers: {text!r}") from e
    if v.shape != (3,):
        raise ModelError(f"the robot description (URDF): {where} is not three numbers: {text!r}")
    return v


def _joint(el: ET.Element) -> UrdfJoint:
    name, kind = el.get("name", ""), el.get("type", "")
    parent, child, origin, axis = el.find("parent"), el.find("child"), el.find("origin"), el.find("axis")
    if not name or parent is None or child is None or not parent.get("link") or not child.get("link"):
        raise ModelError(f"the robot description (URDF): joint {name!r} lacks a name, a parent or a child link")
    if kind not in (*MOVING, "fixed"):
        raise ModelError(f"the robot description (URDF): joint {name!r} is of type {kind!r}; "
                         f"skatelib exports {', '.join((*MOVING, 'fixed'))} joints")
    M = np.eye(4)
    where = f"joint {name!r} <origin>"
    M[:3, :3] = rpy_matrix(_floats(None if origin is None else origin.get("rpy"), "0 0 0", where + " rpy"))
    M[:3, 3] = _floats(None if origin is None else origin.get("xyz"), "0 0 0", where + " xyz")
    a = _floats(None if axis is None else axis.get("xyz"), "1 0 0", f"joint {name!r} <axis> xyz")
    if kind in MOVING and not np.linalg.norm(a) > 0:
        raise ModelError(f"the robot description (URDF): joint {name!r} has a zero axis")
    return UrdfJoint(name, kind, str(parent.get("link")), str(child.get("link")), M,
                     a / np.linalg.norm(a) if np.linalg.norm(a) > 0 else a)


def urdf_joints(urdf: str) -> list[UrdfJoint]:
    """The URDF's joints in file order.

    Raises:
        ModelError: The text is not well-formed XML, or a joint lacks a link, has an unknown type
            or an origin or axis that is not three numbers.
    """
    try:
        root = ET.fromstring(urdf)
    except ET.ParseError as e:
        raise ModelError(f"the robot description (URDF) is not well-formed XML: {e}") from e
    return [_joint(el) for el in root.findall("joint")]


def root_link(urdf: str) -> str:
    """The link that is no joint's child (the floating base: ``trunk``).

    Raises:
        ModelError: No such link, or more than one.
    """
    root = ET.fromstring(urdf)
    children = {j.child for j in urdf_joints(urdf)}
    roots = [el.get("name", "") for el in root.findall("link") if el.get("name") not in children]
    if len(roots) != 1:
        raise ModelError(f"the robot description (URDF) has {len(roots)} root links ({', '.join(roots)}); "
                         "a robot description has one")
    return roots[0]


def joint_transforms(joint: UrdfJoint, q: np.ndarray) -> np.ndarray:
    """The joint's transforms parent -> child (K, 4, 4) at the positions ``q`` (K,) [rad or m]:
    ``origin @ motion(q)``, the motion a rotation about the axis (Rodrigues) or a translation
    along it; the origin alone for a fixed joint."""
    q = np.asarray(q, dtype=np.float64).reshape(-1)
    motion = np.tile(np.eye(4), (len(q), 1, 1))
    if joint.kind == "prismatic":
        motion[:, :3, 3] = q[:, None] * joint.axis
    elif joint.moves:
        x, y, z = joint.axis
        K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
        s, c = np.sin(q)[:, None, None], np.cos(q)[:, None, None]
        motion[:, :3, :3] = np.eye(3) + s * K + (1 - c) * (K @ K)
    return joint.origin @ motion
