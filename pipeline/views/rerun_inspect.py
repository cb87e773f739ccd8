"""Log motion libraries to Rerun: columns over time (``send_columns``), a static scene, and a
saved default blueprint. Imported only by ``skatelib inspect`` and ``track --save``.

What an entry looks like is its kind's (``quadruped/rerun.py``, ``humanoid/rerun.py``, through
the kind table); here: the recording, one tab per entry with its own 3D view, summary and plots,
a tab with every entry side by side, and the viewer.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
from skatelib.library import schema
from skatelib.library.atomic import write_atomic
from skatelib.library.errors import LibraryFormatError
from skatelib.pipeline.kinds import RobotKind, kind_named
from skatelib.proving.twin.record import ESTIMATE_STATE
from skatelib.runtime import Entry, MotionLibrary

SPACING_M = 1.2  # side-by-side entries are this far apart along y


def kind_rerun(lib: MotionLibrary) -> RobotKind:
    """The library's kind (its ``rerun_panels()`` and ``rerun_logger(lib)``)."""
    return kind_named(lib.kind, lib.path)


def blueprint(lib: MotionLibrary, roots: list[str]) -> rrb.Blueprint:
    """One tab per entry: its own 3D view (the others out of it) beside its summary and plots (a
    closed-loop run shares its entry's tab with the reference), so that nothing mixes entries; a
    last tab shows all entries side by side."""
    panels = kind_rerun(lib).rerun_panels()
    groups: dict[str, list[str]] = {}
    for r in roots:
        groups.setdefault(r.strip("/").split("/")[0], []).append(r)

    def plots(members: list[str]) -> list[rrb.TimeSeriesView]:
        return [rrb.TimeSeriesView(name=title, contents=[f"{r}/plots/{p}/**" for r in members] + [
            f"{r}/plots/{p}" for r in members]) for title, p in panels]

    tabs = [rrb.Horizontal(
        rrb.Spatial3DView(name=f"{key} 3D", origin=f"/{key}"),
        rrb.Vertical(rrb.TextDocumentView(origin=f"{members[0]}/summary", name="entry"), *plots(members),
                     row_shares=[2] + [5] * len(panels)),
        name=key, column_shares=[3, 2]) for key, members in groups.items()]
    overview = rrb.Spatial3DView(name=f"all {len(groups)} entries", origin="/")
    return rrb.Blueprint(rrb.Tabs(*tabs, overview), collapse_panels=True)


def _log_summary(rec: rr.RecordingStream, root: str, e: Entry, certificate: Any = None) -> None:
    """A short text at ``<root>/summary`` saying which entry this is and how it did (with the
    library's certificate, how it did under drawn errors)."""
    a = e.attrs
    status = f"{a['status']}" if e.success else f"**FAILED** ({a['status']}): not a usable motion"
    parts = [f"{e.target_velocity_mps:.2f} m/s x {e.n_strides}", status]
    if "iterations" in a:
        parts[-1] += f", {a['iterations']} iterations"
    ph = json.loads(str(a.get(schema.A_PHYSICS, "{}")))
    for key, fmt in (("momentum_speed_mps", "rides at {:.3f} m/s"),
                     ("min_friction_margin_N", "Coulomb margin {:.2f} N"),
                     ("max_torque_rigid_legs_Nm", "torque {:.1f} N m"), ("max_defect", "defect {:.0e}")):
        if key in ph:
            parts.append(fmt.format(ph[key]))
    if schema.A_CLOSED_LOOP in a:
        cl = json.loads(str(a[schema.A_CLOSED_LOOP]))
        parts.append(f"closed loop {'pass' if cl['passed'] else 'FAIL'} ({cl['delivered_mps']:.3f} m/s)")
    figures = None if certificate is None else certificate.current_for(e.key, e.arrays)
    if figures is not None:
        parts.append(f"certified {figures.successes}/{figures.samples} rides ({figures.low:.2f}-{figures.high:.2f})")
    text = f"**{e.key}**: " + "; ".join(parts)
    rec.log(f"{root}/summary", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN), static=True)


def log_library(lib: MotionLibrary, rec: rr.RecordingStream, keys: list[str] | None = None,
                overlay: bool = False) -> list[str]:
    """Log entries (all by default) side by side (or overlaid); returns their entity roots."""
    entries = [lib[k] for k in keys] if keys else list(lib)
    log = kind_rerun(lib).rerun_logger(lib)
    roots = []
    rec.log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    for n, e in enumerate(entries):
        root = f"/{e.key}"
        log(rec, e, root, np.zeros(3) if overlay else np.array([0.0, SPACING_M * n, 0.0]))
        _log_summary(rec, root, e, lib.certificate)
        roots.append(root)
    rec.send_blueprint(blueprint(lib, roots))
    return roots


def save_closed_loop(lib: MotionLibrary, runs: list[tuple[str, Entry]], save: Path,
                     references: dict[str, Entry] | None = None) -> list[str]:
    """Each entry's reference beside its closed-loop run (``skatelib track --save``), with the views
    of ``inspect``: the reference at ``/<key>/reference``, the run 0.6 m beside it at
    ``/<key>/closed_loop``; a run on the estimate, its estimate's board speed and deck roll at
    ``/<key>/estimate`` in the same plots as the run's true ones. ``references``: the references
    that are not the library's entries (a ride's joined entries). Written atomically."""
    log = kind_rerun(lib).rerun_logger(lib)
    rec = rr.RecordingStream(f"skatelib-track-{lib.path.stem}")
    roots = []
    stream = rr.binary_stream(recording=rec)  # in memory, then written whole (a full device: one clear error)
    rec.log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    for n, (key, run) in enumerate(runs):
        offset = np.array([0.0, 2 * SPACING_M * n, 0.0])
        rec.log(f"/{key}", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)  # its tab's 3D view
        ref = (references or {}).get(key) or lib[key]
        log(rec, ref, f"/{key}/reference", offset)
        _log_summary(rec, f"/{key}/reference", ref)
        beside = offset + np.array([0.0, SPACING_M / 2, 0.0])
        log(rec, run, f"/{key}/closed_loop", beside)
        roots += [f"/{key}/reference", f"/{key}/closed_loop"]
        if ESTIMATE_STATE in run.arrays:  # a quadruped's run on the estimate
            from skatelib.pipeline.quadruped.rerun import log_estimate

            log_estimate(rec, f"/{key}/estimate", run.t, run.arrays[ESTIMATE_STATE])
            roots.append(f"/{key}/estimate")
    rec.send_blueprint(blueprint(lib, roots))
    _write_stream(stream, save)
    return roots


def _write_stream(stream: Any, save: Path) -> None:
    data = stream.read(flush=True)
    write_atomic(save, data or b"")


def put_viewer_on_path() -> None:
    """The SDK spawns the viewer found on PATH; the one installed with it sits beside this Python
    (``.venv/bin/rerun``), which is not on PATH when the venv is not activated."""
    here = str(Path(sys.executable).parent)
    parts = os.environ.get("PATH", "").split(os.pathsep)
    if here not in parts:
        os.environ["PATH"] = os.pathsep.join([here, *parts])


def inspect_library(path: Path, keys: list[str] | None, save: Path | None, spawn: bool, overlay: bool) -> list[str]:
    """Open a library and log it to a file (written atomically) and/or a spawned viewer."""
    lib = MotionLibrary.open(path)
    if lib.kind == "quadruped" and not lib.urdf:
        raise LibraryFormatError(path, "/model/robot_urdf", "the library carries no robot description; rebuild it")
    for k in keys or []:
        lib[k]  # raises EntryNotFound with the valid keys before anything is written
    roots: list[str] = []
    if save is not None:  # in memory, then written whole (a full device: one clear error, no partial file)
        rec = rr.RecordingStream(f"skatelib-{path.stem}")
        stream = rr.binary_stream(recording=rec)
        roots = log_library(lib, rec, keys, overlay)
        _write_stream(stream, save)
    if spawn:
        put_viewer_on_path()
        rec = rr.RecordingStream(f"skatelib-{path.stem}")
        rec.spawn()
        roots = log_library(lib, rec, keys, overlay)
        rec.flush()
        rec.disconnect()
    return roots
