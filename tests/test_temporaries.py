"""The sweep of stale temporaries removes what a killed skatelib process left in an output folder
and nothing else: the user's files and folders whose names look like temporaries (a number that is
no live process among dots or dashes) survive every command that writes there."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

from skatelib.library import temporaries
from skatelib.library.atomic import atomic_path
from skatelib.pipeline.build.preflight import check_folder, check_output

from tests.helpers import run_cli

REFERENCE = Path(__file__).parent / "data" / "tiny-reference.h5"

# What a user keeps in a folder: names the old sweep took for a dead writer's temporaries.
USERS = {".thesis.2019.final.tmp": "file", ".photos.1999.backup.tmp": "folder", "skatelib-99999-notes": "folder",
         ".skatelib-tmp.99999.abcdefgh.notes": "folder",  # skatelib's name, but no marker inside
         ".skatelib-tmp.notes": "file", ".skatelib-tmp.99999.short.x": "file"}


def _users_things(folder: Path) -> dict[Path, bytes]:
    """The user's files and folders (each folder with a file in it); path -> content."""
    made = {}
    for name, kind in USERS.items():
        p = folder / name
        if kind == "folder":
            p.mkdir()
            p = p / "inside.txt"
        p.write_bytes(f"the user's {name}".encode())
        made[p] = p.read_bytes()
    return made


def _killed_writer(folder: Path) -> int:
    """Leave a temporary file and a temporary folder in ``folder`` from a process that dies in the
    middle of writing (``os._exit``: no clean-up runs), as kill -9 would; returns its pid."""
    code = ("import os, sys; from pathlib import Path\n"
            "from skatelib.library.atomic import atomic_path\n"
            "from skatelib.library.temporaries import temporary_folder\n"
            "folder = Path(sys.argv[1])\n"
            "with atomic_path(folder / 'x.h5') as tmp, temporary_folder(folder, 'figures') as d:\n"
            "    tmp.write_bytes(b'half'); (d / 'speeds.png').write_bytes(b'half')\n"
            "    print(os.getpid(), flush=True); os._exit(0)\n")
    run = subprocess.run([sys.executable, "-c", code, str(folder)], capture_output=True, text=True, check=True)
    return int(run.stdout)


def _leftovers(folder: Path, pid: int) -> list[Path]:
    return sorted(folder.glob(f"{temporaries.PREFIX}{pid}.*"))


def test_a_sweep_removes_a_dead_writers_temporaries_and_nothing_of_the_users(tmp_path):
    """check_output (build, solve, model --twin, track, frontier) and check_folder (plot, export)
    on a folder holding the user's look-alikes and a killed writer's file and folder: only the
    latter two go."""
    for sweep in (lambda d: check_output(d / "out.h5"), check_folder):
        folder = tmp_path / f"victim{len(list(tmp_path.iterdir()))}"
        folder.mkdir()
        users = _users_things(folder)
        pid = _killed_writer(folder)
        left = _leftovers(folder, pid)
        assert len(left) == 2 and any(p.is_dir() for p in left)
        sweep(folder)
        assert _leftovers(folder, pid) == []
        assert {p: p.read_bytes() for p in users} == users


def test_a_live_writers_temporary_and_a_symlink_are_left_alone(tmp_path):
    """A temporary of a running process (this one) is work in progress; a symlink with a dead
    pid's temporary name, to a folder of the user's, is not followed or removed."""
    with atomic_path(tmp_path / "y.h5") as tmp:
        assert tmp.name.startswith(f"{temporaries.PREFIX}{os.getpid()}.") and tmp.name.endswith(".y.h5")
        assert temporaries.remove_stale_temporaries(tmp_path) == [] and tmp.exists()
    precious = tmp_path / "precious"
    precious.mkdir()
    (precious / temporaries.MARKER).write_bytes(b"")
    (precious / "data.txt").write_text("keep")
    link = tmp_path / f"{temporaries.PREFIX}99999999.abcdefgh.figures"
    link.symlink_to(precious, target_is_directory=True)
    assert temporaries.remove_stale_temporaries(tmp_path) == []
    assert link.is_symlink() and (precious / "data.txt").read_text() == "keep"


def test_export_leaves_the_users_look_alikes_in_its_folder(tmp_path):
    """``skatelib export -f csv -o victim`` writes its files beside the user's look-alikes, which
    survive whole (the old sweep removed ``skatelib-99999-notes/`` and the ``.tmp`` ones)."""
    victim = tmp_path / "victim"
    victim.mkdir()
    users = _users_things(victim)
    lib = tmp_path / "lib.h5"
    shutil.copyfile(REFERENCE, lib)
    r = run_cli(["export", str(lib), "-f", "csv", "-o", str(victim)], timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    assert {p: p.read_bytes() for p in users} == users
    assert sorted(p.name for p in victim.glob("*.csv")) == ["v0.30_s1.csv", "v0.40_s1.csv"]
