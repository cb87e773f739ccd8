"""README.md's Python examples run as written: each ```python block is executed, the default
library's path ("out/cyberdog2-default.h5", which needs a full build) replaced by a small library.

That library is the shipped test reference (tests/data/tiny-reference.h5, two one-stride start-ups
to 0.3 and 0.4 m/s) with its entries relabelled as two-stride start-ups to 0.5 and 0.7 m/s, the
entries the README picks in the default library, and a one-stride transition from 0.5 to 0.7 m/s
(the default library's shape: transitions with a stride count no start-up has); the arrays are the
reference's, only the labels change. The inline ``lib.blend(...)`` calls of the text run on it
too. A block that calls the user's own controller (``mpc.solve(x_measured, ...)``) gets them
from a prelude: an ``mpc`` whose ``solve`` checks the shapes the README states and returns zeros,
and a measured state ``x_measured`` (28 zeros)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from skatelib.library import schema
from skatelib.library.reader import read_library
from skatelib.library.records import EntryRecord
from skatelib.library.writer import write_library

ROOT = Path(__file__).parents[1]
REFERENCE = ROOT / "tests" / "data" / "tiny-reference.h5"
DEFAULT_LIBRARY = '"out/cyberdog2-default.h5"'
RELABEL = {"v0.30_s1": (0.5, 2, 0.0), "v0.40_s1": (0.7, 2, 0.0)}  # reference key: label, strides, from
TRANSITION = ("v0.40_s1", (0.7, 1, 0.5))


def python_blocks() -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", (ROOT / "README.md").read_text(), flags=re.S | re.M)


def _relabelled(folder: Path) -> Path:
    data = read_library(REFERENCE)
    entries = []
    for key, (v, strides, v_from) in [*RELABEL.items(), TRANSITION]:
        r = data.entries[key]
        attrs = {**r.attrs, schema.A_TARGET_VELOCITY: v, schema.A_N_STRIDES: strides, schema.A_FROM_VELOCITY: v_from}
        entries.append(EntryRecord(key=schema.entry_key(v, strides, v_from), attrs=attrs, arrays=dict(r.arrays),
                                   columns=dict(r.columns), units=dict(r.units)))
    protected = {schema.A_FORMAT, schema.A_FORMAT_VERSION, schema.A_CHECKSUM}
    root = {k: v for k, v in data.attrs.items() if k not in protected}
    path = folder / "cyberdog2-default.h5"
    write_library(path, root, data.model_attrs, data.model_arrays, data.model_text, entries)
    return path


class _Mpc:
    """The user's controller of the README's loop: checks what it is given, returns a control."""

    calls = 0

    def solve(self, x: np.ndarray, state: np.ndarray, control: np.ndarray, contact: np.ndarray) -> np.ndarray:
        assert x.shape == (28,) and state.shape == (10, 28) and control.shape == (10, 24)
        assert contact.shape == (10, 4)
        self.calls += 1
        return np.zeros(24)


def test_the_readme_has_python_examples():
    assert python_blocks(), "README.md has no ```python block"


@pytest.mark.parametrize("index", range(len(python_blocks())))
def test_a_readme_example_runs(tmp_path, index):
    """The block runs without error on the small library; where it calls the controller, it did."""
    block = python_blocks()[index]
    lib = _relabelled(tmp_path)
    code = block.replace(DEFAULT_LIBRARY, repr(str(lib)))
    mpc = _Mpc()
    namespace = {"mpc": mpc, "x_measured": np.zeros(28)}
    exec(compile(code, f"README.md python block {index + 1}", "exec"), namespace)
    if "mpc.solve" in block:
        assert mpc.calls > 30


def test_the_readme_blends_as_it_says(tmp_path):
    """Each inline ``lib.blend(...)`` of the text returns a blend of two start-ups (it raised
    EntryNotFound 'strides=1' on a library with one-stride transitions)."""
    from skatelib.runtime import MotionLibrary

    calls = re.findall(r"`(lib\.blend\([^`]*\))`", (ROOT / "README.md").read_text())
    assert calls
    lib = MotionLibrary.open(_relabelled(tmp_path))
    assert any(e.from_velocity_mps for e in lib)
    for call in calls:
        blended = eval(call, {"lib": lib})
        assert all(lib[k].from_velocity_mps == 0.0 for k in blended.attrs["blend_sources"]), call
