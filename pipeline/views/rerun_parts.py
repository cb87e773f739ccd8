"""Pieces of a Rerun recording that every robot kind uses: the time index, a named series, the
ground under an entry, rotation rows as quaternions."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import rerun as rr

GROUND_HALF_WIDTH_M = 0.45


def time_index(t: np.ndarray) -> list[rr.TimeColumn]:
    return [rr.TimeColumn("time", duration=np.asarray(t, dtype=float))]


def series(rec: rr.RecordingStream, root: str, path: str, t: np.ndarray, values: np.ndarray, name: str) -> None:
    """One plotted series with its legend name (units included); a run beside its reference
    (``/<key>/closed_loop``) says which it is."""
    role = [r.replace("_", " ") for r in root.strip("/").split("/")[1:]]
    rec.log(f"{root}/plots/{path}", rr.SeriesLines(names=" ".join([*role, name])), static=True)
    rec.send_columns(f"{root}/plots/{path}", indexes=time_index(t), columns=rr.Scalars.columns(scalars=values))


def ground(rec: rr.RecordingStream, root: str, path_xy: np.ndarray, margin_m: float) -> None:
    """A ground strip under the entry's path (its own, so that a view of one entry shows it), with
    this view's axes (z up)."""
    rec.log(root, rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    border = np.array([margin_m, GROUND_HALF_WIDTH_M])
    lo = path_xy.min(axis=0) - border
    hi = path_xy.max(axis=0) + border
    rec.log(f"{root}/ground", rr.Boxes3D(mins=[[lo[0], lo[1], -0.002]], sizes=[[*(hi - lo), 0.002]],
                                         colors=[(215, 215, 210)], fill_mode="solid"), static=True)


def quat_rows(R: np.ndarray) -> np.ndarray:
    return np.array([pin.Quaternion(Ri).coeffs() for Ri in R])
