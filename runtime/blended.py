"""A blend of two entries of one stride count (``MotionLibrary.blend``), knot by knot."""

from __future__ import annotations

import numpy as np
from skatelib.library import schema
from skatelib.library.errors import SkatelibError
from skatelib.runtime.blend import MarginCheck
from skatelib.runtime.entry import Entry


def blend_pair(a: Entry, b: Entry, target_velocity_mps: float, check: MarginCheck) -> Entry:
    """``(1 - w) a + w b`` knot by knot, ``w`` placing ``target_velocity_mps`` [m/s] between their
    target speeds; the entry
    carries its check and its own attributes (``success`` only when both succeeded and it passes).

    Raises:
        SkatelibError: When the two entries' knot times or contact schedules differ.
    """
    v = target_velocity_mps
    w = 0.0 if b is a else (v - a.target_velocity_mps) / (b.target_velocity_mps - a.target_velocity_mps)
    if a.t.shape != b.t.shape or not np.array_equal(a.t, b.t):
        raise SkatelibError(f"entries {a.key} and {b.key} have different knot times ({len(a.t)} and {len(b.t)} "
                            "knots); cannot blend")
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
    attrs = {schema.A_TARGET_VELOCITY: float(v), schema.A_N_STRIDES: a.n_strides,
             "success": bool(a.success and b.success and result.ok),
             "status": f"blend of {a.key} and {b.key} (weights {1 - w:.3f}, {w:.3f})",
             "blend_sources": (a.key, b.key), "blend_weights": (1.0 - w, w)}
    return Entry(f"blend_v{v:.4f}_s{a.n_strides}", attrs, arrays, a.columns, a.units, result)
