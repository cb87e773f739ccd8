"""Figures of a humanoid motion library (``skatelib plot``), from the file alone.

* ``com``: the centre of mass's forward speed (with each entry's label) and height over time;
* ``footprints``: per entry, the top view the paper draws: COM path, ZMP path and the support
  polygons of the entry's stored plan (each where its segment starts).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from skatelib.library import schema
from skatelib.library.channels import HUMANOID_STATE_NAMES, HUMANOID_STATE_UNITS
from skatelib.library.errors import SkatelibError
from skatelib.pipeline.humanoid.motion import stored_plan
from skatelib.pipeline.views.figures import library_name, panels, solved
from skatelib.runtime import MotionLibrary


def figures(lib: MotionLibrary, plt: Any, frontier_file: Path | None) -> dict[str, Any]:
    """The figures by file stem.

    Raises:
        SkatelibError: When a frontier file is given (humanoid libraries have none).
    """
    if frontier_file is not None:
        raise SkatelibError(f"{lib.path}: a humanoid library has no reachable-speed frontier; drop --frontier")
    out = {"com": plot_com(lib, plt), "footprints": plot_footprints(lib, plt)}
    bodies = [e for e in solved(lib) if schema.D_ZMP_WHOLEBODY in e.arrays]
    if bodies:
        out["zmp_wholebody"] = plot_zmp(lib, bodies, plt)
    return out


def plot_zmp(lib: MotionLibrary, entries: list[Any], plt: Any) -> Any:
    """The paper's Fig. 6-13 counterparts: per entry and axis, the planned ZMP (green), the
    multibody ZMP of the whole body before the dynamics filter (grey) and after it (black), and
    the COM (red)."""
    fig, axes = plt.subplots(len(entries), 2, figsize=(12, 2.8 * len(entries)), squeeze=False, layout="constrained")
    fig.suptitle(f"{library_name(lib)}: planned ZMP (green), multibody ZMP before (grey) and after (black) the "
                 "dynamics filter, COM (red)")
    for row, e in zip(axes, entries, strict=True):
        figures = json.loads(str(e.attrs[schema.A_WHOLEBODY]))
        for axis, ax in enumerate(row):
            ax.plot(e.t, e.arrays[schema.D_ZMP][:, axis], color="C2", lw=1.5)
            ax.plot(e.t, e.arrays[schema.D_ZMP_UNFILTERED][:, axis], color="0.6", lw=0.8)
            ax.plot(e.t, e.arrays[schema.D_ZMP_WHOLEBODY][:, axis], color="k", lw=0.8)
            ax.plot(e.t, e.state[:, axis], color="C3", lw=0.8, ls="--")
            ax.set_ylabel(f"{'xy'[axis]} [m]")
            ax.set_xlabel("time [s]")
            ax.grid(alpha=0.3)
        row[0].set_title(f"{e.key}: ZMP error RMS {figures['zmp_rms_unfiltered_m'] * 100:.1f} cm before the filter, "
                         f"{figures['zmp_rms_m'] * 100:.1f} cm after", fontsize=9)
    return fig


def plot_com(lib: MotionLibrary, plt: Any) -> Any:
    """COM forward speed (label dotted) and height against time, every entry."""
    fig, (speed, height) = panels(plt, 2, f"{library_name(lib)}: centre of mass")
    for i, e in enumerate(lib):
        c = f"C{i % 10}"
        speed.plot(e.t, e.channel("com_vx"), color=c, label=e.key)
        speed.axhline(e.target_velocity_mps, color=c, lw=0.8, ls=":")
        height.plot(e.t, e.channel("com_z"), color=c)
    unit = dict(zip(HUMANOID_STATE_NAMES, HUMANOID_STATE_UNITS, strict=True))
    speed.set_ylabel(f"forward speed [{unit['com_vx']}]")
    height.set_ylabel(f"height [{unit['com_z']}]")
    height.set_xlabel("time [s]")
    speed.legend(fontsize=8)
    for ax in (speed, height):
        ax.grid(alpha=0.3)
    height.ticklabel_format(axis="y", useOffset=False)
    z = np.concatenate([e.channel("com_z") for e in solved(lib)])
    height.set_ylim(z.min() - 0.02, z.max() + 0.02)  # a constant height stays a flat line in the middle
    return fig


def plot_footprints(lib: MotionLibrary, plt: Any) -> Any:
    """Top view per entry: COM path (red), ZMP (green), support polygons of the stored plan (blue)."""
    entries = solved(lib)
    fig, axes = plt.subplots(len(entries), 1, figsize=(10, 2.8 * len(entries)), squeeze=False,
                             layout="constrained")
    fig.suptitle(f"{library_name(lib)}: COM (red), ZMP (green) and support polygons (blue), from above")
    for ax, e in zip(axes[:, 0], entries, strict=True):
        for spec in stored_plan(lib, e):
            for _, sup in spec.segments:
                ring = np.asarray(sup.polygon) + np.asarray(sup.p0)[:2]
                ring = np.vstack([ring, ring[:1]])
                ax.plot(ring[:, 0], ring[:, 1], color="C0", lw=0.8)
        ax.plot(e.channel("com_x"), e.channel("com_y"), color="C3", lw=1.5)
        zmp = e.arrays[schema.D_ZMP]
        ax.plot(zmp[:, 0], zmp[:, 1], ".", color="C2", ms=2)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(e.key, fontsize=9)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.grid(alpha=0.3)
    return fig
