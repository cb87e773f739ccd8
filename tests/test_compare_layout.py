"""What `skatelib diff` sees beyond the numbers of a column: the columns' names and units (a channel
compared with the channel of its name), integer codes compared exactly, an infinity equal to
itself, the controller's solve times reported but not counted, libraries of two kinds refused,
the model's arrays and URDF located, and JSON that a strict parser reads. Each case doctors a copy
of the committed tiny reference library and states what the comparison must say of it."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from skatelib.library.attributes import split
from skatelib.library.compare import KindsDiffer, Tolerance, compare, compare_files
from skatelib.library.reader import read_library
from skatelib.library.writer import write_library
from skatelib.pipeline.views.console import json_text
from skatelib.runtime import MotionLibrary

from tests.helpers import run_cli

REFERENCE = Path(__file__).parent / "data" / "tiny-reference.h5"
KEY = "v0.30_s1"


def _doctored(path: Path, entry=None, model_arrays=None, model_text=None) -> Path:
    """The reference written again with entry ``KEY`` replaced by ``entry(record)`` and the model's
    arrays and texts updated."""
    data = read_library(REFERENCE)
    entries = [entry(e) if entry and k == KEY else e for k, e in data.entries.items()]
    keep = {k: v for k, v in data.attrs.items() if k not in ("format", "format_version", "content_sha256")}
    return write_library(path, keep, data.model_attrs, {**data.model_arrays, **(model_arrays or {})},
                         {**data.model_text, **(model_text or {})}, entries)


def _with(rec, arrays=None, columns=None, units=None):
    return type(rec)(rec.key, rec.attrs, {**rec.arrays, **(arrays or {})}, {**rec.columns, **(columns or {})},
                     {**rec.units, **(units or {})})


def _swap(seq, i: int, j: int) -> tuple:
    out = list(seq)
    out[i], out[j] = out[j], out[i]
    return tuple(out)


def test_swapped_column_names_differ(tmp_path):
    """base_x and base_y renamed into each other's place (the numbers where they were): the runtime
    hands out other numbers for 'base_x', so diff counts the columns' change and compares each
    channel with the one of its name."""
    rec = read_library(REFERENCE).entries[KEY]
    out = _doctored(tmp_path / "swapped.h5", lambda r: _with(r, columns={"state": _swap(r.columns["state"], 0, 1)}))
    read_x = [MotionLibrary.open(p)[KEY].channel("base_x")[20] for p in (REFERENCE, out)]
    assert read_x[0] != read_x[1]
    d = compare_files(REFERENCE, out)
    (change,) = d.changed
    assert not d.equal and change.differs
    assert [s.name for s in change.shapes] == ["state columns"]
    assert change.shapes[0].a == {"0": "base_x", "1": "base_y"} and change.shapes[0].b == {"0": "base_y", "1": "base_x"}
    moved = {c.column: c.max_abs for c in change.channels}
    x, y = rec.arrays["state"][:, 0], rec.arrays["state"][:, 1]
    assert set(moved) == {"base_x", "base_y"} and moved["base_x"] == pytest.approx(np.max(np.abs(x - y)))


def test_reordered_columns_compare_by_name(tmp_path):
    """The state's first two columns stored the other way round, names and numbers together: every
    channel holds what it held, so no channel differs; the order itself is a counted change (a
    reader by position gets another channel)."""
    def reordered(r):
        state = np.array(r.arrays["state"])
        state[:, [0, 1]] = state[:, [1, 0]]
        return _with(r, {"state": state}, {"state": _swap(r.columns["state"], 0, 1)},
                     {"state": _swap(r.units["state"], 0, 1)})

    d = compare_files(REFERENCE, _doctored(tmp_path / "reordered.h5", reordered))
    (change,) = d.changed
    assert change.channels == () and [s.name for s in change.shapes] == ["state columns"] and not d.equal


def test_a_unit_changed_differs(tmp_path):
    """base_roll's unit written as deg over the same numbers: a counted change naming the column."""
    out = _doctored(tmp_path / "deg.h5", lambda r: _with(r, units={"state": tuple(
        "deg" if c == "base_roll" else u for c, u in zip(r.columns["state"], r.units["state"], strict=True))}))
    (change,) = compare_files(REFERENCE, out).changed
    assert [(s.name, s.a, s.b) for s in change.shapes] == [("state units", {"base_roll": "rad"}, {"base_roll": "deg"})]


def test_contact_codes_compare_exactly_under_any_tolerance(tmp_path):
    """A foot's contact code from board (1) to swing (0) at one knot: a difference even with
    atol 1 (codes are not measurements); a float channel moved by 0.5 is hidden by it."""
    def recoded(r):
        contact = np.array(r.arrays["contact"])
        state = np.array(r.arrays["state"])
        k = int(np.flatnonzero(contact[:, 0] == 1)[0])
        contact[k, 0] = 0
        state[k, 2] += 0.5
        return _with(r, {"contact": contact, "state": state})

    d = compare_files(REFERENCE, _doctored(tmp_path / "codes.h5", recoded), Tolerance(atol=1.0))
    (change,) = d.changed
    assert [(c.array, c.a, c.b) for c in change.channels] == [("contact", 1.0, 0.0)] and not d.equal


def test_an_infinity_equals_itself():
    """inf against inf, and -inf against -inf, are alike (``inf - inf`` is NaN); against another
    number or the other infinity they differ."""
    a = np.array([np.inf, -np.inf, np.inf, np.inf, 1.0])
    b = np.array([np.inf, -np.inf, -np.inf, 1e308, 1.0])
    assert Tolerance(atol=1e-3).exceeded(a, b).tolist() == [False, False, True, True, False]


def test_the_controllers_solve_times_are_effort():
    """The closed-loop verdicts' MPC and whole-body solve times (model plant, twin, a maneuver's)
    are the machine's: reported, not counted; the delivered speed is counted."""
    figures = {"closed_loop.mpc_median_ms": 1.6, "closed_loop.mpc_max_ms": 5.2, "closed_loop_twin.wbc_median_ms": 0.1,
               "closed_loop_twin.mpc_median_ms": 1.8, "closed_loop.delivered_mps": 0.3,
               "closed_loop_twin.max_wheel_lift_ms": 12.0}
    counted, effort = split(figures)
    assert set(counted) == {"closed_loop.delivered_mps", "closed_loop_twin.max_wheel_lift_ms"}
    assert set(effort) == set(figures) - set(counted)


def test_libraries_of_two_kinds_are_not_compared(tmp_path):
    """A quadruped's library against one that says it is a humanoid's: KindsDiffer naming both
    files and kinds, not a list of every entry removed and added."""
    data = read_library(REFERENCE)
    other = dataclasses.replace(data, path=tmp_path / "walk.h5", attrs={**data.attrs, "kind": "humanoid"})
    with pytest.raises(KindsDiffer, match=r"tiny-reference.h5 is a quadruped library and .*walk.h5 a humanoid one"):
        compare(data, other)


def test_the_model_arrays_and_urdf_are_located(tmp_path):
    """One element of a model array moved, one URDF limit changed: the array's change names the
    element and gives both values, the URDF's its first differing line."""
    data = read_library(REFERENCE)
    inertia = np.array(data.model_arrays["robot_inertia_kgm2"])
    inertia[1, 2] += 1e-3
    urdf = data.model_text["robot_urdf"]
    line = next(i for i, s in enumerate(urdf.splitlines()) if 'effort="' in s)
    lines = urdf.splitlines()
    lines[line] = lines[line].replace('effort="', 'effort="9')
    out = _doctored(tmp_path / "model.h5", model_arrays={"robot_inertia_kgm2": inertia},
                    model_text={"robot_urdf": "\n".join(lines)})
    model = {c.name: c for c in compare_files(REFERENCE, out).model}
    assert set(model) == {"robot_inertia_kgm2[1, 2]", f"robot_urdf line {line + 1}"}
    m = model["robot_inertia_kgm2[1, 2]"]
    assert float(m.b) - float(m.a) == pytest.approx(1e-3)
    assert 'effort="9' in model[f"robot_urdf line {line + 1}"].b


def test_json_is_strict_json(tmp_path):
    """json_text writes NaN and infinities as null (a strict parser refuses Python's NaN token), and
    diff --json of a channel that became NaN is read by such a parser; each changed entry says
    whether it differs."""
    doc = json.loads(json_text({"a": float("nan"), "b": [np.float64("inf"), 1.5], "c": np.int64(3), "d": (True,)}),
                     parse_constant=lambda c: pytest.fail(f"non-standard JSON constant {c}"))
    assert doc == {"a": None, "b": [None, 1.5], "c": 3, "d": [True]}

    def nan_at_20(r):
        state = np.array(r.arrays["state"])
        state[20, 2] = np.nan
        return _with(r, {"state": state})

    out = _doctored(tmp_path / "nan.h5", nan_at_20)
    r = run_cli(["diff", str(REFERENCE), str(out), "--json"])
    doc = json.loads(r.stdout, parse_constant=lambda c: pytest.fail(f"non-standard JSON constant {c}"))
    (entry,) = doc["changed"]
    assert r.returncode == 1 and entry["differs"] is True
    assert entry["channels"][0]["column"] == "base_z" and entry["channels"][0]["max_abs"] is None


def test_a_humanoids_node_arrays_name_step_node_channel_and_time():
    """nodes_state (steps x start, nodes, end x channels, laid out as state) with one value moved:
    named by its channel, step and node, at that node's time in nodes_t; nodes_control (the nodes
    alone) at the time of its node, one past the step's start."""
    from skatelib.library.channel_diff import channels
    from skatelib.library.records import EntryRecord

    rng = np.random.default_rng(0)
    times = np.cumsum(rng.uniform(0.05, 0.1, (3, 6)), axis=None).reshape(3, 6)
    state, control = rng.normal(size=(3, 6, 2)), rng.normal(size=(3, 4, 2))
    rec = EntryRecord("walk", {}, {"nodes_t": times, "nodes_state": state, "nodes_control": control},
                      {"state": ("com_x", "com_y"), "control": ("com_ax", "com_ay")},
                      {"state": ("m", "m"), "control": ("m/s^2", "m/s^2")})
    moved_state, moved_control = state.copy(), control.copy()
    moved_state[2, 4, 1] += 0.002
    moved_control[1, 0, 0] -= 0.5
    (s,) = channels("nodes_state", state, moved_state, rec, np.zeros(0), Tolerance())
    (c,) = channels("nodes_control", control, moved_control, rec, np.zeros(0), Tolerance())
    assert (s.column, s.unit, s.at_s) == ("com_y (step 2, node 4)", "m", times[2, 4])
    assert s.max_abs == pytest.approx(0.002)
    assert (c.column, c.unit, c.at_s) == ("com_ax (step 1, node 0)", "m/s^2", times[1, 1])


def test_other_knots_give_both_durations(tmp_path):
    """The entry stored a knot shorter: the arrays' shapes, and how long each motion lasts."""
    out = _doctored(tmp_path / "short.h5", lambda r: type(r)(r.key, r.attrs, {k: v[:-1] for k, v in r.arrays.items()},
                                                              r.columns, r.units))
    (change,) = compare_files(REFERENCE, out).changed
    t = read_library(REFERENCE).entries[KEY].arrays["t"]
    shapes = {s.name: (s.a, s.b) for s in change.shapes}
    assert shapes["t"] == ([len(t)], [len(t) - 1])
    assert shapes["duration [s]"] == (pytest.approx(t[-1] - t[0]), pytest.approx(t[-2] - t[0]))


def test_validate_names_stored_figures_that_its_checks_do_not_give(tmp_path):
    """A library whose physics_json claims a Coulomb margin of 5 N (its arrays give about 2.4 N),
    sealed again: validate names the stored and the computed figure; the untouched reference has
    no such note (the same code gives the same numbers)."""
    from skatelib.pipeline.quadruped.kind import stored_figures_note

    def claimed(r):
        physics = json.loads(r.attrs["physics_json"])
        return type(r)(r.key, {**r.attrs, "physics_json": json.dumps({**physics, "min_friction_margin_N": 5.0})},
                       r.arrays, r.columns, r.units)

    r = run_cli(["validate", str(_doctored(tmp_path / "claimed.h5", claimed))])
    line = next(x for x in r.stdout.splitlines() if x.startswith(KEY))
    assert "stored figures differ" in line and "min_friction_margin_N 5 stored" in line, r.stdout
    assert "stored figures differ" not in run_cli(["validate", str(REFERENCE)]).stdout
    assert stored_figures_note('{"max_defect": 1e-5}', {"max_defect": 1e-5 * (1 + 1e-12)}) == ""
    assert "max_defect" in stored_figures_note('{"max_defect": 1e-5}', {"max_defect": 2e-5})
