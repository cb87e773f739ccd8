"""`skatelib export`: each format read back with its own reader (numpy, csv, the mcap package's
ROS 2 decoder) equals the library: every array, column name and unit; the MCAP's poses, joint
states and foot forces at the entry's times (the bag's ROS 2 rules, /tf and the entries' timeline:
``test_ros_bag.py``)."""

from __future__ import annotations

import csv
import stat
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from skatelib.library.channels import LEGS
from skatelib.library.reader import read_library
from skatelib.library.rotations import rpy_matrices
from skatelib.pipeline.ros_messages import quaternion_xyzw

from tests.helpers import run_cli

_cli = run_cli


@pytest.fixture(scope="module")
def lib(tiny_v03):
    """A library of one solved entry (0.3 m/s, one stride; the session's)."""
    return tiny_v03.path


def test_npz_round_trips(lib, tmp_path):
    data = read_library(lib)
    r = _cli(["export", str(lib), "-f", "npz", "-o", str(tmp_path / "npz")])
    assert r.returncode == 0, r.stdout + r.stderr
    for key, e in data.entries.items():
        with np.load(tmp_path / "npz" / f"{key}.npz") as z:
            for name, arr in e.arrays.items():
                np.testing.assert_array_equal(z[name], arr)
            for name, cols in e.columns.items():
                assert list(z[f"{name}__columns"]) == list(cols) and list(z[f"{name}__units"]) == list(e.units[name])


def test_csv_round_trips(lib, tmp_path):
    """Every cell equals the library's value to the last bit (repr of a float); a control's last
    knot is empty."""
    data = read_library(lib)
    r = _cli(["export", str(lib), "-f", "csv", "-o", str(tmp_path / "csv")])
    assert r.returncode == 0, r.stdout + r.stderr
    key, e = next(iter(data.entries.items()))
    with open(tmp_path / "csv" / f"{key}.csv", newline="") as f:
        rows = list(csv.reader(f))
    head, body = rows[0], rows[1:]
    assert head[0] == "t [s]" and len(body) == len(e.arrays["t"])
    col = head.index("state.base_z [m]")
    assert [float(row[col]) for row in body] == e.arrays["state"][:, 2].tolist()
    col = head.index("foot_pos.RL.y [m]")
    assert [float(row[col]) for row in body] == e.arrays["foot_pos"][:, 2, 1].tolist()
    col = head.index("control.f_FR_z [N]")
    assert [float(row[col]) for row in body[:-1]] == e.arrays["control"][:, 5].tolist() and body[-1][col] == ""


def test_mcap_round_trips(lib, tmp_path):
    """The bag of one entry read with mcap's ROS 2 decoder: one message per knot and topic, stamped
    with the knot's time; the base position, the orientation (as a rotation matrix) and the joint angles,
    velocities and foot forces equal the library's."""
    reader = pytest.importorskip("mcap.reader")
    decoder = pytest.importorskip("mcap_ros2.decoder")
    data = read_library(lib)
    out = tmp_path / "lib.mcap"
    r = _cli(["export", str(lib), "-f", "mcap", "-o", str(out)])
    assert r.returncode == 0, r.stdout + r.stderr
    e = next(iter(data.entries.values()))
    t, x, u = e.arrays["t"], e.arrays["state"], e.arrays["control"]
    got: dict[str, list] = {}
    with open(out, "rb") as f:
        for _, channel, message, m in reader.make_reader(f, decoder_factories=[decoder.DecoderFactory()]
                                                        ).iter_decoded_messages():
            got.setdefault(channel.topic, []).append((message.log_time, m))
    poses = got["/skatelib/base_pose"]
    assert [ns for ns, _ in poses] == [round(s * 1e9) for s in t]
    R = rpy_matrices(x[:, 3:6])
    for k, (_, m) in enumerate(poses):
        p = m.pose.position
        assert [p.x, p.y, p.z] == x[k, 0:3].tolist()
        o = m.pose.orientation
        np.testing.assert_allclose([o.x, o.y, o.z, o.w], quaternion_xyzw(R[k]), atol=1e-15)
    joints = got["/joint_states"]
    assert list(joints[3][1].name)[:3] == ["FL_abad", "FL_hip", "FL_knee"]
    np.testing.assert_array_equal([list(m.position) for _, m in joints], x[:, 12:24])
    np.testing.assert_array_equal([list(m.velocity) for _, m in joints][:-1], u[:, 12:24])
    for i, leg in enumerate(LEGS):
        forces = [[m.wrench.force.x, m.wrench.force.y, m.wrench.force.z] for _, m in got[f"/skatelib/foot_force/{leg}"]]
        np.testing.assert_array_equal(forces[:-1], u[:, 3 * i:3 * i + 3])
    assert len(got["/skatelib/arrays/state"]) == len(t) and len(got["/skatelib/board_twist"]) == len(t)


def test_quaternion_matches_the_rotation():
    """The quaternion of random rotations rebuilds the matrix (an independent formula)."""
    rng = np.random.default_rng(1)
    for rpy in rng.uniform(-3.1, 3.1, size=(200, 3)):
        R = rpy_matrices(rpy[None])[0]
        x, y, z, w = quaternion_xyzw(R)
        rebuilt = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        np.testing.assert_allclose(rebuilt, R, atol=1e-12)


def test_failed_entries_are_left_out_and_named(tmp_path):
    """A library with a failed entry beside a solved one: the export writes the solved one's file
    alone and names the one left out; a library whose only entry failed: exit 1, nothing to export,
    no folder made."""
    from skatelib.library import schema
    from skatelib.library.writer import write_library

    from tests.test_cpp_reader import _entry, _root

    good = _entry(0.3, 1, False)
    other = _entry(0.4, 1, False)
    bad = type(other)(other.key, {**other.attrs, schema.A_SUCCESS: False, schema.A_STATUS: "Infeasible"},
                      other.arrays, other.columns, other.units)
    model = dict.fromkeys(schema.QUADRUPED_MODEL_ATTRS, 1.0)
    lib = write_library(tmp_path / "f.h5", _root(), model, {}, {}, [good, bad])
    r = _cli(["export", str(lib), "-f", "csv", "-o", str(tmp_path / "csv")])
    assert r.returncode == 0 and "left out 1 failed entry" in r.stdout, r.stdout + r.stderr
    assert {p.name for p in (tmp_path / "csv").iterdir()} == {f"{good.key}.csv"}
    lib = write_library(tmp_path / "g.h5", _root(), model, {}, {}, [bad])
    r = _cli(["export", str(lib), "-f", "csv", "-o", str(tmp_path / "none")])
    assert r.returncode == 1 and "nothing to export" in r.stderr, r.stdout + r.stderr
    assert not (tmp_path / "none").exists()


REFERENCE = Path(__file__).parent / "data" / "tiny-reference.h5"  # two solved entries


@pytest.mark.parametrize("fmt", ["npz", "csv"])
@pytest.mark.parametrize("existing", [False, True])
def test_an_interrupted_export_leaves_nothing(tmp_path, monkeypatch, fmt, existing):
    """Ctrl-C while the second entry is converted: no file of the export, no temporary, and no
    folder it made (the old code left the first entry's file in a new folder); a folder that was
    there keeps exactly what it had."""
    from skatelib.pipeline import exports

    out = tmp_path / "a" / "b"
    if existing:
        out.mkdir(parents=True)
        (out / "mine.txt").write_text("the user's")
    convert = exports.headers if fmt == "csv" else np.savez
    calls = []

    def second_interrupts(*args: Any, **kw: Any) -> Any:
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return convert(*args, **kw)

    if fmt == "csv":
        monkeypatch.setattr(exports, "headers", second_interrupts)
    else:
        monkeypatch.setattr(exports.np, "savez", second_interrupts)
    with pytest.raises(KeyboardInterrupt):
        exports.export(REFERENCE, fmt, out)
    assert len(calls) == 2
    if existing:
        assert sorted(p.name for p in tmp_path.rglob("*")) == ["a", "b", "mine.txt"]
    else:
        assert list(tmp_path.iterdir()) == []


def test_a_failed_export_leaves_no_folder(tmp_path):
    """`export` of a damaged library into a new folder: exit 3, and the folder (and its new parent)
    is not made (the old code made it before reading the library)."""
    bad = tmp_path / "bad.h5"
    bad.write_bytes(REFERENCE.read_bytes()[:5000])
    r = _cli(["export", str(bad), "-f", "csv", "-o", str(tmp_path / "new" / "csv")])
    assert r.returncode == 3, r.stdout + r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.h5"]


def test_a_complete_export_makes_an_ordinary_folder(tmp_path):
    """The files all arrive, in a folder with the mode mkdir gives (not the staging folder's 0700),
    with nothing else in it; into an existing folder they join what was there."""
    out = tmp_path / "new" / "npz"
    written = _cli(["export", str(REFERENCE), "-f", "npz", "-o", str(out)])
    assert written.returncode == 0, written.stdout + written.stderr
    assert sorted(p.name for p in out.iterdir()) == ["v0.30_s1.npz", "v0.40_s1.npz"]
    assert stat.S_IMODE(out.stat().st_mode) == stat.S_IMODE((tmp_path / "new").stat().st_mode)
    (out / "v0.30_s1.npz").unlink()
    (out / "mine.txt").write_text("the user's")
    assert _cli(["export", str(REFERENCE), "-f", "npz", "-o", str(out)]).returncode == 0
    assert sorted(p.name for p in out.iterdir()) == ["mine.txt", "v0.30_s1.npz", "v0.40_s1.npz"]


@pytest.mark.parametrize("fmt", ["npz", "csv"])
def test_a_file_of_the_users_with_an_entrys_name_is_not_overwritten(tmp_path, fmt):
    """A folder that holds a file of another kind under an entry's file name: exit 2 naming it, and
    nothing of the export arrives (the other entry's file neither). A file the export wrote before
    is replaced."""
    out = tmp_path / "x"
    out.mkdir()
    theirs = out / f"v0.30_s1.{fmt}"
    theirs.write_text("the user's notes")
    r = _cli(["export", str(REFERENCE), "-f", fmt, "-o", str(out)])
    assert r.returncode == 2 and theirs.name in r.stderr and "refusing to overwrite" in r.stderr, r.stderr
    assert sorted(p.name for p in out.iterdir()) == [theirs.name] and theirs.read_text() == "the user's notes"
    theirs.unlink()
    assert _cli(["export", str(REFERENCE), "-f", fmt, "-o", str(out)]).returncode == 0
    assert _cli(["export", str(REFERENCE), "-f", fmt, "-o", str(out)]).returncode == 0  # its own files: replaced
