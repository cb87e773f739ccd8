"""``skatelib track --report OUT.html``: the plan against the closed loop per entry with its verdict;
the Coulomb margin it plots against a hand computation, each in its own cone (the plan's planning
mu, the closed loop's the plant's); paths and options it refuses before any run."""

from __future__ import annotations

import re
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from skatelib.runtime import Entry

from tests.helpers import run_cli

REFERENCE = Path(__file__).parent / "data" / "tiny-reference.h5"


def _entry(forces: np.ndarray, deck_roll_rad: float = 0.0, contact: np.ndarray | None = None) -> Entry:
    """An entry of two knots whose one control row holds ``forces`` (4 feet x 3) and no joint rates,
    the deck rolled by ``deck_roll_rad`` at heading 0, the feet's ``contact`` codes if given."""
    from skatelib.library import schema
    from skatelib.library.channels import CONTROL_NAMES, I_BOARD_ROLL, STATE_NAMES

    control = np.hstack([forces.reshape(1, 12), np.zeros((1, 12))])
    state = np.zeros((2, 28))
    state[:, I_BOARD_ROLL] = deck_roll_rad
    arrays = {schema.D_T: np.array([0.0, 0.1]), schema.D_STATE: state, schema.D_CONTROL: control,
              schema.D_BOARD_POS: np.zeros((2, 4))}
    if contact is not None:
        arrays[schema.D_CONTACT] = np.tile(contact, (2, 1))
    columns = {schema.D_STATE: STATE_NAMES, schema.D_CONTROL: CONTROL_NAMES}
    return Entry("k", {schema.A_TARGET_VELOCITY: 0.5}, arrays, columns)


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


def test_the_margin_is_taken_about_the_surface_under_each_foot():
    """On a deck rolled 0.2 rad, a foot pushing 10 N straight into it has the whole cone's margin
    (mu 10 N; about the vertical it would lose about 2 N of it), and one pushing 10 N straight down
    loses mu 10 N - 10 N sin 0.2 of it; a foot on the floor is taken about the vertical with the
    floor's mu."""
    from skatelib.library.channels import BOARD, GROUND, SWING
    from skatelib.pipeline.views.track_report import Cone, coulomb_margin

    roll, deck = 0.2, np.array([0, 1, 0, 0])
    into_deck = 10.0 * np.array([0.0, -np.sin(roll), np.cos(roll)])  # the deck's normal, R_x(roll) e_z
    one = np.zeros((4, 3))
    one[1] = into_deck
    rolled = _entry(one, roll, deck * BOARD)
    assert coulomb_margin(rolled, Cone(0.6, 0.3))[0] == pytest.approx(6.0)
    one[1] = [0.0, 0.0, 10.0]
    down = coulomb_margin(_entry(one, roll, deck * BOARD), 0.6)[0]
    assert down == pytest.approx(0.6 * 10.0 * np.cos(roll) - 10.0 * np.sin(roll))
    one[1] = [3.0, 0.0, 10.0]
    floor = np.array([SWING, GROUND, SWING, SWING])
    assert coulomb_margin(_entry(one, roll, floor), Cone(0.6, 0.5))[0] == pytest.approx(0.5 * 10.0 - 3.0)


def _verdict(**figures: Any) -> Any:
    """A model-plant verdict of zeros but ``figures``."""
    import dataclasses

    from skatelib.proving.verdict import TrackResult

    zeros = {f.name: 0 for f in dataclasses.fields(TrackResult)}
    return TrackResult(**{**zeros, "key": "v0.30_s1", "reasons": "", **figures})


def _mu(cone: Any) -> tuple[float, float]:
    """A cone's mu on the deck and on the floor."""
    return cone.deck, cone.floor


def test_each_margin_takes_its_own_cone():
    """The plan's margin in the planning cone (friction_mu_plan 0.45, not the model's 0.6); the
    closed loop's in the plant's: the model plant's mu after --perturb (0.5 for mu=0.5, 0.3 for mu=-50%,
    the library's 0.6 for none), the twin's deck keeping the library's 0.6 under a floor of 0.5 and
    taking a floor's 0.8 (MuJoCo's larger coefficient of the two)."""
    from skatelib.pipeline.views.track_report import Cone, plan_cone, plant_cone
    from skatelib.runtime import MotionLibrary

    lib = MotionLibrary.open(REFERENCE)
    assert lib.quadruped_model.friction_mu == pytest.approx(0.6)
    assert _mu(plan_cone(lib)) == pytest.approx((0.45, 0.45))
    model = _verdict()
    assert _mu(plant_cone(lib, model, "mass=-10%,kb=-20%,rolling=+100%,mu=0.5")) == pytest.approx((0.5, 0.5))
    assert plant_cone(lib, model, "mu=-50%").deck == pytest.approx(0.3)
    assert _mu(plant_cone(lib, model, "none")) == pytest.approx((0.6, 0.6))
    twin = object()  # not the model plant's verdict: the twin's
    assert _mu(plant_cone(lib, twin, "mass=+10%,mu=0.5")) == pytest.approx((0.6, 0.5))
    assert _mu(plant_cone(lib, twin, "mu=0.8")) == pytest.approx((0.8, 0.8))
    assert _mu(plant_cone(lib, twin, "kb=-20%")) == pytest.approx((0.6, 0.6))
    # a plain number is the key's unit on the twin too (a 9.37 kg robot): read as the rides read it
    assert _mu(plant_cone(lib, twin, "mass=9.37,mu=0.5")) == pytest.approx((0.6, 0.5))
    assert Cone(0.6, 0.5).label() == "mu 0.60 on the deck, 0.50 on the floor" and Cone(0.5, 0.5).label() == "mu 0.50"


def test_the_figure_draws_each_margin_in_its_cone_beside_the_verdicts():
    """The margin panel: the plan's curve in the plan's cone, the closed loop's in the plant's (by
    hand: 0.5 x 20 N - 5 N and 0.45 x 20 N - 5 N for the same forces), each labelled with its mu,
    and the verdict's smallest margin of a commanded force as a line of its own."""
    import matplotlib.pyplot as plt
    from skatelib.pipeline.views.track_report import Cone, Margins, figure

    f = np.array([[3.0, 4.0, 20.0], [0.0, 0.0, 30.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    e = _entry(f)
    fig = figure(e, e, Margins(Cone(0.45, 0.45), Cone(0.5, 0.5), -0.04), "k")
    lines = {line.get_label(): line.get_ydata() for line in fig.axes[3].get_lines()}
    plt.close(fig)
    assert lines["plan, mu 0.45"][0] == pytest.approx(0.45 * 20.0 - 5.0)
    assert lines["closed loop, mu 0.50"][0] == pytest.approx(0.5 * 20.0 - 5.0)
    (verdict,) = [y for label, y in lines.items() if label.startswith("verdict")]
    assert verdict[0] == pytest.approx(-0.04)


def test_the_reports_margin_is_the_plants(tmp_path):
    """With the plant's mu at 0.5 (the library's is 0.6, its planning mu 0.45), the report says the
    closed loop's margin is taken in mu 0.50 and the plan's in 0.45, and never names the model's 0.6."""
    warnings.filterwarnings("ignore", message=".*format 1.5")
    out = tmp_path / "report.html"
    r = run_cli(["track", str(REFERENCE), "-e", "v0.30_s1", "--perturb", "mu=0.5,kb=-20%", "--report", str(out),
                 "-j", "1", "--no-progress"])
    assert f"wrote {out}" in " ".join(r.stdout.split()), r.stdout + r.stderr
    text = " ".join(out.read_text().split())
    assert "the planning cone (mu 0.45)" in text and "the plant&#x27;s (mu 0.50)" in text, text[:2000]
    assert "0.6" not in text.split("<h2")[0], text[:2000]


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
