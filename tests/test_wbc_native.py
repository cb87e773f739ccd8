"""The whole-body tick's C code (``skatelib.control.wbc_native``) against its Python path: the
targets at random states (every contact code, attitude errors up to and at a half turn, where
pinocchio's log3 takes its other branch), the QP's arrays for every stance set with the joints in
channel order and permuted, and a ride on the twin tick by tick; with a negative control showing
the comparison sees a changed weight."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")
pytest.importorskip("mujoco")
pytest.importorskip("daqp")

from skatelib.control import wbc_native  # noqa: E402
from skatelib.control.body_plan import BodyTargets  # noqa: E402
from skatelib.control.feedback import RobotState  # noqa: E402
from skatelib.control.multibody import RobotDynamics  # noqa: E402
from skatelib.control.params import SkateParams  # noqa: E402
from skatelib.control.wbc import WholeBodyController  # noqa: E402
from skatelib.control.wbc_settings import NV, WbcSettings  # noqa: E402
from skatelib.control.wbc_targets import ContactTable, TargetMaker, WbcTargets  # noqa: E402
from skatelib.runtime import MotionLibrary  # noqa: E402

pytestmark = pytest.mark.skipif(wbc_native.wbc_library() is None, reason="no C compiler")
C_SETTINGS, PY_SETTINGS = WbcSettings(), WbcSettings(compiled=False)
TOL = 1e-12


def _close(a: np.ndarray, b: np.ndarray, tol: float = TOL) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and bool(np.max(np.abs(a - b), initial=0.0) <= tol * max(1.0, np.max(np.abs(b))))


def _same_targets(a: WbcTargets, b: WbcTargets, attitude_error: float = 0.0) -> list[str]:
    """The fields of two targets that differ beyond rounding: the attitude's, beyond rounding
    amplified by log3's condition at the trunk's ``attitude_error`` [rad] (theta / sin(theta), which
    grows without bound toward a half turn; within 1e-4 rad of it, 1e-6)."""
    condition = 1.0 / np.sinc(attitude_error / np.pi) if attitude_error < np.pi - 1e-4 else 1e6
    tol = {"angular_acc": TOL * max(condition, 1.0)}
    return [f.name for f in dataclasses.fields(a)
            if not _close(getattr(a, f.name), getattr(b, f.name), tol.get(f.name, TOL))]


def _attitude_error(st: RobotState, bt: BodyTargets) -> float:
    """The angle between the plan's trunk attitude (its yaw on the deck's) and the trunk's [rad]."""
    plan_R = pin.rpy.rpyToMatrix(bt.rpy[0], bt.rpy[1], bt.rpy[2] + st.deck_yaw)
    return float(np.linalg.norm(pin.log3(plan_R @ st.trunk_R.T)))


@pytest.fixture(scope="module")
def robot(tiny_v04):
    lib = MotionLibrary.open(tiny_v04.path)
    return lib, RobotDynamics.from_library(lib), SkateParams.from_library(lib)


class _RandomPlan:
    """A plan whose targets are drawn anew at every call (the same draws for two makers)."""

    def __init__(self, seed: int):
        self.rng = np.random.default_rng(seed)

    def at(self, tau: float) -> BodyTargets:
        r = self.rng
        return BodyTargets(com=r.normal(size=3), com_v=r.normal(size=3), rpy=r.uniform(-np.pi, np.pi, 3),
                           omega=r.normal(size=3), feet=r.normal(size=(3, 4)), feet_v=r.normal(size=(3, 4)),
                           feet_a=r.normal(size=(3, 4)), q=r.normal(size=12), board_v=r.normal(size=3))


def _rotation(rng: np.random.Generator) -> np.ndarray:
    quat = rng.normal(size=4)
    return np.asarray(pin.Quaternion(*(quat / np.linalg.norm(quat))).matrix())


def _random_state(rng: np.random.Generator, dyn: RobotDynamics) -> tuple[RobotState, object, np.ndarray]:
    st = RobotState(trunk_pos=rng.normal(size=3), trunk_R=_rotation(rng), trunk_v=rng.normal(size=3),
                    trunk_omega=rng.normal(size=3), q=rng.normal(size=12), qd=rng.normal(size=12),
                    deck_pos=rng.normal(size=3), deck_R=_rotation(rng), deck_v=rng.normal(size=3),
                    deck_omega=rng.normal(size=3), foot_touch=rng.integers(0, 3, 4).astype(np.int8),
                    contact_points=rng.normal(size=(3, 4)))
    qp, vp = dyn.configuration(st.trunk_pos, st.trunk_R, st.q, st.trunk_v, st.trunk_omega, st.qd)
    T = dyn.terms(qp, vp)
    return st, T, (T.J_feet @ vp).T


def test_the_c_targets_are_the_python_targets(robot):
    """At random states, with random contact codes (the table's rows drawn per tick) and plans, the
    stance set kept between ticks: the same targets; and where the trunk's attitude error is a half
    turn (log3's singular branch) or just short of it."""
    _, dyn, p = robot
    rng = np.random.default_rng(5)
    codes = rng.integers(0, 3, (400, 4))
    table = ContactTable(lambda t: codes[min(round(t / 0.002), len(codes) - 1)], 0.0, 0.7, 0.002)
    made = [TargetMaker(_RandomPlan(9), table, p, s) for s in (C_SETTINGS, PY_SETTINGS)]
    assert made[0]._native is not None and made[1]._native is None
    shadow = _RandomPlan(9)  # the plans' draws, again
    stances = set()
    for k in range(300):
        st, T, feet_v = _random_state(rng, dyn)
        forces = rng.normal(size=(3, 4))
        a, b = (m(0.002 * k, st, T, feet_v, forces) for m in made)
        error = _attitude_error(st, shadow.at(0.0))
        assert not _same_targets(a, b, error), (k, _same_targets(a, b, error))
        stances.add(tuple(b.stance))
    assert len(stances) >= 8  # the stance logic ran through most of its cases
    # Negative control: a C maker with another COM gain is seen to differ.
    other = TargetMaker(_RandomPlan(9), table, p, dataclasses.replace(C_SETTINGS, kp_com=101.0))
    python = TargetMaker(_RandomPlan(9), table, p, PY_SETTINGS)
    st, T, feet_v = _random_state(rng, dyn)
    assert _same_targets(other(0.0, st, T, feet_v, np.zeros((3, 4))), python(0.0, st, T, feet_v, np.zeros((3, 4)))) \
        == ["com_acc"]

    # A half turn between the plan's attitude and the trunk's, and nearly one.
    for angle in (np.pi, np.pi - 1e-9, np.pi - 1e-4):
        st, T, feet_v = _random_state(rng, dyn)
        plans = [_RandomPlan(3), _RandomPlan(3)]
        bt = _RandomPlan(3).at(0.0)
        plan_R = pin.rpy.rpyToMatrix(bt.rpy[0], bt.rpy[1], bt.rpy[2] + st.deck_yaw)
        axis = rng.normal(size=3)
        st.trunk_R = pin.exp3(angle * axis / np.linalg.norm(axis)).T @ plan_R
        made = [TargetMaker(plan, table, p, s) for plan, s in zip(plans, (C_SETTINGS, PY_SETTINGS), strict=True)]
        a, b = (m(0.0, st, T, feet_v, np.zeros((3, 4))) for m in made)
        assert not _same_targets(a, b, _attitude_error(st, bt)), angle


@pytest.mark.parametrize("permuted", [False, True])
def test_the_c_assembly_is_the_python_assembly(robot, permuted):
    """For every stance set, feet on the deck or the floor, at random states and targets: the same
    H, g, rows and bounds; with the joints' columns permuted too (a
    robot whose channel order is not pinocchio's). Negative control: a C assembly built with
    another swing weight differs."""
    _, dyn, _ = robot
    rng = np.random.default_rng(11)
    joints = np.arange(6, NV)
    if permuted:
        joints = 6 + rng.permutation(12)
    ctrls = [WholeBodyController(joints, 12.0, 0.6, s) for s in (C_SETTINGS, PY_SETTINGS)]
    other = WholeBodyController(joints, 12.0, 0.6, dataclasses.replace(C_SETTINGS, w_swing=2.0))
    assert ctrls[0]._native is not None and ctrls[1]._native is None
    for mask in range(16):
        stance = np.array([(mask >> i) & 1 for i in range(4)], dtype=bool)
        _, T, _ = _random_state(rng, dyn)
        tg = WbcTargets(stance=stance, on_deck=rng.random(4) < 0.5, deck_R=_rotation(rng),
                        stance_acc=rng.normal(size=(3, 4)), com_acc=rng.normal(size=3),
                        angular_acc=rng.normal(size=3), swing_acc=rng.normal(size=(3, 4)),
                        forces=rng.normal(size=(3, 4)), posture_acc=rng.normal(size=12))
        a, b = (c.problem(T, tg) for c in ctrls)
        for name in ("H", "g", "A", "lower", "upper"):
            assert _close(getattr(a, name), getattr(b, name)), (mask, name)
        assert np.array_equal(a.equality, b.equality)
        if 0 < mask < 15:  # a swinging foot: its weight enters H
            assert not _close(other.problem(T, tg).H, b.H)


def test_a_ride_ticks_the_same_either_way(robot):
    """The tiny library's entry ridden on the twin: at every tick the C targets and the C assembly
    equal the Python ones on the same sensed state (stance sets of three and four feet met)."""
    from skatelib.proving.setup import ClosedLoop
    from skatelib.proving.twin.loop import TwinLoop
    from skatelib.sim.figures import TwinFigures
    from skatelib.sim.plant import TwinPlant

    lib, _, p = robot
    loop = TwinLoop(lib, lib.keys()[0], ClosedLoop(p, p), TwinPlant(TwinFigures.from_library(lib)))
    ctrl = loop.ctrl
    assert ctrl.targets._native is not None and ctrl.wbc._native is not None
    python = TargetMaker(ctrl.targets.plan, ctrl.contacts, ctrl.targets.p, PY_SETTINGS)
    python_wbc = WholeBodyController(ctrl.dyn.v_index, ctrl.kin.torque_limit_Nm, p.mu_plan, PY_SETTINGS)
    compiled = ctrl.targets
    sizes, worst = set(), 0.0

    def both(t, st, T, feet_v, forces):
        nonlocal worst
        python.stance = compiled.stance.copy()
        a, b = compiled(t, st, T, feet_v, forces), python(t, st, T, feet_v, forces)
        assert not _same_targets(a, b), (t, _same_targets(a, b))
        qa, qb = python_wbc.problem(T, a), ctrl.wbc.problem(T, a)
        for name in ("H", "g", "A", "lower", "upper"):
            assert _close(getattr(qa, name), getattr(qb, name)), (t, name)
        sizes.add(int(a.stance.sum()))
        worst = max(worst, float(np.max(np.abs(python_wbc.solve(T, a).tau - ctrl.wbc.solve(T, a).tau))))
        return a

    ctrl.targets = both  # type: ignore[assignment]
    run = loop.ride()
    assert not run.fall and {3, 4} <= sizes
    assert worst < 1e-9


def test_a_cache_others_can_write_keeps_the_python_path(monkeypatch, tmp_path):
    """The whole-body tick's C code is kept under the rules of the controller's compiled code: in a
    cache folder others can write it is neither compiled nor loaded, a warning names the folder and
    what to do, and the controller runs its Python path. Negative control: the folder made private
    again gives the C code."""
    from skatelib.library import trust

    monkeypatch.setenv(trust.CACHE_ENV, str(tmp_path))
    monkeypatch.delenv(trust.COMPILE_ENV, raising=False)  # the native code in that cache folder
    (tmp_path / "native").mkdir(mode=0o700)
    (tmp_path / "native").chmod(0o777)
    monkeypatch.setattr(wbc_native, "_LIB", [])
    with pytest.warns(RuntimeWarning, match=r"native.*can be written by others.*compiled=False.*Python path runs"):
        assert WholeBodyController(np.arange(6, NV), 12.0, 0.6, C_SETTINGS)._native is None
    assert not list((tmp_path / "native").glob("wbc_tick_*.so"))
    (tmp_path / "native").chmod(0o700)
    monkeypatch.setattr(wbc_native, "_LIB", [])
    assert WholeBodyController(np.arange(6, NV), 12.0, 0.6, C_SETTINGS)._native is not None
    assert len(list((tmp_path / "native").glob("wbc_tick_*.so"))) == 1

