"""``skatelib track --report OUT.html``: the plan against the closed loop per entry with its verdict;
the Coulomb margin it plots against a hand computation; paths and options it refuses before any run."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from skatelib.runtime import Entry

from tests.helpers import run_cli

REFERENCE = Path(__file__).parent / "data" / "tiny-reference.h5"


def _entry(forces: np.ndarray) -> Entry:
    """An entry of two knots whose one control row holds ``forces`` (4 feet x 3) and no joint rates."""
    from skatelib.library import schema

    control = np.hstack([forces.reshape(1, 12), np.zeros((1, 12))])
    arrays = {schema.D_T: np.array([0.0, 0.1]), schema.D_STATE: np.zeros((2, 28)), schema.D_CONTROL: control}
    return Entry("k", {schema.A_TARGET_VELOCITY: 0.5}, arrays, {})


def test_the_margin_is_the_worst_loaded_foots_cone():
    """mu f_n - |f_t| of the loaded feet, the smallest: a foot without load does not count; no loaded
    foot gives NaN. Taking the normal force from the wrong axis (the negative control) gives another
    figure."""
    from skatelib.pipeline.views.track_report import coulomb_margin

    f = np.array([[3.0, 4.0, 20.0], [0.0, 0.0, 30.0], [1.0, 0.0, 0.5], [0.0, 0.0, 0.0]])
    assert coulomb_margin(_entry(f), 0.5)[0] == pytest.approx(0.5 * 20.0 - 5.0)
    assert np.isnan(coulomb_margin(_entry(np.zeros((4, 3))), 0.5)[0])
    swapped = f[:, [2, 1, 0]]
    assert coulomb_margin(_entry(swapped), 0.5)[0] != pytest.approx(5.0)


def test_track_writes_a_report_with_each_entrys_figure_and_verdict(tmp_path):
    """The model plant's report: one section per entry with its figure (a PNG), its verdict and the
    pass count of the table; the command's exit code as without the report."""
    warnings.filterwarnings("ignore", message=".*format 1.5")
    out = tmp_path / "report.html"
    r = run_cli(["track", str(REFERENCE), "--perturb", "none", "--report", str(out), "--no-progress"])
    assert r.returncode in (0, 1) and f"wrote {out}" in " ".join(r.stdout.split()), r.stdout + r.stderr
    text = out.read_text()
    keys = re.findall(r"<h2 id='([^']+)'>", text)
    assert keys == ["v0.30_s1", "v0.40_s1"], keys
    assert text.count("data:image/png;base64,") == 2
    passed = text.count("color:green'>pass<")
    assert f"{passed} of 2 passed" in text and (passed == 2) == (r.returncode == 0)


def test_a_report_is_refused_where_it_would_show_nothing(tmp_path):
    """Not an .html path, or a ride or maneuver (a report shows entries' runs): exit 2 before any run,
    nothing written."""
    for extra in (["--report", str(tmp_path / "r.txt")],
                  ["--report", str(tmp_path / "r.html"), "--ride", "0:0.3"],
                  ["--report", str(tmp_path / "r.html"), "--maneuver", "steer"]):
        r = run_cli(["track", str(REFERENCE), *extra, "--no-progress"])
        assert r.returncode == 2 and "report" in r.stderr, (extra, r.stderr)
    assert not list(tmp_path.iterdir())
