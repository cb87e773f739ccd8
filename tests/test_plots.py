"""`skatelib plot`: the figures are written from the file, the plotted forces are the library's,
and bad input is refused with the file named."""

from __future__ import annotations

import json
import os
import subprocess

import numpy as np
import pytest

pytest.importorskip("matplotlib")
from skatelib.library.errors import SkatelibError
from skatelib.pipeline.quadruped.plots import push_foot_forces
from skatelib.pipeline.views.figures import write_figures
from skatelib.runtime import MotionLibrary

from tests.helpers import CLI


@pytest.fixture(scope="module")
def lib_path(tiny_build):
    return tiny_build.path


def test_plot_writes_every_figure(lib_path, tmp_path):
    """PNG and SVG of the speeds, deck roll and push forces; the frontier from a frontier file."""
    frontier = tmp_path / "f.json"
    frontier.write_text(json.dumps({"search": {}, "points": [
        {"n_strides": 1, "fastest_mps": 0.4, "first_failure_mps": 0.45, "limit": "",
         "probes": [{"velocity_mps": 0.4, "ok": True}, {"velocity_mps": 0.45, "ok": False}]}]}))
    r = subprocess.run([*CLI, "plot", str(lib_path), "-o", str(tmp_path / "figs"), "--frontier", str(frontier)],
                       capture_output=True, text=True, env={**os.environ, "COLUMNS": "200"})
    assert r.returncode == 0, r.stdout + r.stderr
    for stem in ("speeds", "deck_roll", "push_forces", "frontier"):
        png = (tmp_path / "figs" / f"{stem}.png").read_bytes()
        assert png.startswith(b"\x89PNG") and len(png) > 10_000
        assert (tmp_path / "figs" / f"{stem}.svg").read_text().lstrip().startswith("<?xml")
    assert not list((tmp_path / "figs").glob(".skatelib-tmp.*"))  # written atomically


def test_push_forces_are_the_ground_foot_forces(lib_path):
    """The plotted |f_t| and mu f_n are those of the foot on the ground, from the stored controls,
    NaN while no foot is on the ground; a push foot whose force is doctored outside the cone shows."""
    lib = MotionLibrary.open(lib_path)
    e = lib["v0.30_s1"]
    mu = float(lib.model["friction_mu"])
    t, ft, limit = push_foot_forces(e, mu)
    assert e.contact is not None
    on = (e.contact[:-1] == 2).any(axis=1)
    assert np.all(np.isnan(ft[~on])) and np.all(np.isfinite(ft[on])) and len(t) == len(e.t) - 1
    k = int(np.nonzero(on)[0][0])
    leg = int(np.nonzero(e.contact[k] == 2)[0][0])
    f = e.control[k, 3 * leg:3 * leg + 3]
    assert ft[k] == pytest.approx(np.hypot(f[0], f[1])) and limit[k] == pytest.approx(mu * f[2])
    assert np.all(ft[on] <= limit[on] + 1e-6)  # the library's pushes are inside Coulomb's cone

    class Doctored:  # the same entry with the first push's tangential force doubled
        contact = e.contact
        t = e.t
        control = e.control.copy()

    Doctored.control[k, 3 * leg:3 * leg + 2] *= 3.0
    _, ft2, limit2 = push_foot_forces(Doctored, mu)  # type: ignore[arg-type]
    assert ft2[k] > limit2[k]


@pytest.mark.parametrize(("text", "says"), [
    ("{}", "its 'points' are missing"), ("[1, 2]", "its 'points' are missing"),
    ('{"points": 3}', "its 'points' are missing"), ("not json", "not JSON"), (None, "cannot be read"),
])
def test_plot_refuses_a_bad_frontier_file(lib_path, tmp_path, text, says):
    """A file that is not a frontier: the option and the file named, what is wrong with it in words
    (not Python's), what to give instead; no figure written."""
    bad = tmp_path / "nope.json"
    if text is not None:
        bad.write_text(text)
    with pytest.raises(SkatelibError, match=rf"--frontier .*nope\.json: {says}.*skatelib frontier -o"):
        write_figures(lib_path, tmp_path / "figs", bad)
    assert not (tmp_path / "figs").exists()


def test_humanoid_figures_draw_the_library(hrp2_walk_path, tmp_path):
    """A humanoid library gets its own figures (through the kind table): COM speed and height, the
    top view whose COM line is the stored com_x, com_y and whose polygons are the stored plan's,
    and the planned against the whole body's multibody ZMP."""
    import matplotlib.pyplot as plt
    from skatelib.pipeline.humanoid.motion import stored_plan
    from skatelib.pipeline.humanoid.plots import plot_footprints

    path = hrp2_walk_path
    written = write_figures(path, tmp_path / "figs", None, ("png",))
    assert sorted(p.name for p in written) == ["com.png", "footprints.png", "zmp_wholebody.png"]
    assert all(p.read_bytes().startswith(b"\x89PNG") for p in written)
    lib = MotionLibrary.open(path)
    e = next(iter(lib))
    lines = plot_footprints(lib, plt).axes[0].get_lines()
    n_polygons = sum(len(spec.segments) for spec in stored_plan(lib, e))
    assert len(lines) == n_polygons + 2  # polygons, COM, ZMP
    com = lines[n_polygons]
    assert np.array_equal(com.get_xdata(), e.channel("com_x")) and np.array_equal(com.get_ydata(), e.channel("com_y"))
    with pytest.raises(SkatelibError, match="no reachable-speed frontier"):
        write_figures(path, tmp_path / "f2", tmp_path / "any.json")
    plt.close("all")
