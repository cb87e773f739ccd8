"""The estimator's written-out small algebra (``skatelib.control.estimator.vec3``) against numpy's
and scipy's general routines over random inputs."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pinocchio")

from skatelib.control.estimator.deck import plane_normal
from skatelib.control.estimator.vec3 import cross, exp_so3


def test_cross_is_numpys_cross():
    """Three-vectors and (3, n) columns, either side broadcasting: bit for bit np.cross."""
    rng = np.random.default_rng(1)
    for _ in range(200):
        a, b, B = rng.normal(size=3), rng.normal(size=3), rng.normal(size=(3, 4))
        assert np.array_equal(cross(a, b), np.cross(a, b))
        assert np.array_equal(cross(a, B), np.cross(a, B.T).T)
        assert np.array_equal(cross(B, a), np.cross(B.T, a).T)


def test_exp_so3_is_the_matrix_exponential():
    """Rodrigues' formula against scipy's matrix exponential of the skew matrix, small angles included."""
    expm = pytest.importorskip("scipy.linalg").expm
    rng = np.random.default_rng(2)
    for scale in (1e-12, 1e-5, 0.1, 3.0):
        for _ in range(50):
            w = scale * rng.normal(size=3)
            K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
            assert np.allclose(exp_so3(w), expm(K), atol=1e-14)


def test_three_points_plane_is_the_least_squares_plane():
    """Three points' normal by the cross product is the SVD's normal of the same points."""
    rng = np.random.default_rng(3)
    for _ in range(100):
        pts = rng.normal(size=(3, 3))
        n_svd = np.linalg.svd(pts - pts.mean(axis=1, keepdims=True))[0][:, 2]
        n_svd = n_svd if n_svd[2] > 0 else -n_svd
        assert np.allclose(plane_normal(pts), n_svd, atol=1e-10)
