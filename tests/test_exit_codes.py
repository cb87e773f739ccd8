"""Every command's failure modes that need no solve, against README's exit-code table: an unknown
option is usage (2), a missing or damaged library 3, an output path that cannot be used 2;
each with one message on stderr and no traceback. (Code 1 is tested where entries fail or
libraries differ: test_build, test_compare; 4 in test_first_contact; 130 in test_reliability.)"""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import pytest
from skatelib.library import errors

from tests.helpers import CLI, TINY

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "tests" / "data" / "tiny-reference.h5"
COMMANDS = ("build", "solve", "frontier", "model", "info", "validate", "inspect", "plot", "track", "diff", "export",
            "certify")


def _run(args: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=120,
                          env={**os.environ, "COLUMNS": "200"})


def test_readme_documents_the_codes_the_command_line_uses():
    """README's table lists exactly the codes of skatelib.library.errors (and 0)."""
    text = (ROOT / "README.md").read_text()
    table = text[text.index("### Exit codes"):]
    documented = {int(m) for m in re.findall(r"^\| (\d+) \|", table, flags=re.M)}
    used = {0, errors.EXIT_FAILED, errors.EXIT_USAGE, errors.EXIT_LIBRARY, errors.EXIT_DEPENDENCY,
            errors.EXIT_INTERRUPTED}
    assert documented == used


@pytest.mark.parametrize("command", COMMANDS)
def test_an_unknown_option_is_usage(command):
    r = _run([command, "--no-such-option"])
    assert r.returncode == errors.EXIT_USAGE and "No such option" in r.stderr, r.stderr


@pytest.mark.parametrize("args", [
    ["info", "{missing}"], ["validate", "{missing}"], ["inspect", "{missing}", "--save", "{tmp}/x.rrd"],
    ["plot", "{missing}", "-o", "{tmp}/fig"], ["track", "{missing}"], ["diff", "{missing}", "{ref}"],
    ["diff", "{ref}", "{missing}"], ["export", "{missing}", "-f", "csv", "-o", "{tmp}/csv"],
    ["model", "{damaged}", "--twin", "{tmp}/t.xml"], ["model", "{missing}", "--twin", "{tmp}/t.xml"],
    ["info", "{damaged}"], ["build", "{tiny}", "--check", "{missing}"],
    ["certify", "{missing}"], ["certify", "{damaged}"],
])
def test_a_missing_or_damaged_library_is_3(tmp_path, args):
    damaged = tmp_path / "damaged.h5"
    raw = bytearray(REFERENCE.read_bytes())
    raw[len(raw) // 2] ^= 0xFF
    damaged.write_bytes(bytes(raw))
    line = [a.format(missing=tmp_path / "missing.h5", ref=REFERENCE, tmp=tmp_path, damaged=damaged, tiny=TINY)
            for a in args]
    r = _run(line)
    assert r.returncode == errors.EXIT_LIBRARY, (line, r.returncode, r.stderr)
    assert "Traceback" not in r.stderr and ("missing.h5" in r.stderr or "damaged.h5" in r.stderr), r.stderr


@pytest.mark.parametrize("args", [
    ["build", "{tiny}", "-o", "{tmp}"], ["solve", "-V", "0.3", "-s", "1", "--config", "{tiny}", "-o", "{tmp}"],
    ["frontier", "{tiny}", "-o", "{tmp}"], ["model", "{tiny}", "--twin", "{tmp}"],
    ["inspect", "{ref}", "--save", "{tmp}"], ["track", "{ref}", "--save", "{tmp}"],
    ["plot", "{ref}", "-o", "{file}"], ["export", "{ref}", "-f", "csv", "-o", "{file}"],
    ["export", "{ref}", "-f", "mcap", "-o", "{tmp}"], ["build", "{tiny}", "--check", "{ref}", "-o", "{tmp}/x.h5"],
])
def test_an_output_that_cannot_be_used_is_2(tmp_path, args):
    """A folder where a file goes, a file where a folder goes: refused before any work, the
    path named, nothing changed."""
    file = tmp_path / "notes.txt"
    file.write_text("keep me")
    line = [a.format(tiny=TINY, ref=REFERENCE, tmp=tmp_path, file=file) for a in args]
    r = _run(line)
    assert r.returncode == errors.EXIT_USAGE, (line, r.returncode, r.stdout, r.stderr)
    assert "Traceback" not in r.stderr and file.read_text() == "keep me"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


@pytest.mark.parametrize("variable", ["SKATELIB_CACHE_DIR", "SKATELIB_COMPILE_DIR"])
@pytest.mark.parametrize("args", [["solve", "-V", "0.5", "-s", "2", "-o", "{tmp}/x.h5"],
                                  ["frontier", "-s", "2", "-o", "{tmp}/f.json"],
                                  ["build", "-o", "{tmp}/x.h5", "--no-cache"]])
def test_a_cache_folder_that_is_a_file_is_refused_first(tmp_path, args, variable):
    """The folder of compiled code naming a file (SKATELIB_CACHE_DIR with no SKATELIB_COMPILE_DIR
    set, or SKATELIB_COMPILE_DIR): solve, frontier and build --no-cache (which still keep the
    compiled stage functions there) exit 2 naming the variable, before any solve, with advice
    that is not to pass --no-cache."""
    blocker = tmp_path / "cachefile"
    blocker.write_text("")
    env = {k: v for k, v in os.environ.items() if k != "SKATELIB_COMPILE_DIR"}
    r = subprocess.run([*CLI, *[a.format(tmp=tmp_path) for a in args]], capture_output=True, text=True, timeout=120,
                       env={**env, "COLUMNS": "200", variable: str(blocker)})
    assert r.returncode == errors.EXIT_USAGE and variable in r.stderr, r.stdout + r.stderr
    assert "pass --no-cache" not in r.stderr and "Traceback" not in r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cachefile"]
