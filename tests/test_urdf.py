"""A library's URDF never makes skatelib read a file outside the library: a ``<mesh>`` (or a
``<texture>``) naming a local path is dropped before pinocchio's geometry or MuJoCo sees the text,
said once in a note, and `inspect`, `model --twin` and `track --plant mujoco` work on the URDF's
primitive shapes. (pinocchio's visual model opened the path, so `inspect` read `/etc/shadow`;
MuJoCo loaded the mesh into the twin or stopped on a traceback.) Whether the mesh file was read is
seen by its access time (set older than its modification time: any read moves it on a relatime or
strictatime mount; the test checks that first) and by the outputs' content."""

from __future__ import annotations

import dataclasses
import os
import subprocess
from pathlib import Path

import pytest
from skatelib.library import schema
from skatelib.library.errors import ModelError
from skatelib.library.reader import read_library
from skatelib.library.urdf import mesh_files, without_meshes
from skatelib.library.writer import write_library

from tests.helpers import CLI

REFERENCE = Path(__file__).parent / "data" / "tiny-reference.h5"
ROBOTS = Path(__file__).parents[1] / "configs" / "robots"
MARKER = b"# skatelib-test-mesh-bytes 5f1c"
# A mesh MuJoCo and pinocchio would load (a tetrahedron), with bytes the outputs must not carry.
MESH = b"v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n" + MARKER + b"\n"
TRUNK_BOX = '<geometry><box size="0.38 0.11 0.09"/></geometry>\n    </visual>'


def _with_mesh(urdf: str, mesh: Path) -> str:
    extra = (f'\n    <visual><geometry><mesh filename="{mesh}"/></geometry>'
             f'<material name="skin"><texture filename="{mesh}"/></material></visual>'
             f'\n    <collision><geometry><mesh filename="{mesh}" scale="1 1 1"/></geometry></collision>')
    assert TRUNK_BOX in urdf
    return urdf.replace(TRUNK_BOX, TRUNK_BOX + extra, 1)


def _crafted(folder: Path, mesh: Path) -> Path:
    """A copy of the reference library whose URDF names ``mesh``, sealed as skatelib writes."""
    data = read_library(REFERENCE)
    text = dict(data.model_text)
    text[schema.D_ROBOT_URDF] = _with_mesh(text[schema.D_ROBOT_URDF], mesh)
    protected = {schema.A_FORMAT, schema.A_FORMAT_VERSION, schema.A_CHECKSUM}
    root = {k: v for k, v in data.attrs.items() if k not in protected}
    path = folder / "crafted.h5"
    write_library(path, root, data.model_attrs, data.model_arrays, text, list(data.entries.values()))
    return path


def _untouched(mesh: Path) -> float:
    """Give ``mesh`` an access time older than its modification time; returns it."""
    st = mesh.stat()
    os.utime(mesh, ns=(1_000_000_000, st.st_mtime_ns))
    return mesh.stat().st_atime


@pytest.fixture
def crafted(tmp_path):
    """(library, mesh file, whether reads are seen in the access time); the mesh also under its bare
    name in the working folder (MuJoCo strips a mesh's folder and looks there)."""
    mesh = tmp_path / "skin.obj"
    mesh.write_bytes(MESH)
    before = _untouched(mesh)
    mesh.read_bytes()
    seen = mesh.stat().st_atime != before  # a noatime mount shows no read
    return _crafted(tmp_path, mesh), mesh, seen


def _run(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=600, cwd=cwd,
                          env={**os.environ, "COLUMNS": "200"})


@pytest.mark.parametrize("name", ["cyberdog2.urdf", "hrp2_class.urdf"])
def test_the_shipped_urdfs_name_no_mesh_and_pass_unchanged(name):
    text = (ROBOTS / name).read_text()
    assert mesh_files(text) == [] and without_meshes(text) is text


def test_meshes_and_textures_are_dropped_and_primitives_kept(tmp_path):
    """The mesh shapes and the texture go, every primitive shape and every link and joint stay."""
    import xml.etree.ElementTree as ET

    text = (ROBOTS / "cyberdog2.urdf").read_text()
    mesh = tmp_path / "skin.obj"
    crafted = _with_mesh(text, mesh)
    assert mesh_files(crafted) == [str(mesh)] * 3
    kept = ET.fromstring(without_meshes(crafted))
    plain = ET.fromstring(text)
    assert mesh_files(without_meshes(crafted)) == []
    for tag in ("link", "joint", "box", "sphere", "cylinder", "visual", "inertial"):
        assert len(list(kept.iter(tag))) == len(list(plain.iter(tag))), tag


def test_a_foot_without_a_primitive_shape_is_a_model_error():
    """The twin's feet are the URDF's foot spheres: a foot given only a mesh is refused naming it."""
    pytest.importorskip("mujoco")
    from skatelib.runtime import MotionLibrary
    from skatelib.sim.figures import TwinFigures
    from skatelib.sim.robot import robot_spec

    f = TwinFigures.from_library(MotionLibrary.open(REFERENCE))
    sphere = '<geometry><sphere radius="0.019"/></geometry>'
    assert sphere in f.urdf
    meshy = f.urdf.replace(sphere, '<geometry><mesh filename="/nonexistent/foot.stl"/></geometry>', 1)
    with pytest.raises(ModelError, match="FL_foot no primitive shape"):
        robot_spec(dataclasses.replace(f, urdf=meshy))


def test_inspect_draws_the_primitives_and_reads_no_mesh(crafted, tmp_path):
    """`inspect --save`: exit 0, the note once, no traceback; the recording holds none of the mesh's
    bytes and the mesh was not read."""
    pytest.importorskip("rerun")
    lib, mesh, seen = crafted
    atime = _untouched(mesh)
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / mesh.name).write_bytes(MESH)
    rrd = tmp_path / "out.rrd"
    r = _run(["inspect", str(lib), "--save", str(rrd)], tmp_path / "run")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "Traceback" not in r.stderr and r.stderr.count("names mesh files") == 1, r.stderr
    assert MARKER not in rrd.read_bytes()
    if seen:
        assert mesh.stat().st_atime == atime


def test_the_twin_is_built_from_the_primitives_and_reads_no_mesh(crafted, tmp_path):
    """`model --twin`: exit 0, no traceback, an MJCF with no mesh; then `track --plant mujoco` of
    one entry rides it (exit 0 or 1: the verdict is the entry's), the note once, no traceback; the
    mesh (at its path and under its bare name in the working folder) read by neither."""
    pytest.importorskip("mujoco")
    lib, mesh, seen = crafted
    run = tmp_path / "run"
    run.mkdir()
    bare = run / mesh.name
    bare.write_bytes(MESH)
    atimes = {p: _untouched(p) for p in (mesh, bare)}
    xml = tmp_path / "twin.xml"
    r = _run(["model", str(lib), "--twin", str(xml)], run)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stdout + r.stderr
    assert r.stderr.count("names mesh files") == 1
    assert "<mesh" not in xml.read_text() and mesh.name not in xml.read_text()
    r = _run(["track", str(lib), "--plant", "mujoco", "-e", "v0.30_s1", "--perturb", "none", "-j", "1",
              "--no-progress"], run)
    assert r.returncode in (0, 1) and "Traceback" not in r.stderr, r.stdout + r.stderr
    assert "v0.30_s1" in r.stdout and r.stderr.count("names mesh files") == 1
    if seen:
        assert {p: p.stat().st_atime for p in atimes} == atimes
