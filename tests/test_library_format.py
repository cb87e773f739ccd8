"""Library file format: round trip, atomic writes, and clear refusals of bad files."""

from __future__ import annotations

import os
import shutil
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest
from skatelib.library import schema
from skatelib.library.errors import LibraryFormatError
from skatelib.library.reader import read_library
from skatelib.library.records import EntryRecord
from skatelib.library.writer import write_library

ROOT = {schema.A_KIND: "humanoid", schema.A_NAME: "t", schema.A_SKATELIB_VERSION: "0", schema.A_CREATED: "now",
        schema.A_GIT_COMMIT: "abc", schema.A_GIT_DIRTY: False, schema.A_CONFIG_TOML: "x = 1",
        schema.A_CASADI: "3", schema.A_IPOPT: "3", schema.A_PINOCCHIO: "3"}


def _entry(key="e", n=11):
    t = np.linspace(0, 1, n)
    attrs = dict(zip(schema.ENTRY_ATTRS, (0.5, 1, True, "Solve_Succeeded", 7, 0.1, 1.0, 1e-9), strict=True))
    return EntryRecord(key=key, attrs=attrs, arrays={"t": t, "state": np.outer(t, [1.0, 2.0]),
                                                   "control": np.ones((n - 1, 1))},
                     columns={"state": ("a", "b"), "control": ("c",)}, units={"state": ("m", "m/s"), "control": ("N",)})


def _write(path: Path) -> Path:
    return write_library(path, ROOT, {"gravity_mps2": 9.81}, {"I": np.eye(3)}, {"robot_urdf": "<robot/>"}, [_entry()])


def test_round_trip_keeps_arrays_columns_and_text(tmp_path):
    """Everything written is read back identically, and arrays come back read-only."""
    data = read_library(_write(tmp_path / "a.h5"))
    e = data.entries["e"]
    assert np.array_equal(e.arrays["state"], np.outer(np.linspace(0, 1, 11), [1.0, 2.0]))
    assert e.columns["state"] == ("a", "b") and e.units["state"] == ("m", "m/s")
    assert data.model_text["robot_urdf"] == "<robot/>"
    assert data.attrs[schema.A_FORMAT_VERSION] == schema.FORMAT_VERSION_STR
    with pytest.raises(ValueError):
        e.arrays["state"][0, 0] = 1.0


def test_failed_write_leaves_no_file(tmp_path):
    """An exception while writing leaves neither the target nor a temporary file behind."""
    target = tmp_path / "b.h5"
    bad = EntryRecord(key="e", attrs={"x": object()}, arrays={"t": np.zeros(2)})
    with pytest.raises(TypeError):
        write_library(target, ROOT, {}, {}, {}, [bad])
    assert os.listdir(tmp_path) == []


def test_changed_value_is_detected_by_checksum(tmp_path):
    """Changing one stored number makes the reader refuse the file, naming the checksum."""
    p = _write(tmp_path / "c.h5")
    with h5py.File(p, "r+") as f:
        f["packed/state"][3, 1] = 42.0
    with pytest.raises(LibraryFormatError, match="checksum") as e:
        read_library(p)
    assert e.value.path == p


def test_edited_attribute_is_refused(tmp_path):
    """An attribute edited behind the index breaks the checksum, and the full read names it."""
    p = _write(tmp_path / "c2.h5")
    with h5py.File(p, "r+") as f:
        f["entries/e"].attrs["success"] = False
    with pytest.raises(LibraryFormatError, match="checksum"):
        read_library(p)
    with pytest.raises(LibraryFormatError, match=r"/entries/e@success"):
        read_library(p, verify_checksum=False, full=True)


@pytest.mark.parametrize(("removed", "field"), [
    (("entries/e", "attr", "success"), "/entries/e@success"),
    (("model", "attr", "gravity_mps2"), "/model@gravity_mps2"),
    (("", "attr", schema.A_KIND), f"/@{schema.A_KIND}"),
    (("entries/e/state", "node", None), "/entries/e/state"),
    (("entries", "node", None), "/entries/e"),
    (("packed/state", "node", None), "/packed/state"),
])
def test_a_part_removed_behind_the_index_is_named(tmp_path, removed, field):
    """An attribute, a view or a packed dataset that the checksummed index has but the file lost
    (deleted behind the checksum): the full read names it and says to rebuild, where the default
    read (from the index alone) has what it needs."""
    p = _write(tmp_path / "r.h5")
    where, what, name = removed
    with h5py.File(p, "r+") as f:
        if what == "attr":
            del (f[where] if where else f).attrs[name]
        else:
            del f[where]
    with pytest.raises(LibraryFormatError, match="rebuild") as e:
        read_library(p, verify_checksum=False, full=True)
    assert e.value.field == field, str(e.value)


def test_entry_views_show_the_packed_data(tmp_path):
    """/entries/<key>/<name> are readable datasets with columns, equal to the packed rows."""
    p = _write(tmp_path / "c3.h5")
    with h5py.File(p, "r") as f:
        assert np.array_equal(f["entries/e/state"][()], np.outer(np.linspace(0, 1, 11), [1.0, 2.0]))
        assert [x.decode() if isinstance(x, bytes) else x for x in f["entries/e/state"].attrs["columns"]] == ["a", "b"]
        assert f["entries/e"].attrs["n_strides"] == 1
    read_library(p, full=True)


@pytest.mark.parametrize("frac", np.linspace(0.01, 0.99, 25).tolist())
def test_any_flipped_byte_is_detected(tmp_path, frac):
    """One inverted byte anywhere in the file (data, metadata or HDF5 slack) is refused."""
    p = _write(tmp_path / "flip.h5")
    data = bytearray(p.read_bytes())
    data[int(len(data) * frac)] ^= 0xFF
    p.write_bytes(bytes(data))
    with pytest.raises(LibraryFormatError):
        read_library(p)


def test_zeroed_block_is_detected(tmp_path):
    """A 4 KiB block of zeros in the middle of the file is caught (checksum or HDF5 error)."""
    p = _write(tmp_path / "d.h5")
    data = bytearray(p.read_bytes())
    mid = len(data) // 2
    data[mid: mid + 4096] = bytes(min(4096, len(data) - mid))
    p.write_bytes(bytes(data))
    with pytest.raises(LibraryFormatError):
        read_library(p)


def test_truncated_file_is_refused(tmp_path):
    """A truncated file raises LibraryFormatError naming the file, not an h5py OSError."""
    p = _write(tmp_path / "e.h5")
    p.write_bytes(p.read_bytes()[:1000])
    with pytest.raises(LibraryFormatError, match="truncated: 1000 of its"):
        read_library(p)


@pytest.mark.parametrize(("version", "match"), [("2.0", "update skatelib"), ("0.9", "rebuild")])
def test_other_major_versions_are_refused_with_advice(tmp_path, monkeypatch, version, match):
    """A newer major version asks to update skatelib; an older one says how to migrate."""
    monkeypatch.setattr(schema, "FORMAT_VERSION_STR", version)
    p = _write(tmp_path / "f.h5")
    monkeypatch.undo()
    with pytest.raises(LibraryFormatError, match=match):
        read_library(p)


def test_newer_minor_version_only_warns(tmp_path, monkeypatch):
    """A file written as format 1.7 is read, with a warning that names the version."""
    monkeypatch.setattr(schema, "FORMAT_VERSION_STR", "1.7")
    p = _write(tmp_path / "g.h5")
    monkeypatch.undo()
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        data = read_library(p)
    assert any("format 1.7" in str(x.message) for x in w)
    assert "e" in data.entries


def test_missing_dataset_is_named(tmp_path):
    """A required dataset that is absent is named in the error, the packed one that is gone, not the
    entry's view of it (checksum off to reach that check)."""
    p = _write(tmp_path / "h.h5")
    with h5py.File(p, "r+") as f:
        del f["packed/control"]
    with pytest.raises(LibraryFormatError, match="rebuild") as e:
        read_library(p, verify_checksum=False)
    assert e.value.field == "/packed/control"


def test_not_a_library(tmp_path):
    """An HDF5 file of something else is refused as not a skatelib library."""
    p = tmp_path / "i.h5"
    with h5py.File(p, "w") as f:
        f["x"] = 1
    with pytest.raises(LibraryFormatError, match="not a skatelib motion library"):
        read_library(p)
    shutil.rmtree(tmp_path)


def test_a_device_is_named_as_no_file():
    """/dev/null exists but is no library file: said so, not 'no such file'."""
    with pytest.raises(LibraryFormatError, match="not a regular file"):
        read_library(Path("/dev/null"))
