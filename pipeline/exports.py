"""Libraries in other tools' formats (``skatelib export``), each read back by a test:

Only solved entries are written (a failed entry's arrays are no motion; the command names those
it leaves out).

* ``npz``: a folder with one ``<key>.npz`` per entry: its arrays by name (``t``, ``state``, ...),
  and for each array with named columns ``<name>__columns`` and ``<name>__units``.
* ``csv``: a folder with one ``<key>.csv`` per entry: a row per knot, a column per channel headed
  ``array.column [unit]`` (trailing axes flattened: ``foot_pos.FL.x [m]``); a control holds on
  [t_k, t_{k+1}), so the last knot's control cells are empty.
* ``mcap``: one ROS 2 bag (MCAP, CDR) for Foxglove and ``ros2 bag play``, a file whose name ends
  in ``.mcap`` (the storage both pick by it; another name is refused): the entries one after
  another in time, ``/robot_description``, ``/tf``, ``/joint_states`` and every array, topic
  names valid under ROS 2's rules (:mod:`skatelib.pipeline.ros_bag`).
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from skatelib.library import schema
from skatelib.library.atomic import atomic_folder, confined, write_atomic
from skatelib.library.channel_diff import column_names
from skatelib.library.errors import OutputError
from skatelib.library.reader import LibraryData, read_library
from skatelib.library.records import EntryRecord

FORMATS = ("npz", "csv", "mcap")
MCAP_SUFFIX = ".mcap"


def headers(e: EntryRecord) -> tuple[list[str], np.ndarray]:
    """The CSV's column headers and its (knots, columns) table (NaN where a control has no value)."""
    t = np.asarray(e.arrays["t"], dtype=np.float64)
    heads, cols = ["t [s]"], [t[:, None]]
    for name in sorted(k for k in e.arrays if k != "t"):
        a = np.asarray(e.arrays[name], dtype=np.float64)
        if a.ndim == 0 or a.shape[0] not in (len(t), len(t) - 1):
            continue  # not a per-knot array (the humanoid's per-step node tables)
        flat = a.reshape(len(a), -1)
        if len(flat) < len(t):
            flat = np.vstack([flat, np.full((len(t) - len(flat), flat.shape[1]), np.nan)])
        heads += [f"{name}.{c} [{u}]" if u else f"{name}.{c}" for c, u in zip(*column_names(name, a, e), strict=True)]
        cols.append(flat)
    return heads, np.hstack(cols)


def solved(data: LibraryData) -> dict[str, EntryRecord]:
    """The entries an export writes: the solved ones (a failed entry's arrays are no motion)."""
    return {k: e for k, e in data.entries.items() if bool(e.attrs.get(schema.A_SUCCESS, False))}


def npz_files(data: LibraryData) -> Iterator[tuple[str, bytes]]:
    """Each solved entry as ``<key>.npz``: its arrays, column names and units."""
    for key, e in solved(data).items():
        arrays: dict[str, np.ndarray] = {k: np.asarray(v) for k, v in e.arrays.items()}
        for k in e.columns:
            arrays[f"{k}__columns"] = np.array(list(e.columns[k]))
            arrays[f"{k}__units"] = np.array(list(e.units.get(k, [""] * len(e.columns[k]))))
        buffer = io.BytesIO()
        np.savez(buffer, **arrays)  # type: ignore[arg-type]
        yield f"{key}.npz", buffer.getvalue()


def csv_files(data: LibraryData) -> Iterator[tuple[str, bytes]]:
    """Each solved entry as ``<key>.csv``: a row per knot (:func:`headers`)."""
    for key, e in solved(data).items():
        heads, table = headers(e)
        text = io.StringIO()
        w = csv.writer(text, lineterminator="\n")
        w.writerow(heads)
        for row in table:
            w.writerow(["" if np.isnan(v) else repr(float(v)) for v in row])
        yield f"{key}.csv", text.getvalue().encode()


def write_folder(out: Path, files: Iterable[tuple[str, bytes]]) -> list[Path]:
    """Write ``files`` (name, bytes) into the folder ``out``, all or none
    (:func:`skatelib.library.atomic.atomic_folder`); each name a plain one kept inside it."""
    names = []
    with atomic_folder(out) as staging:
        for name, data in files:
            confined(staging, name).write_bytes(data)
            names.append(name)
    return [out / name for name in names]


def write_npz(path: Path, out: Path) -> list[Path]:
    return write_folder(out, npz_files(read_library(path)))


def write_csv(path: Path, out: Path) -> list[Path]:
    return write_folder(out, csv_files(read_library(path)))


def write_mcap(path: Path, out: Path) -> list[Path]:
    """One ROS 2 bag of every solved entry (:mod:`skatelib.pipeline.ros_bag`) at ``out``.

    Raises:
        OutputError: ``out``'s name does not end in ``.mcap`` (nothing read, nothing written).
        ImportError: mcap or mcap-ros2-support is not installed.
    """
    if out.suffix.lower() != MCAP_SUFFIX:
        raise OutputError(out, f"a ROS 2 bag is a file ending in {MCAP_SUFFIX} (ros2 bag play and Foxglove "
                               f"pick its storage by the name); give e.g. -o {out.with_name(out.name + MCAP_SUFFIX)}")
    try:
        import mcap_ros2  # noqa: F401
    except ImportError as missing:
        raise ImportError(f"MCAP export needs mcap and mcap-ros2-support ({missing}); "
                          "pip install 'skatelib[export]'") from missing
    from skatelib.pipeline.ros_bag import write_bag

    data = read_library(path)
    return [write_atomic(out, write_bag(data, solved(data)))]


def export(path: Path, fmt: str, out: Path) -> list[Path]:
    """Write the library at ``path`` as ``fmt`` (:data:`FORMATS`) to ``out`` (a folder for npz and
    csv, a file for mcap): the file whole or not at all, the folder's files all or none (an
    interrupted or failed export leaves no file and no folder it made)."""
    writers: dict[str, Any] = {"npz": write_npz, "csv": write_csv, "mcap": write_mcap}
    return list(writers[fmt](path, out))
