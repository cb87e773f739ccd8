"""The twin's step and readout in C (``skatelib.sim.native``) against its Python path
(``TwinPlant(compiled=False)``): the same states to the bit, tick by tick, rolling on the deck under
the default model errors and fallen onto the floor; a changed rolling resistance is seen; without a
C compiler the Python path runs."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from skatelib.library import trust  # noqa: E402
from skatelib.pipeline.config import load_config  # noqa: E402
from skatelib.pipeline.quadruped.config import QuadrupedConfig  # noqa: E402
from skatelib.pipeline.twin import twin_figures  # noqa: E402
from skatelib.sim import native  # noqa: E402
from skatelib.sim.errors import parse_twin_perturbation  # noqa: E402
from skatelib.sim.humanoid.state import TRUTH_LAYOUT, truth_columns  # noqa: E402
from skatelib.sim.plant import TwinPlant, TwinState  # noqa: E402
from skatelib.sim.stand import StandController  # noqa: E402

pytestmark = pytest.mark.skipif(native.twin_library() is None, reason="no C compiler or no MuJoCo headers")
DEFAULT_ERRORS = "mass=+10%,kb=-20%,rolling=+100%,mu=0.5"


@pytest.fixture(scope="module")
def figures():
    return twin_figures(load_config(None, QuadrupedConfig))


def _pair(f, errors: str = DEFAULT_ERRORS) -> tuple[TwinPlant, TwinPlant]:
    e = parse_twin_perturbation(errors, f.friction_mu)
    return TwinPlant(f, e), TwinPlant(f, e, compiled=False)


def _stance(p: TwinPlant, trunk_dx: float = 0.0, trunk_z: float | None = None) -> None:
    """The plant in its stance keyframe, the trunk moved by ``trunk_dx`` (and to ``trunk_z``)."""
    key = p.m.key("stance")
    pos = key.qpos[p.trunk_q:p.trunk_q + 3].copy()
    pos[0] += trunk_dx
    if trunk_z is not None:
        pos[2] = trunk_z
    deck = key.qpos[p.deck_q:p.deck_q + 7]
    p.place(pos, key.qpos[p.trunk_q + 3:p.trunk_q + 7], key.qpos[p.qadr], np.array([deck[0], deck[1], 0.0]))


def _ride(plants: tuple[TwinPlant, ...], ticks: int, wobble_Nm: float = 0.4) -> list[list[TwinState]]:
    """Each plant under the same torques (a stance hold from the first plant's state, plus a wobble),
    two steps a tick; the states of every tick."""
    hold = StandController(plants[0].m, 8.9, 9.81)
    out: list[list[TwinState]] = [[] for _ in plants]
    for k in range(ticks):
        tau = hold(plants[0].d) + wobble_Nm * np.sin(0.05 * k + np.arange(12))
        for p, states in zip(plants, out, strict=True):
            p.step(tau, 2)
            states.append(p.state())
    return out


def _assert_same(a: TwinState, b: TwinState) -> None:
    for field in dataclasses.fields(TwinState):
        x, y = getattr(a, field.name), getattr(b, field.name)
        assert np.array_equal(x, y), (field.name, a.t, x, y)


def test_the_compiled_twin_is_the_python_twin_rolling_on_the_deck(figures):
    """Launched at 0.8 m/s and ridden 600 ticks (1.2 s) under the default model errors."""
    c, py = _pair(figures)
    assert c._native is not None and py._native is None
    for p in (c, py):
        _stance(p)
        p.launch(0.8)
    states = _ride((c, py), 600)
    for a, b in zip(*states, strict=True):
        _assert_same(a, b)
    end = states[0][-1]
    assert end.deck_v[0] > 0.5 and np.all(end.foot_touch == 1) and np.all(end.wheel_load_N > 0)


def test_the_compiled_twin_is_the_python_twin_fallen_on_the_floor(figures):
    """Dropped beside the board: feet, knees and trunk on the floor, read alike."""
    c, py = _pair(figures, "mu=0.5")
    for p in (c, py):
        _stance(p, trunk_dx=0.8, trunk_z=0.12)
    states = _ride((c, py), 300, wobble_Nm=2.0)
    for a, b in zip(*states, strict=True):
        _assert_same(a, b)
    assert any(s.floor_touches for s in states[0]) and any(np.any(s.foot_touch == 2) for s in states[0])


def test_a_changed_rolling_resistance_is_seen(figures):
    """The comparison sees a rolling coefficient 1 % off in the C plant's tables."""
    c, py = _pair(figures)
    c._native.tables.roll.coefficient *= 1.01
    for p in (c, py):
        _stance(p)
        p.launch(0.8)
    a, b = _ride((c, py), 200)
    assert not np.array_equal(a[-1].deck_v, b[-1].deck_v)


def test_without_a_compiler_the_python_twin_runs(figures, monkeypatch, tmp_path):
    compiled = TwinPlant(figures)
    monkeypatch.setattr(native, "_LIB", [])
    monkeypatch.setenv("CC", "false")
    monkeypatch.setenv(trust.CACHE_ENV, str(tmp_path))
    monkeypatch.delenv(trust.COMPILE_ENV, raising=False)
    with pytest.warns(RuntimeWarning, match=r"false failed on twin_tick.c.*Python path runs"):
        p = TwinPlant(figures)
    assert p._native is None and not list(tmp_path.rglob("*.so"))
    for plant in (p, compiled):
        _stance(plant)
    _assert_same(p.state(), compiled.state())


def _same_truth(a, b) -> bool:
    """Every field of two humanoid truths (or readings) equal (NaN to NaN)."""
    for field in dataclasses.fields(a):
        x, y = getattr(a, field.name), getattr(b, field.name)
        if isinstance(x, tuple) or x is None or y is None:
            if x != y if isinstance(x, tuple) else (x is None) != (y is None):
                return False
        elif not np.array_equal(x, y, equal_nan=True):
            return False
    return True


def _same_rows(a: np.ndarray, b: np.ndarray) -> bool:
    """Two truth rows equal in every field of the layout (NaN to NaN) and the joints' torques."""
    cols = (*TRUTH_LAYOUT, "torque")
    return all(np.array_equal(x, y, equal_nan=True) for x, y in zip(
        truth_columns(a[None], cols).values(), truth_columns(b[None], cols).values(), strict=True))


def test_the_humanoid_twins_steps_in_c_are_the_python_steps(hrp2_skate_v100):
    """The humanoid skate's twin under its default errors and a shove: the physics steps, the
    sensors and the ground truth in C (the shove, the board's rolling torques; the noisy readings;
    the soles' wrenches, ZMPs and velocities, the deck) give the Python path's states, readings and
    truths to the bit, tick by tick (the two plants draw the same noise); a shove 1 N stronger in
    the C plant is seen."""
    from skatelib.proving.humanoid.loop import figures_for
    from skatelib.runtime import MotionLibrary
    from skatelib.sim.humanoid.errors import DEFAULT_HUMANOID_PERTURBATION, parse_humanoid_perturbation
    from skatelib.sim.humanoid.plant import HumanoidPlant

    lib = MotionLibrary.open(hrp2_skate_v100)
    f = figures_for(lib, next(e.key for e in lib if e.success))
    errors = parse_humanoid_perturbation(f"{DEFAULT_HUMANOID_PERTURBATION},shove=40,shove_t=0.1")

    FIELDS = ("qpos", "qvel", "ctrl", "xfrc_applied")

    def run(c: HumanoidPlant, py: HumanoidPlant) -> tuple[bool, float]:
        same, gap = True, 0.0
        for k in range(150):
            target = f.q0_rad + 0.05 * np.sin(0.1 * k + np.arange(len(f.q0_rad)))
            for p in (c, py):
                p.step(target, 2)
            gap = max(gap, float(np.max(np.abs(c.d.qpos - py.d.qpos))))
            same &= all(np.array_equal(getattr(c.d, a), getattr(py.d, a)) for a in FIELDS)
            same &= _same_truth(c.truth(0.012), py.truth(0.012)) and _same_truth(c.readings(), py.readings())
            rows = (c.truth_row(0.012), py.truth_row(0.012))
            same &= _same_rows(*rows) and c.floor_touches(rows[0]) == py.floor_touches(rows[1])
            kept.append((rows[0], c.truth_of(rows[0])))
        return same, gap

    kept: list = []

    c, py = HumanoidPlant(f, errors), HumanoidPlant(f, errors, compiled=False)
    assert c._steps is not None and py._steps is None and c._truth is not None and c._sense is not None
    assert c.rolling is not None and errors.force_noise_N > 0
    assert run(c, py) == (True, 0.0)
    # a run's table of rows, by column, is its truths' fields stacked
    columns = truth_columns(np.array([r for r, _ in kept]), (*TRUTH_LAYOUT, "torque"))
    truths = [t for _, t in kept]
    assert all(np.array_equal(v, np.array([getattr(t, k) for t in truths]), equal_nan=True) for k, v in columns.items())
    assert columns["deck_R"].shape == (150, 3, 3) and columns["t"].shape == (150,)
    stronger = HumanoidPlant(f, dataclasses.replace(errors, shove_N=errors.shove_N + 1.0))
    same, gap = run(stronger, HumanoidPlant(f, errors, compiled=False))
    assert not same and gap > 0.0
