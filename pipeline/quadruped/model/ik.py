"""Numeric inverse kinematics: damped Newton steps toward a foot target, and CasADi functions
evaluated on NumPy arrays with little overhead (a cold guess's inverse kinematics evaluates the leg's
kinematics some 1,200 times)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np


class Evaluated:
    """A CasADi function of one vector, with dense outputs, evaluated on NumPy arrays through its
    buffer: about 2 us a call where ``Function.__call__`` and the DM conversions take some 27 us,
    the same values to the bit (the same function evaluates them). Each call returns new arrays."""

    def __init__(self, fn: ca.Function):
        if fn.n_in() != 1 or not all(fn.sparsity_out(i).is_dense() for i in range(fn.n_out())):
            raise ValueError(f"{fn.name()}: one input and dense outputs wanted (ca.densify them)")
        self._arg = np.zeros(fn.nnz_in(0))
        self._res = [np.zeros(fn.nnz_out(i)) for i in range(fn.n_out())]
        self._shapes = [fn.size_out(i) for i in range(fn.n_out())]
        self._buffer, self._eval = fn.buffer()
        # CasADi's stubs name a size argument that its binding does not take (it reads the buffer's)
        self._buffer.set_arg(0, self._arg.data)  # type: ignore[call-arg]
        for i, res in enumerate(self._res):
            self._buffer.set_res(i, res.data)  # type: ignore[call-arg]

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, ...]:
        self._arg[:] = np.asarray(x, dtype=float).reshape(-1)
        self._eval()
        return tuple(r.reshape(shape, order="F").copy() for r, shape in zip(self._res, self._shapes, strict=True))


@dataclass(frozen=True)
class DampedNewton:
    """Damped (Levenberg-Marquardt) Newton steps on joint angles toward a foot target.

    A step is kept only when it brings the foot closer; otherwise the damping grows tenfold and
    the step is tried again shorter (and it shrinks back after a kept step). Toward a target out of
    reach, or one behind a joint limit, the plain clipped Newton step overshoots and bounces
    between the limit and the far side without settling, so its last iterate (and a cold initial
    guess built from it) followed the last bits of the 3 x 3 solves, which differ between BLAS
    kernels; the kept steps settle at the nearest reachable point instead.
    """

    damping: float  # the smallest damping, used while steps are kept [m^2]
    tol: float  # residual norm at which to stop [m]
    max_iter: int  # evaluations of ``fn`` after the first

    def solve(self, fn: Any, goal: np.ndarray, q0: np.ndarray,
              limits: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, float]:
        """Steps toward ``fn(q)[0] == goal``, where ``fn(q) -> (p, dp/dq)``, each clipped to ``limits``
        when given. Returns the joints and their residual norm [m] (the smallest reached)."""
        q = np.array(q0, dtype=float)
        goal = np.asarray(goal, dtype=float).reshape(-1)
        pos, J = (np.asarray(v) for v in fn(q))
        err = goal - pos.reshape(-1)
        residual = float(np.linalg.norm(err))
        damping = self.damping
        for _ in range(self.max_iter):
            if residual < self.tol:
                break
            trial = q + self._step(q, J, err, damping, limits)
            if limits is not None:
                trial = np.clip(trial, *limits)
            pos_t, J_t = (np.asarray(v) for v in fn(trial))
            err_t = goal - pos_t.reshape(-1)
            residual_t = float(np.linalg.norm(err_t))
            if residual_t < residual:
                q, J, err, residual = trial, J_t, err_t, residual_t
                damping = max(damping / 10.0, self.damping)
            else:
                damping *= 10.0
        return q, residual

    @staticmethod
    def _step(q: np.ndarray, J: np.ndarray, err: np.ndarray, damping: float,
              limits: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray:
        """The damped Newton step on the joints not held at a limit they would leave outwards
        (the others stay put: a step through the limit, clipped, is no Newton step)."""
        free = np.ones(len(q), dtype=bool)
        if limits is not None:
            descent = J.T @ err
            free = ~(((q <= limits[0]) & (descent < 0)) | ((q >= limits[1]) & (descent > 0)))
        step = np.zeros(len(q))
        if not free.any():
            return step
        Jf = J[:, free]
        step[free] = np.linalg.solve(Jf.T @ Jf + damping * np.eye(int(free.sum())), Jf.T @ err)
        return step
