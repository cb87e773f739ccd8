"""The checks of what a humanoid entry serves a controller (t, state, control, zmp, contact_point,
step_index): the shipped walk and skate pass them within their tolerances, `skatelib validate`
fails a copy with one of those arrays doctored (checksum sealed again) naming the array and what
is wrong, and the build's judge refuses such a motion before it is stored."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from skatelib.library import schema
from skatelib.library.reader import read_library
from skatelib.library.writer import write_library
from skatelib.pipeline.humanoid.motion import stored_plan
from skatelib.pipeline.humanoid.served import TOLERANCES, Served, measure
from skatelib.pipeline.humanoid.verify import judge, served_failures
from skatelib.pipeline.validate import validate_library
from skatelib.runtime import MotionLibrary


def _set(index, value=None, add=None, times=None):
    """A change of one array: ``a[index]`` set to ``value``, or increased by ``add``, or multiplied by ``times``."""

    def change(a):
        a = np.array(a)
        a[index] = value if value is not None else a[index] + add if add is not None else a[index] * times
        return a

    return change


def _swap(a):
    a = np.array(a)
    a[[300, 301]] = a[[301, 300]]
    return a


def _doctored(path, folder, name, change):
    """A copy of the library at ``path`` with its one entry's dataset ``name`` changed, written (and
    sealed) as the writer writes any library."""
    folder.mkdir(parents=True, exist_ok=True)
    data = read_library(path)
    (rec,) = data.entries.values()
    moved = dataclasses.replace(rec, arrays={**rec.arrays, name: change(rec.arrays[name])})
    keep = {k: v for k, v in data.attrs.items() if k not in ("format", "format_version", "content_sha256")}
    return write_library(folder / f"{name}.h5", keep, data.model_attrs, data.model_arrays, data.model_text, [moved])


def _messages(path):
    found: list[str] = []
    assert validate_library(path, lambda key, status, msg, fig: found.append(msg)) == 1
    return "; ".join(found)


def test_the_shipped_walk_and_skates_pass_within_every_tolerance(hrp2_walk_path, hrp2_skate_build):
    """Every entry of the walk (0.375 m/s) and the skate (0.5, 0.75, 1 m/s): no failure, and each
    check's worst value under its tolerance (by the margins the module's docstring states)."""
    worst = dict.fromkeys(TOLERANCES, 0.0)
    for path in (hrp2_walk_path, hrp2_skate_build.path):
        lib = MotionLibrary.open(path)
        for e in lib:
            served, plan = Served.of(e.arrays), stored_plan(lib, e)
            assert served_failures(served, plan, 9.81) == [], e.key
            for name, w in measure(served, plan, 9.81).items():
                worst[name] = max(worst[name], w.value)
    assert all(worst[name] <= TOLERANCES[name] / 5 for name in TOLERANCES), worst
    assert worst["position"] > 1e-6  # the GPM's own position/velocity mismatch: a real tolerance, not round-off


@pytest.mark.parametrize(("name", "change", "words"), [
    (schema.D_STATE, _set((slice(None), 3), times=2.0),
     "state com_vx is not the time integral of control (the COM acceleration): off by"),
    (schema.D_STATE, _set((slice(None), 3), times=2.0), "state com_vx differs from nodes_state at nodes_t"),
    (schema.D_STATE, _set((300, 0), add=0.05), "state com_x is not the time integral of the COM velocity in state"),
    (schema.D_CONTROL, _set((slice(None), 0), add=1.0), "control com_ax differs from nodes_control at nodes_t"),
    (schema.D_CONTROL, _set((300, 2), add=0.01), "state com_vz is not the time integral of control"),
    (schema.D_CONTROL, lambda a: np.array(a)[:-1], "control: shape (659, 3), expected (660, 3)"),
    (schema.D_T, _swap, "t: not strictly increasing at knot 301"),
    (schema.D_T, _set(slice(None), add=0.5), "t: starts at 0.500000 s, nodes_t at 0.000000 s"),
    (schema.D_NODES_T, _set((2, -1), add=0.01), "nodes_t: the times of step 2 do not span the planned duration"),
    (schema.D_ZMP, _set((300, 1), add=0.5),
     "zmp zmp_y is not the ZMP of the COM motion (state, control) over contact_point: off by 5.00e-01 m"),
    (schema.D_STEP_INDEX, _set(slice(300, None), value=0), "step_index: decreases at knot 300"),
    (schema.D_STEP_INDEX, _set(320, value=3), "step_index: 3 at knot 320 (t = 3.200 s), nodes_t puts it in step 4"),
    (schema.D_STEP_INDEX, lambda a: np.asarray(a, dtype=float), "step_index: dtype float64, expected integers"),
    (schema.D_CONTACT_POINT, _set((300, 0), add=1.0), "contact_point x differs from the plan's contact point"),
    (schema.D_NODES_CONTACT_POINT, _set((3, 5, 1), add=0.01),
     "nodes_contact_point y differs from the plan's contact point"),
])
def test_validate_names_a_doctored_served_array(hrp2_walk_path, tmp_path, name, change, words):
    """A served array of the walk doctored (a whole column scaled or shifted, one knot moved, two
    times swapped, the step index wrong from a knot on or at one boundary): validate fails the
    entry with a message naming the array, the column and what is wrong."""
    assert words in _messages(_doctored(hrp2_walk_path, tmp_path, name, change))


def test_validate_catches_a_doctored_skate(hrp2_skate_v100, tmp_path):
    """On a skate, whose contact point rides the board: the board foot's point moved 1 cm at one
    knot of the slide, and the velocity off by 1 mm/s during the push."""
    assert "contact_point x differs from the plan's contact point: off by 1.00e-02 m" in _messages(
        _doctored(hrp2_skate_v100, tmp_path, schema.D_CONTACT_POINT, _set((200, 0), add=0.01)))
    assert "state com_vx is not the time integral of control" in _messages(
        _doctored(hrp2_skate_v100, tmp_path / "v", schema.D_STATE, _set((slice(40, 60), 3), add=1e-3)))


def test_the_build_judge_refuses_a_motion_whose_served_arrays_do_not_hold(hrp2_walk_motion):
    """The build judges the arrays it is about to store with the same checks: the solved walk
    passes, and the same motion with its served acceleration 1 m/s^2 off (its nodes untouched)
    fails naming ``control``."""
    c, m = hrp2_walk_motion
    assert judge(c, m) == ()
    found = judge(c, dataclasses.replace(m, control=m.control + np.array([1.0, 0.0, 0.0])))
    assert any(f.startswith("control com_ax differs from nodes_control") for f in found), found
    found = judge(c, dataclasses.replace(m, control=_set((300, 1), value=np.nan)(m.control)))
    assert found == ("control: not finite at row 300",)  # a reader refuses a file with one: it never gets there
