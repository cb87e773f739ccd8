"""A library's index is checked once, when the file is opened: a key that is a path, an absolute
path or carries terminal control codes, an entry that is not an object or lacks its fields, a key
given twice: every reader refuses the file with the library-format error (exit 3) naming the file
and the key (escaped), and ``export`` writes nothing, inside its folder or outside."""

from __future__ import annotations

import copy
import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest
from skatelib.library import schema
from skatelib.library.atomic import confined
from skatelib.library.digest import placeholder, seal
from skatelib.library.errors import EXIT_LIBRARY, LibraryFormatError, OutputError
from skatelib.library.reader import read_library
from skatelib.library.records import EntryRecord
from skatelib.library.writer import write_library
from skatelib.runtime import MotionLibrary

from tests.helpers import run_cli

REFERENCE = Path(__file__).parent / "data" / "tiny-reference.h5"


def crafted(folder: Path, change: Callable[[dict[str, Any]], None]) -> Path:
    """A copy of the reference library whose index ``change`` rewrote, sealed with a valid checksum
    (what someone crafting a file would do)."""
    path = folder / "crafted.h5"
    shutil.copyfile(REFERENCE, path)
    marker = placeholder()
    with h5py.File(path, "r+") as f:
        index = json.loads(f[f"{schema.G_PACKED}/{schema.D_INDEX}"][()].tobytes().decode())
        change(index)
        del f[f"{schema.G_PACKED}/{schema.D_INDEX}"]
        f[f"{schema.G_PACKED}/{schema.D_INDEX}"] = np.frombuffer(json.dumps(index).encode(), dtype=np.uint8)
        f.attrs[schema.A_CHECKSUM] = np.bytes_(marker)
    raw = bytearray(path.read_bytes())
    seal(raw, marker)
    path.write_bytes(raw)
    return path


def _first_key(key: Any) -> Callable[[dict[str, Any]], None]:
    def change(index: dict[str, Any]) -> None:
        index["entries"][0]["key"] = key

    return change


def test_the_crafting_keeps_a_readable_file(tmp_path):
    """The test's own tool: a file whose index is rewritten unchanged reads as the reference."""
    path = crafted(tmp_path, lambda index: None)
    assert read_library(path).entries.keys() == read_library(REFERENCE).entries.keys()


@pytest.mark.parametrize("fmt", ["npz", "csv"])
@pytest.mark.parametrize("key", ["../../escaped", "/tmp/skatelib-escaped", "sub/escaped", ".."],
                         ids=["parent", "absolute", "subfolder", "dotdot"])
def test_export_refuses_a_key_that_is_a_path(tmp_path, key, fmt):
    """``export`` of a file whose entry key leads outside the output folder: exit 3 naming the file
    and the key, and no file written anywhere (the old reader wrote ``out/../../escaped.npz``)."""
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    lib = crafted(work, _first_key(key))
    escaped = Path(f"/tmp/skatelib-escaped.{fmt}")  # where the absolute key pointed
    escaped.unlink(missing_ok=True)
    before = sorted(p for p in tmp_path.rglob("*"))
    r = run_cli(["export", str(lib), "-f", fmt, "-o", str(work / "out")], timeout=120)
    assert r.returncode == EXIT_LIBRARY, r.stdout + r.stderr
    assert "crafted.h5" in r.stderr and repr(key) in r.stderr and "rebuild it" in r.stderr
    assert "Traceback" not in r.stderr
    after = [p for p in sorted(tmp_path.rglob("*")) if p not in before]
    assert after in ([], [work / "out"]) and not list((work / "out").glob("*"))
    assert not escaped.exists()


def test_a_key_with_terminal_codes_is_refused_escaped(tmp_path):
    """A key carrying an escape sequence (clear the screen, a colour) is refused by ``info``, and
    the message shows it escaped: no ESC byte reaches the terminal."""
    lib = crafted(tmp_path, _first_key("v0.30_s1\x1b[2J\x1b[31m"))
    r = run_cli(["info", str(lib)], timeout=120)
    assert r.returncode == EXIT_LIBRARY, r.stdout + r.stderr
    assert "\x1b" not in r.stdout + r.stderr
    assert "\\x1b[2J" in r.stderr and "not a plain name" in r.stderr


CASES: dict[str, tuple[Callable[[dict[str, Any]], None], str]] = {
    "entry not an object": (lambda ix: ix["entries"].__setitem__(0, 5), "is not a JSON object"),
    "entry a list": (lambda ix: ix["entries"].__setitem__(0, ["v0.30_s1"]), "is not a JSON object"),
    "entry without attrs": (lambda ix: ix["entries"][0].pop("attrs"), "lacks attrs"),
    "attrs not an object": (lambda ix: ix["entries"][0].__setitem__("attrs", [1]), "attributes are not"),
    "rows not pairs": (lambda ix: ix["entries"][0].__setitem__("rows", {"t": 3}), "rows are not"),
    "columns not strings": (lambda ix: ix["entries"][0].__setitem__("columns", {"state": 7}), "columns are not"),
    "entries not a list": (lambda ix: ix.__setitem__("entries", {"v0.30_s1": {}}), "'entries' is not a JSON list"),
    "key not a string": (_first_key(3), "entry key 3 is not a string"),
    "duplicate key": (lambda ix: ix["entries"].append(copy.deepcopy(ix["entries"][0])), "names this entry twice"),
    "model array not an object": (lambda ix: ix.__setitem__("model_arrays", {"x": 1}), "'model_arrays'"),
}


@pytest.mark.parametrize("case", CASES)
def test_a_misshapen_index_is_a_format_error(tmp_path, case):
    """Each malformed index: ``LibraryFormatError`` naming the file (not a TypeError or KeyError
    from deep inside the reader), from the reader and from ``MotionLibrary``."""
    change, words = CASES[case]
    lib = crafted(tmp_path, change)
    for read in (read_library, MotionLibrary.open):
        with pytest.raises(LibraryFormatError, match="rebuild it") as e:
            read(lib)
        assert str(lib) in str(e.value) and words in str(e.value), str(e.value)


@pytest.mark.slow
def test_the_command_line_says_exit_3_for_an_entry_without_attributes(tmp_path):
    """``export`` and ``info`` of an entry without attributes: exit 3 and one line, no traceback
    (it was a KeyError's traceback and exit 1)."""
    lib = crafted(tmp_path, CASES["entry without attrs"][0])
    for args in (["info", str(lib)], ["export", str(lib), "-f", "npz", "-o", str(tmp_path / "out")]):
        r = run_cli(args, timeout=120)
        assert r.returncode == EXIT_LIBRARY and "lacks attrs" in r.stderr, r.stdout + r.stderr
        assert "Traceback" not in r.stderr


@pytest.mark.parametrize("name", ["../x.npz", "/etc/x.npz", "a/x.npz", "..", ".", "", "a\\x.npz", "x\0.npz"])
def test_confined_refuses_names_that_leave_the_folder(tmp_path, name):
    """A file name from a library's content is one plain name inside the output folder."""
    with pytest.raises(OutputError, match="leads outside"):
        confined(tmp_path, name)
    assert confined(tmp_path, "v0.50-0.80_s1.npz") == tmp_path / "v0.50-0.80_s1.npz"


@pytest.mark.parametrize("key", ["v0.50_s2", "v0.50-0.80_s1", "walk_v0.375_n6", "skate_v1.00"])
def test_the_keys_skatelib_writes_are_plain_names(key):
    """Every kind of key the builders make passes the rule the reader applies."""
    assert schema.entry_key_problem(key) == ""
    assert schema.entry_key(0.5, 2) == "v0.50_s2" and schema.humanoid_key("walk", 0.375, 6) == "walk_v0.375_n6"


def test_the_writer_refuses_a_key_the_reader_would_refuse(tmp_path):
    """A key that is a path is not written (the writer fails before any byte)."""
    e = EntryRecord(key="../x", attrs={}, arrays={"t": np.zeros(2)})
    with pytest.raises(ValueError, match="not a plain name"):
        write_library(tmp_path / "x.h5", {}, {}, {}, {}, [e])
    assert not list(tmp_path.iterdir())
