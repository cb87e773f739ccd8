"""The estimator's compiled tick (``skatelib.control.estimator.native``): its legs' kinematics
against pinocchio's at random joint angles. Its whole tick against the Python tick on a ride on
the twin is in ``tests/test_twin_estimate.py`` (``test_the_compiled_tick_is_the_python_tick``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pinocchio")

import pinocchio as pin
from skatelib.control.estimator import loads, native
from skatelib.control.estimator.legs import leg_terms
from skatelib.control.estimator.native import CompiledTick, leg_chains, static_loads, tick_library
from skatelib.control.kinematics import LegKinematics
from skatelib.library import compiled, trust
from skatelib.pipeline.config import load_config


@pytest.fixture(scope="module")
def kin() -> LegKinematics:
    cfg = load_config()
    model = pin.buildModelFromUrdf(str(cfg.urdf_path))
    joints = [model.getJointId(n) for n in cfg.robot.joint_names]
    return LegKinematics(model=model, data=model.createData(),
                         q_index=np.array([model.joints[j].idx_q for j in joints]),
                         v_index=np.array([model.joints[j].idx_v for j in joints]),
                         feet=tuple(model.getFrameId(f) for f in cfg.robot.foot_frames),
                         foot_radius_m=0.02, torque_limit_Nm=0.0, lower_rad=model.lowerPositionLimit,
                         upper_rad=model.upperPositionLimit)


def test_the_compiled_legs_are_pinocchios(kin):
    """Foot centres and their linear and angular Jacobians (trunk frame) at 50 random joint
    angles, within +-1.5 rad of zero on every joint: the C code's composition of the model's
    joint placements and axes equals pinocchio's to 1e-12."""
    lib = tick_library()
    if lib is None:
        pytest.skip("no C compiler: the estimator runs its Python tick")
    chains = leg_chains(kin)
    assert chains is not None
    tick = CompiledTick(lib, chains)
    rng = np.random.default_rng(0)
    for _ in range(50):
        q = rng.uniform(-1.5, 1.5, 12)
        ref = leg_terms(kin, q)
        r, J, Jw = tick.legs(q)
        assert np.allclose(r, ref.r, atol=1e-12, rtol=0)
        assert np.allclose(J, ref.J, atol=1e-12, rtol=0)
        assert np.allclose(Jw, ref.Jw, atol=1e-12, rtol=0)


def test_the_compiled_legs_fail_on_a_changed_model(kin):
    """Negative control: the chains read from the model with one hip's placement moved by 1 cm
    put that leg's foot 1 cm off pinocchio's, the other legs' feet where pinocchio has them."""
    lib = tick_library()
    if lib is None:
        pytest.skip("no C compiler")
    chains = leg_chains(kin)
    assert chains is not None
    joint_p = chains[1].copy()
    joint_p[0, 1, 0] += 0.01
    tick = CompiledTick(lib, (chains[0], joint_p, *chains[2:]))
    q = np.full(12, 0.3)
    r, _, _ = tick.legs(q)
    gap = np.linalg.norm(r - leg_terms(kin, q).r, axis=0)
    assert gap[0] == pytest.approx(0.01, abs=1e-9)
    assert np.all(gap[1:] < 1e-12)


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_the_compiled_static_loads_are_least_squares(n):
    """The feet's static loads (the minimum-norm loads that carry the weight with no moment about
    the centre of mass, clipped at zero) from the C code equal numpy's least squares
    (``loads.static_loads``) for 1-4 feet at 200 random places, three or four of them in a line
    among them (the rank-deficient case)."""
    lib = tick_library()
    if lib is None:
        pytest.skip("no C compiler")
    rng = np.random.default_rng(n)
    for k in range(200):
        feet = rng.uniform(-0.2, 0.2, (2, n))
        if k % 4 == 0 and n >= 3:  # in a line
            feet[1] = 0.3 * feet[0] + 0.05
        com = rng.uniform(-0.05, 0.05, 2)
        ref = loads.static_loads(feet, com, 87.0)
        assert np.allclose(static_loads(lib, feet, com, 87.0), ref, atol=1e-9, rtol=0), (feet, com, ref)


def test_a_compiler_that_fails_leaves_the_python_tick(monkeypatch, tmp_path):
    """A C compiler that fails (``$CC`` set to ``false``), with an empty cache: no compiled tick,
    and a warning that names the compiler's failure and says the Python tick runs."""
    monkeypatch.setattr(native, "_LIB", [])
    monkeypatch.setenv("CC", "false")
    monkeypatch.setenv(trust.CACHE_ENV, str(tmp_path))
    monkeypatch.delenv(trust.COMPILE_ENV, raising=False)  # the native code in that cache folder
    with pytest.warns(RuntimeWarning, match=r"false failed on tick.c.*the Python tick runs"):
        assert native.tick_library() is None
    assert not list(tmp_path.rglob("*.so"))


def test_cc_with_its_own_arguments_and_one_not_on_the_path(monkeypatch, tmp_path):
    """``$CC`` is a command with arguments (``ccache gcc``-style: here ``false --anything``, which
    fails): the warning names the whole command; a ``$CC`` not on the PATH is named as such, not
    replaced by another compiler."""
    monkeypatch.setenv(trust.CACHE_ENV, str(tmp_path))
    monkeypatch.delenv(trust.COMPILE_ENV, raising=False)  # the native code in that cache folder
    monkeypatch.setattr(native, "_LIB", [])
    monkeypatch.setenv("CC", "false --anything")
    with pytest.warns(RuntimeWarning, match=r"false --anything failed on tick.c"):
        assert native.tick_library() is None
    monkeypatch.setattr(native, "_LIB", [])
    monkeypatch.setenv("CC", "no-such-compiler-here")
    with pytest.warns(RuntimeWarning, match=r"\$CC='no-such-compiler-here' is not on the PATH"):
        assert native.tick_library() is None


def _cached_tick(folder) -> list:
    return sorted(p for p in (folder / "native").glob("estimator_tick_*.so"))


def test_the_cached_tick_is_checked_and_loaded_from_a_private_copy(monkeypatch, tmp_path):
    """The compiled tick follows the rules of the build's compiled code: built with its SHA-256
    recorded; a cached file whose bytes changed since, or a symlink in its place, is not loaded but
    compiled again (with a note saying why); what ctypes loads is a private copy of the bytes
    checked, not the cached path."""
    monkeypatch.setenv(trust.CACHE_ENV, str(tmp_path))
    monkeypatch.delenv(trust.COMPILE_ENV, raising=False)  # the native code in that cache folder
    monkeypatch.setattr(native, "_LIB", [])
    loaded: list[str] = []
    real_cdll = native.ctypes.CDLL
    monkeypatch.setattr(native.ctypes, "CDLL", lambda path: loaded.append(path) or real_cdll(path))
    assert native.tick_library() is not None
    (target,) = _cached_tick(tmp_path)
    assert trust.digest_record(target).read_text().strip() == trust.sha256_of(target)
    assert loaded[-1] != str(target) and not Path(loaded[-1]).exists()  # the private copy, removed
    assert compiled.usable_code(target)[0] == target.read_bytes()

    target.write_bytes(target.read_bytes() + b"\0")  # changed after it was built
    monkeypatch.setattr(native, "_LIB", [])
    with pytest.warns(trust.CacheNote, match="changed after it was built"):
        assert native.tick_library() is not None
    assert trust.digest_record(target).read_text().strip() == trust.sha256_of(target)  # compiled again

    elsewhere = tmp_path / "elsewhere.so"
    target.rename(elsewhere)
    target.symlink_to(elsewhere)
    monkeypatch.setattr(native, "_LIB", [])
    with pytest.warns(trust.CacheNote, match="symbolic link"):
        assert native.tick_library() is not None
    assert not target.is_symlink()


def test_a_cache_others_can_write_keeps_the_python_tick(monkeypatch, tmp_path):
    """A cache folder others can write is not used (whoever can write it could run code in the
    controller): the warning names the folder and what to do, the Python tick runs, nothing is
    compiled there. Negative control: the same folder made private again gives the compiled tick."""
    monkeypatch.setenv(trust.CACHE_ENV, str(tmp_path))
    monkeypatch.delenv(trust.COMPILE_ENV, raising=False)  # the native code in that cache folder
    (tmp_path / "native").mkdir(mode=0o700)
    (tmp_path / "native").chmod(0o777)
    monkeypatch.setattr(native, "_LIB", [])
    with pytest.warns(RuntimeWarning, match=r"native.*can be written by others.*compiled=False.*Python tick runs"):
        assert native.tick_library() is None
    assert not _cached_tick(tmp_path)
    (tmp_path / "native").chmod(0o700)
    monkeypatch.setattr(native, "_LIB", [])
    assert native.tick_library() is not None


def test_a_killed_processs_temporaries_in_the_native_folder_are_swept(monkeypatch, tmp_path):
    """A process killed while compiling or loading the tick leaves its temporary folder in
    ``native/``; the next process that loads the tick removes it (and keeps the user's look-alike)."""
    from tests.test_temporaries import _killed_writer, _leftovers

    monkeypatch.setenv(trust.CACHE_ENV, str(tmp_path))
    monkeypatch.delenv(trust.COMPILE_ENV, raising=False)  # the native code in that cache folder
    native_dir = tmp_path / "native"
    native_dir.mkdir(mode=0o700)
    pid = _killed_writer(native_dir)
    look_alike = native_dir / ".skatelib-tmp.notes"
    look_alike.write_text("the user's")
    assert _leftovers(native_dir, pid)
    monkeypatch.setattr(native, "_LIB", [])
    assert native.tick_library() is not None
    assert not _leftovers(native_dir, pid) and look_alike.read_text() == "the user's"
