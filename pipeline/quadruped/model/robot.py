"""A 12-joint quadruped loaded from its URDF with pinocchio, and its CasADi foot kinematics.

The kinematic chains are read off the pinocchio model (joint placements and axes), so no link
length is typed twice: ``foot_position_body`` is a CasADi expression of the 12 joint angles,
valid for any URDF whose four feet each hang from a chain of three revolute joints.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np
import pinocchio as pin
from skatelib.library.channels import LEGS
from skatelib.library.errors import ModelError
from skatelib.pipeline.quadruped.model.urdf import free_flyer_model

Sym = Any  # a CasADi SX or MX expression (CasADi's stubs do not type mixed arithmetic)


@dataclass(frozen=True)
class ChainLink:
    """One revolute joint of a leg: its placement in the parent joint frame and its axis."""

    name: str
    rotation: np.ndarray  # (3, 3) placement rotation in the parent joint frame
    translation: np.ndarray  # (3,) placement translation [m]
    axis: np.ndarray  # (3,) unit rotation axis in the joint frame
    lower_rad: float
    upper_rad: float
    velocity_radps: float
    effort_Nm: float


@dataclass(frozen=True)
class LegChain:
    """The three joints of one leg, root first, and the foot frame in the last joint's frame."""

    leg: str
    links: tuple[ChainLink, ...]
    foot_rotation: np.ndarray
    foot_translation: np.ndarray


@dataclass(frozen=True)
class SingleRigidBody:
    """Composite single rigid body of the whole robot at one configuration (SRBKM)."""

    mass_kg: float
    inertia_kgm2: np.ndarray  # (3, 3) about the centre of mass, trunk axes
    com_offset_m: np.ndarray  # (3,) centre of mass in the trunk frame


class Quadruped:
    """A quadruped description: pinocchio model plus the extracted leg chains.

    Args:
        urdf_path: The URDF file.
        joint_names: 12 joint names in channel order (FL FR RL RR x abad hip knee).
        foot_frames: 4 frame names at the foot sphere centres.

    Raises:
        ModelError: When a joint or frame is missing or a leg is not a 3-joint revolute chain.
    """

    def __init__(self, urdf_path: Path, joint_names: tuple[str, ...], foot_frames: tuple[str, ...]):
        self.urdf_path = Path(urdf_path)
        self.urdf_text = self.urdf_path.read_text()
        self.model = free_flyer_model(self.urdf_path)
        self.joint_names = tuple(joint_names)
        self.foot_frames = tuple(foot_frames)
        self.chains = tuple(self._chain(i, leg) for i, leg in enumerate(LEGS))
        # Index of each channel-order joint in pinocchio's configuration vector.
        self.q_index = np.array([self.model.joints[self.model.getJointId(n)].idx_q for n in self.joint_names])
        self._fk = self._build_fk()

    @property
    def mass_kg(self) -> float:
        return float(sum(inertia.mass for inertia in self.model.inertias))

    def _chain(self, leg_i: int, leg: str) -> LegChain:
        m = self.model
        frame = self.foot_frames[leg_i]
        if not m.existFrame(frame):
            raise ModelError(f"{self.urdf_path}: no frame {frame!r} for leg {leg}; "
                             f"frames: {', '.join(f.name for f in m.frames)}")
        f = m.frames[m.getFrameId(frame)]
        chain_ids = []
        j = f.parentJoint
        while j > 1:  # 0 is the universe, 1 the floating base
            chain_ids.append(j)
            j = m.parents[j]
        chain_ids.reverse()
        expected = self.joint_names[3 * leg_i: 3 * leg_i + 3]
        names = tuple(m.names[j] for j in chain_ids)
        if names != expected:
            raise ModelError(f"{self.urdf_path}: leg {leg} chain is {names}, expected {expected}")
        links = []
        for jid in chain_ids:
            jm = m.joints[jid]
            if jm.nq != 1 or ("Revolute" not in jm.shortname() and jm.shortname() not in (
                    "JointModelRX", "JointModelRY", "JointModelRZ")):
                raise ModelError(f"{self.urdf_path}: joint {m.names[jid]} is {jm.shortname()}, need revolute")
            jd = jm.createData()
            jm.calc(jd, np.zeros(m.nq))
            axis = np.asarray(jd.S).reshape(6)[3:6].copy()
            plc = m.jointPlacements[jid]
            links.append(ChainLink(
                name=m.names[jid], rotation=plc.rotation.copy(), translation=plc.translation.copy(),
                axis=axis, lower_rad=float(m.lowerPositionLimit[jm.idx_q]),
                upper_rad=float(m.upperPositionLimit[jm.idx_q]),
                velocity_radps=float(m.velocityLimit[jm.idx_v]), effort_Nm=float(m.effortLimit[jm.idx_v])))
        return LegChain(leg=leg, links=tuple(links), foot_rotation=f.placement.rotation.copy(),
                        foot_translation=f.placement.translation.copy())

    def _build_fk(self) -> ca.Function:
        q = ca.SX.sym("q", 12)
        feet = [foot_position_leg(chain, q[3 * i: 3 * i + 3]) for i, chain in enumerate(self.chains)]
        return ca.Function("foot_positions_body", [q], [ca.horzcat(*feet)], ["q"], ["p"])

    def foot_positions_body(self, q: Sym) -> Sym:
        """Foot sphere centres in the trunk frame, (3, 4) columns FL FR RL RR [m]."""
        return self._fk(q)

    @property
    def lower_limits(self) -> np.ndarray:
        return np.array([lk.lower_rad for c in self.chains for lk in c.links])

    @property
    def upper_limits(self) -> np.ndarray:
        return np.array([lk.upper_rad for c in self.chains for lk in c.links])

    def pin_configuration(self, base_pos: np.ndarray, base_rot: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Pinocchio configuration vector from a trunk pose and channel-order joint angles."""
        qp = pin.neutral(self.model)
        qp[:3] = base_pos
        qp[3:7] = pin.Quaternion(base_rot).coeffs()
        qp[self.q_index] = q
        return qp

    def single_rigid_body(self, q: np.ndarray) -> SingleRigidBody:
        """Composite rigid-body mass, inertia and centre of mass at joint angles ``q`` (trunk at rest).

        Uses pinocchio's centroidal composite rigid-body algorithm, so the inertia includes the legs.
        """
        data = self.model.createData()
        qp = self.pin_configuration(np.zeros(3), np.eye(3), np.asarray(q, dtype=float))
        pin.ccrba(self.model, data, qp, np.zeros(self.model.nv))
        return SingleRigidBody(mass_kg=float(data.Ig.mass), inertia_kgm2=np.array(data.Ig.inertia),
                               com_offset_m=np.array(data.com[0]))


def _axis_rotation(axis: np.ndarray, angle: Sym) -> Sym:
    """Rotation matrix about a unit ``axis`` (Rodrigues); exact zeros simplify away in SX."""
    x, y, z = (float(a) for a in axis)
    c, s = ca.cos(angle), ca.sin(angle)
    C = 1 - c
    return ca.vertcat(
        ca.horzcat(c + x * x * C, x * y * C - z * s, x * z * C + y * s),
        ca.horzcat(y * x * C + z * s, c + y * y * C, y * z * C - x * s),
        ca.horzcat(z * x * C - y * s, z * y * C + x * s, c + z * z * C),
    )


def foot_position_leg(chain: LegChain, q_leg: Sym) -> Sym:
    """Foot position in the trunk frame for one leg, composing placements and joint rotations."""
    R: Sym = ca.DM.eye(3)
    p: Sym = ca.DM.zeros(3)
    for i, link in enumerate(chain.links):
        p = p + R @ ca.DM(link.translation)
        R = R @ ca.DM(link.rotation) @ _axis_rotation(link.axis, q_leg[i])
    return p + R @ ca.DM(chain.foot_translation)
