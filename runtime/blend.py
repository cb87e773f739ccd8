"""Blending two library entries (``MotionLibrary.blend``) and the margins a blend must keep."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skatelib.library import schema
from skatelib.library.channels import S_Q
from skatelib.library.errors import SkatelibError
from skatelib.library.margins import friction_margins, friction_use
from skatelib.runtime.entry import Entry


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


def blend_pair(a: Entry, b: Entry, velocity: float, check: MarginCheck) -> Entry:
    """``(1 - w) a + w b`` knot by knot, ``w`` placing ``velocity`` between their labels; the entry
    carries its check and its own attributes (``success`` only when both succeeded and it passes).

    Raises:
        SkatelibError: When the two entries' contact schedules differ.
    """
    w = 0.0 if b is a else (velocity - a.target_velocity_mps) / (b.target_velocity_mps - a.target_velocity_mps)
    if a.contact is not None and b.contact is not None and not np.array_equal(a.contact, b.contact):
        raise SkatelibError(f"entries {a.key} and {b.key} have different contact schedules; cannot blend")
    arrays = {schema.D_T: a.t}
    for name in (schema.D_STATE, schema.D_CONTROL, schema.D_FOOT_POS, schema.D_BOARD_POS):
        xa, xb = getattr(a, name), getattr(b, name)
        if xa is not None and xb is not None:
            arrays[name] = (1 - w) * xa + w * xb
    if a.contact is not None:
        arrays[schema.D_CONTACT] = a.contact
    result = check(arrays)
    attrs = {"target_velocity_mps": float(velocity), "n_strides": a.n_strides,
             "success": bool(a.success and b.success and result.ok),
             "status": f"blend of {a.key} and {b.key} (weights {1 - w:.3f}, {w:.3f})",
             "blend_sources": (a.key, b.key), "blend_weights": (1.0 - w, w)}
    return Entry(f"blend_v{velocity:.4f}_s{a.n_strides}", attrs, arrays, a.columns, a.units, result)
