"""The margins a blend of two library entries must keep (``MotionLibrary.blend``) and their check."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from skatelib.library import schema
from skatelib.library.channels import S_Q
from skatelib.library.errors import SkatelibError
from skatelib.library.margins import friction_margins, friction_use


@dataclass(frozen=True)
class BlendMargin:
    """What a blended entry must keep (``MotionLibrary.blend``).

    Attributes:
        friction_fraction: Every contact force within ``(1 - friction_fraction) mu`` of its normal
            force: ``|f_t| <= (1 - friction_fraction) mu f_n`` [-]. Relative, because an absolute
            margin cannot hold where a foot touches down or lifts off with a tiny normal force.
        joint_rad: Every joint angle at least this far inside its limits [rad].
    """

    friction_fraction: float = 0.01
    joint_rad: float = 0.01

    def __post_init__(self) -> None:
        """Raises:
            ValueError: A margin that is no margin: ``friction_fraction`` outside [0, 1) or
                ``joint_rad`` negative or not finite (a negative one would pass a force outside the
                cone or a joint beyond its limit).
        """
        f, j = self.friction_fraction, self.joint_rad
        if not (isinstance(f, (int, float)) and 0.0 <= f < 1.0):
            raise ValueError(f"BlendMargin(friction_fraction={f!r}): a fraction of mu from 0 up to (not) 1")
        if not (isinstance(j, (int, float)) and 0.0 <= j < float("inf")):
            raise ValueError(f"BlendMargin(joint_rad={j!r}): a finite distance from the joint limits >= 0 rad")


DEFAULT_MARGIN = BlendMargin()


@dataclass(frozen=True)
class BlendCheck:
    """Margins of a blended entry and the ones asked for.

    Attributes:
        min_friction_margin_N: Smallest Coulomb margin mu f_n - |f_t| [N].
        max_friction_use: Largest |f_t| / (mu f_n) [-] (1: on the cone).
        min_joint_limit_slack_rad: Smallest distance of a joint angle from its limits [rad].
        required: The margins asked for.
    """

    min_friction_margin_N: float
    max_friction_use: float
    min_joint_limit_slack_rad: float
    required: BlendMargin = BlendMargin()

    @property
    def ok(self) -> bool:
        return (self.max_friction_use <= 1.0 - self.required.friction_fraction
                and self.min_joint_limit_slack_rad >= self.required.joint_rad)


@dataclass(frozen=True)
class MarginCheck:
    """Measures a blend's arrays against the library's friction coefficient and joint limits."""

    mu: float
    joint_lower: np.ndarray | None
    joint_upper: np.ndarray | None
    required: BlendMargin

    def __call__(self, arrays: dict[str, np.ndarray]) -> BlendCheck:
        state, control = arrays[schema.D_STATE], arrays[schema.D_CONTROL]
        contact = arrays.get(schema.D_CONTACT)
        fric, use = np.inf, 0.0
        if contact is not None:
            fric = float(friction_margins(state, control, contact, self.mu)[0].min(initial=np.inf))
            use = friction_use(state, control, contact, self.mu)
        q, lo, hi = state[:, S_Q], self.joint_lower, self.joint_upper
        slack = np.inf if lo is None or hi is None else float(min(np.min(q - lo), np.min(hi - q)))
        return BlendCheck(min_friction_margin_N=fric, max_friction_use=use, min_joint_limit_slack_rad=slack,
                          required=self.required)


def check_blend(path: Path, kind: str, margin: object) -> None:
    """A blend can be made and checked: of a quadruped's library, with a :class:`BlendMargin`.

    Raises:
        TypeError: ``margin`` is not a :class:`BlendMargin`.
        SkatelibError: The library is not a quadruped's (nothing of a humanoid's to check it by).
    """
    if not isinstance(margin, BlendMargin):
        raise TypeError(f"blend(margin=...): a BlendMargin(friction_fraction, joint_rad), got {margin!r}")
    if kind != "quadruped":
        raise SkatelibError(f"{path}: blend mixes a quadruped's start-ups, whose feet and joints it checks; this is a "
                            f"{kind} library: select() its entries")
