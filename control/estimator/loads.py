"""How far each stance foot gives under its share of the robot's weight.

A foot is not a rigid sphere: its rubber (and the deck's and floor's surface) gives under load,
so a loaded foot's centre sits ``c_i = k f_i`` less than its radius over the surface it stands on
(k: the foot's compliance [m/N], f_i its normal load). On the twin k is the same for every foot
and load (0.097 mm/N measured: CyberDog2's feet carry 15-37 N, so they give 1.4-3.6 mm), and the
loads differ: with the push foot on the floor the deck feet on its diagonal carry twice what the
third does. Their unequal give tilts the plane through the deck feet's centres by several
milliradians, which the deck's roll would read as roll, and their mean give lowers the deck's top
as the feet place it, which the body's height and the push foot's clearance would read as height.

The loads come from statics, as the robot knows nothing else of them (no foot force sensors): the
weight m g over the stance feet with no moment about the centre of mass, the smallest loads that
do it (three feet not in a line: the one solution; four: the least-squares one). A push or a
landing loads the feet beyond that for a moment; the static share is what they carry on average.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class BodyFigures:
    """What the estimator knows of the robot's mass: ``mass_kg`` [kg], its centre of mass in the
    trunk frame ``com_offset_m`` (3,) [m], and its feet's ``compliance_m_per_N`` (0: rigid feet)."""

    mass_kg: float
    com_offset_m: np.ndarray
    compliance_m_per_N: float = 0.097e-3


def static_loads(feet_xy: np.ndarray, com_xy: np.ndarray, weight_N: float) -> np.ndarray:
    """(n,) the smallest normal loads [N] of feet at ``feet_xy`` (2, n) that carry ``weight_N`` with
    no moment about ``com_xy`` (2,): the minimum-norm solution of sum f = W, sum f (x_i - x_c) = 0;
    loads below zero (the centre of mass outside the feet) clipped to zero, loads above the weight
    to the weight (no foot carries more than the whole robot at rest: three feet nearly in a line
    with the centre of mass off it have an exact solution of loads without bound)."""
    n = feet_xy.shape[1]
    if n == 0:
        return np.zeros(0)
    if n >= 3:
        f = _min_norm_loads(feet_xy, com_xy, weight_N)
        if f is not None:
            return np.clip(f, 0.0, weight_N)
    A = np.vstack([np.ones(n), feet_xy - com_xy[:, None]])
    b = np.array([weight_N, 0.0, 0.0])
    f = np.linalg.lstsq(A, b, rcond=None)[0]
    return np.asarray(np.clip(f, 0.0, weight_N))


def _min_norm_loads(feet_xy: np.ndarray, com_xy: np.ndarray, weight_N: float) -> np.ndarray | None:
    """:func:`static_loads`' solution for three or more feet not in a line, f = A^T (A A^T)^-1 b
    with A A^T's 3 x 3 inverse's first column by cofactors (b = (W, 0, 0)); None when the feet
    are (nearly) in a line. The hot path's form of ``np.linalg.lstsq``: same loads to rounding."""
    dx = feet_xy[0] - float(com_xy[0])
    dy = feet_xy[1] - float(com_xy[1])
    n = float(len(dx))
    sx, sy = float(dx.sum()), float(dy.sum())
    sxx, syy, sxy = float(dx @ dx), float(dy @ dy), float(dx @ dy)
    c0, c1, c2 = sxx * syy - sxy * sxy, sy * sxy - sx * syy, sx * sxy - sy * sxx  # cofactors of row 0
    det = n * c0 + sx * c1 + sy * c2
    if abs(det) <= 1e-12 * max(1.0, n * sxx * syy):
        return None
    w = weight_N / det
    return np.asarray(w * (c0 + c1 * dx + c2 * dy))


def compressions(feet: np.ndarray, stance: np.ndarray, com: np.ndarray, body: BodyFigures,
                 gravity_mps2: float) -> np.ndarray:
    """(4,) how far each stance foot gives [m] (zero for the others): the foot centres ``feet``
    (3, 4, world), ``stance`` (4,) bool, the centre of mass ``com`` (3,, world)."""
    out = np.zeros(feet.shape[1])
    idx = np.flatnonzero(stance)
    if body.compliance_m_per_N > 0 and len(idx):
        out[idx] = body.compliance_m_per_N * static_loads(feet[0:2, idx], com[0:2], body.mass_kg * gravity_mps2)
    return out
