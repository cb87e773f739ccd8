"""Tables that fit: ``skatelib info`` at 100 columns and ``skatelib track`` at 80 (model plant,
twin, humanoid) print no line wider than the terminal and no cut cell ("…"), and every column
header carries its unit in brackets or is unitless by nature; the fitting itself keeps every cell
whole at any width. Negative controls: the same checks flag the tables as rich lays them out by
itself (the cells cut) and the headers without units."""

from __future__ import annotations

import io
import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rich.console import Console
from rich.markup import escape
from rich.table import Table
from skatelib.pipeline.views.fitted import fitted_tables

from tests.helpers import CLI

DATA = Path(__file__).parent / "data"
REFERENCE = DATA / "tiny-reference.h5"  # 2 start-ups (0.30 and 0.40 m/s, 1 stride)
SIDESLIP = DATA / "old-sideslip.h5"  # a speed-up and a stop

# Headers without a unit by nature: names, counts, yes/no, verdicts, texts; "parameter" and "value"
# of the model table, whose every name ends in its unit (robot_mass_kg).
UNITLESS = {"entry", "status", "success", "solved", "strides", "iter", "knots", "verdict", "closed loop", "on twin",
            "fell", "entries", "why", "parameter", "value"}
UNIT = re.compile(r"\[[^\]]+\]")
NUMBER = re.compile(r"^-?\d+(\.\d+)?$")  # a matrix's axis values (transitions: the target speeds)


def run(args: list[str], columns: int, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, "COLUMNS": str(columns)})


def headers(out: str) -> list[str]:
    """Every table's column headers, the lines of a wrapped header joined: the rows between a
    table's top rule (┏) and its header rule (┡), split at the column rules (┃)."""
    found: list[str] = []
    block: list[list[str]] | None = None
    for line in out.splitlines():
        if line.startswith("┏"):
            block = []
        elif line.startswith("┡") and block is not None:
            found += [" ".join(w for w in words if w) for words in zip(*block, strict=True)]
            block = None
        elif block is not None and line.startswith("┃"):
            block.append([c.strip() for c in line.split("┃")[1:-1]])
    return found


def problems(out: str, width: int) -> list[str]:
    """What makes an output not fit: lines wider than ``width``, cut cells, headers with no unit."""
    wide = [f"{len(x)} columns: {x}" for x in out.splitlines() if len(x) > width]
    cut = [f"cut: {x}" for x in out.splitlines() if "…" in x]
    unitless = [f"no unit: {h!r}" for h in headers(out)
                if not UNIT.search(h) and h not in UNITLESS and not NUMBER.match(h)]
    return wide + cut + unitless


def test_the_checks_catch_what_rich_cuts_and_headers_without_units():
    """Negative control: the old entry table of ``info`` (13 columns, the units missing from "off
    label" and "defect"), as rich lays it out by itself, is flagged at 80 columns for its cut cells
    and at 200 for exactly those two headers; the same rows through :func:`fitted_tables` pass."""
    old = ("entry", "v [m/s]", "strides", "success", "status", "iter", "knots", "duration [s]", "solve [s]",
           "momentum [m/s]", "off label", "Coulomb margin [N]", "defect")
    row = ["v0.80-1.00_s1", "1.00", "1", "True", "Solve_Succeeded", "44", "51", "1.50", "7.18", "0.991", "-0.90%",
           "1.887", "4.4e-05"]
    t = Table(title="2 entries")
    for h in old:
        t.add_column(escape(h), justify="right")
    t.add_row(*row)
    found = problems(_render([t], 80), 80)
    assert any(p.startswith("cut:") for p in found), found
    assert problems(_render([t], 200), 200) == ["no unit: 'off label'", "no unit: 'defect'"]
    fixed = (*old[:10], "off label [%]", old[11], "defect [SI]")
    assert problems(_render(fitted_tables("2 entries", fixed, [row], 80), 80), 80) == []


def _render(tables: list[Table], width: int) -> str:
    c = Console(width=width, file=io.StringIO(), color_system=None)
    for t in tables:
        c.print(t)
    return c.file.getvalue()  # type: ignore[attr-defined]


WORD = st.text(alphabet="abcdefghij0123456789.-_/", min_size=1, max_size=12)
CELL = st.lists(WORD, min_size=1, max_size=3).map(" ".join)


@settings(max_examples=60, deadline=None)
@given(n=st.integers(2, 12), width=st.integers(40, 200), data=st.data())
def test_fitted_tables_cut_no_cell_at_any_width(n, width, data):
    """Any table (2 to 12 columns, cells of words up to 12 characters, a key up to 16) at any width
    from 40 to 200 prints no line wider than the console and no "…", and every word of every cell
    is shown whole (the rendering searched for it); the first column is in every part."""
    heads = [f"h{i} [u]" for i in range(n)]
    rows = [[data.draw(st.text(alphabet="abcv0123456789._-", min_size=1, max_size=16))]
            + [data.draw(CELL) for _ in range(n - 1)] for _ in range(data.draw(st.integers(1, 4)))]
    tables = fitted_tables("t", heads, rows, width)
    out = _render(tables, width)
    assert all(len(x) <= width for x in out.splitlines()) and "…" not in out, out
    shown = set(re.findall(r"[^\s│┃]+", out))
    for r in rows:
        assert r[0] in shown and all(w in shown for c in r[1:] for w in c.split()), (r, out)
    assert all(t.columns[0].header == "h0 \\[u]" for t in tables)


@pytest.mark.parametrize("library", [REFERENCE, SIDESLIP])
def test_info_fits_100_columns(library):
    """``skatelib info`` at 100 columns: no line wider, no cut cell, units in the headers; the
    summary shows the counts ``--json`` holds (entries, kinds, solved)."""
    r = run(["info", str(library)], 100, timeout=120)
    assert r.returncode == 0, r.stderr
    assert problems(r.stdout, 100) == [], r.stdout
    doc = json.loads(run(["info", str(library), "--json"], 80, timeout=120).stdout)
    entries = doc["entries"]
    kinds: dict[str, int] = {}
    for e in entries:  # the moves from each entry's speeds, as this test names them
        v0, v = e["from_velocity_mps"], e["target_velocity_mps"]
        kind = "stop" if v == 0 else "start-up" if v0 == 0 else "speed-up" if v > v0 else "slow-down"
        kinds[kind] = kinds.get(kind, 0) + 1
    assert doc["summary"]["kinds"] == kinds and doc["summary"]["solved"] == sum(e["success"] for e in entries)
    assert f"{len(entries)} entries: " in r.stdout and f"{doc['summary']['solved']} solved" in r.stdout
    assert all(e["key"] in r.stdout for e in entries)
    assert "robot_mass_kg" not in r.stdout  # the model is --wide's
    wide = run(["info", str(library), "--wide"], 100, timeout=120)
    assert "robot_mass_kg" in wide.stdout and problems(wide.stdout, 100) == [], wide.stdout


@pytest.fixture(scope="module")
def judged(tmp_path_factory):
    """A copy of the reference library with both closed-loop verdicts stored (``validate
    --closed-loop`` on the model plant and on the twin, the tables printed at 80 columns)."""
    pytest.importorskip("mujoco")
    path = tmp_path_factory.mktemp("judged") / "lib.h5"
    shutil.copyfile(REFERENCE, path)
    shown = []
    for plant in ("model", "mujoco"):
        r = run(["validate", str(path), "--closed-loop", "--plant", plant, "--perturb", "none", "-j", "2"], 80)
        assert "stored 2 closed-loop verdicts" in r.stdout, r.stdout + r.stderr
        shown.append(r.stdout)
    return path, shown


def test_validate_closed_loop_tables_fit_80_columns(judged):
    """The verdict tables of ``validate --closed-loop`` (the model plant's and the twin's, the same
    as ``track``'s) at 80 columns: nothing wider, nothing cut, units in every header."""
    _, shown = judged
    for out in shown:
        assert problems(out, 80) == [], out
        assert "v0.30_s1" in out and "v0.40_s1" in out


def test_info_shows_the_stored_verdicts_within_100_columns(judged):
    """With both verdicts stored the summary counts them (as many passes as ``--json`` holds) and
    the compact table gains a column each, still within 100 columns; ``--wide`` shows them whole."""
    path, _ = judged
    r = run(["info", str(path)], 100, timeout=120)
    assert problems(r.stdout, 100) == [], r.stdout
    doc = json.loads(run(["info", str(path), "--json"], 80, timeout=120).stdout)
    for name, where in (("closed_loop", "the model plant"), ("closed_loop_twin", "the twin")):
        passed = sum(e[name]["passed"] for e in doc["entries"])
        assert f"closed loop on {where}: {passed} of 2 stored verdicts pass" in r.stdout, r.stdout
    assert "closed loop" in headers(r.stdout) and "on twin" in headers(r.stdout)
    wide = run(["info", str(path), "--wide"], 80, timeout=120)
    assert problems(wide.stdout, 80) == [] and "closed loop on the twin" in wide.stdout, wide.stdout


@pytest.mark.parametrize("plant", ["model", "mujoco"])
def test_track_fits_80_columns(plant):
    """``COLUMNS=80 skatelib track`` (one entry, either plant): its table in parts of at most 80
    columns, every part with the entry, no cut cell, units in every header."""
    if plant == "mujoco":
        pytest.importorskip("mujoco")
    r = run(["track", str(REFERENCE), "-e", "v0.30_s1", "--plant", plant, "--perturb", "none", "--no-progress"], 80)
    assert r.returncode == 0, r.stdout + r.stderr
    assert problems(r.stdout, 80) == [], r.stdout
    parts = r.stdout.count("┏")
    assert parts >= 2 and r.stdout.count("v0.30_s1") >= parts  # too wide for one: parts, each with its entry


def test_humanoid_track_fits_80_columns(hrp2_walk_path):
    """``COLUMNS=80 skatelib track HUMANOID_LIB --plant mujoco``: nothing wider, nothing cut,
    units in every header."""
    pytest.importorskip("mujoco")
    r = run(["track", str(hrp2_walk_path), "--plant", "mujoco", "--perturb", "none", "--no-progress"], 80)
    assert r.returncode == 0, r.stdout + r.stderr
    assert problems(r.stdout, 80) == [], r.stdout
