"""The trunk's position and velocity, the board's speed and the accelerometer's bias: a linear
Kalman filter in the world frame on the attitude of :mod:`.attitude` (the Cheetah-style filter of
Bledt et al. 2018, "MIT Cheetah 3", Sec. IV, with Bloesch et al. 2013's leg-kinematics
measurement, "State estimation for legged robots: consistent fusion of leg kinematics and IMU"),
its stance-foot model changed for a rolling deck.

State s = (p, v, u, b_a): the trunk's position and velocity, the board's speed u along its
heading h, the accelerometer's bias. Prediction over dt with the IMU's specific force a_m:

    a = R (a_m - b_a) - g e_z,   p += v dt + a dt^2 / 2,   v += a dt,   u, b_a: random walks.

Measurements, per stance foot i (r_i, J_i its centre and linear Jacobian in the trunk frame,
omega_f its angular velocity, n the normal of its surface, rho the foot's radius; the contact point
of a rolling sphere moves with the surface under it):

    v + R (omega x r_i + J_i qd) - omega_f x (rho n) = 0                         (ground)
    ... = u h + omega_B x (c_i - a_B)                                            (deck)

(a_B on the deck's roll axis, which rides along h: a board's wheels neither slip sideways nor
leave the floor), and the centre's height: rho on the ground, on the deck the axis' height plus
the foothold's height about it, R_B (f_i + d e_z) . e_z. A foot whose velocity disagrees with its
surface's beyond the innovation's spread (``gate``: it has not landed yet, or it slips) is left out
of the tick.
The classical filter (``moving_deck=False``: every stance foot stays put) is the negative control.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

UP = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class OdometrySettings:
    """Noise densities and gates of the filter.

    Attributes:
        position_walk: The position's random walk [m/sqrt(s)] (what the heights correct).
        accel_noise: The specific force's white noise as the filter sees it (sensor noise and the
            trunk's vibrations) [m/s^2/sqrt(Hz)].
        board_accel: The board speed's random walk [m/s^2/sqrt(Hz)] (pushes, braking).
        bias_walk: The accelerometer bias' random walk [m/s^2/sqrt(s)].
        foot_velocity: A stance foot's kinematic velocity's noise [m/s] (joint velocities, the
            foot's rolling).
        foot_height: Its height's noise [m].
        gate: A stance foot whose velocity innovation has a squared Mahalanobis distance beyond
            this is left out (16: 0.1 % of consistent 3-vectors).
        moving_deck: A foot on the deck moves with it (False: every stance foot stays put).
    """

    position_walk: float = 0.003
    accel_noise: float = 0.03
    board_accel: float = 1.0
    bias_walk: float = 1e-3
    foot_velocity: float = 0.05
    foot_height: float = 0.003
    gate: float = 16.0
    moving_deck: bool = True


@dataclass
class FootMeasure:
    """One stance foot's rows: its velocity relation (``on_deck``: with the board's speed along
    ``heading``), the world velocity its surface has besides (``surface_v``), its kinematic velocity
    relative to the trunk's (``relative_v``: the contact point's, world), and its centre's height
    relation (``height_target``: what p_z + (R r_i)_z should be)."""

    on_deck: bool
    relative_v: np.ndarray
    surface_v: np.ndarray
    heading: np.ndarray
    centre_offset_z: float
    height_target: float


def _sym_outer(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a b^T + b a^T."""
    B = a[:, None] * b
    return B + B.T


class LegOdometry:
    """The filter of the module docstring (10 states). Its matrices are kept and filled in place:
    it runs at every whole-body tick."""

    N = 10

    def __init__(self, p0: np.ndarray, v0: np.ndarray, u0: float, settings: OdometrySettings | None = None,
                 bias_sd: float = 0.02):
        self.s = s = settings or OdometrySettings()
        self.x = np.concatenate([p0, v0, [u0], np.zeros(3)])
        self.P = np.diag([1e-6] * 3 + [1e-4] * 3 + [1e-4] + [bias_sd**2] * 3)
        self._F = np.eye(self.N)
        self.process_noise = np.array([s.position_walk**2] * 3 + [s.accel_noise**2] * 3 + [s.board_accel**2]
                           + [s.bias_walk**2] * 3)  # the process noise per second (diagonal)
        self._diag = np.diag_indices(self.N)
        self._foot_noise = s.foot_velocity**2 * np.eye(3)
        self._rows: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = {}

    @property
    def p(self) -> np.ndarray:
        return self.x[0:3]

    @property
    def v(self) -> np.ndarray:
        return self.x[3:6]

    @property
    def u(self) -> float:
        return float(self.x[6])

    def horizontal_bias_known(self, sd: float) -> None:
        """The accelerometer's bias along the trunk's x and y known to ``sd`` [m/s^2] (1 sigma): its
        uncertainty there set to it, before any update."""
        self.P[7:9, :] = 0.0
        self.P[:, 7:9] = 0.0
        self.P[7, 7] = self.P[8, 8] = sd * sd

    def predict(self, R: np.ndarray, accel: np.ndarray, dt: float, gravity: float) -> None:
        x, F = self.x, self._F
        a = R @ (accel - x[7:10])
        a[2] -= gravity
        x[0:3] += x[3:6] * dt + 0.5 * a * dt * dt
        x[3:6] += a * dt
        F[0, 3] = F[1, 4] = F[2, 5] = dt
        F[0:3, 7:10] = -0.5 * dt * dt * R
        F[3:6, 7:10] = -dt * R
        P = F @ self.P @ F.T
        P[self._diag] += self.process_noise * dt
        self.P = P

    def correct(self, feet: list[FootMeasure]) -> np.ndarray:
        """The stance feet's rows (those within the gate); returns which were used (bool, per item)."""
        if not feet:
            return np.zeros(0, dtype=bool)
        return self.correct_feet(np.array([f.on_deck for f in feet]), np.column_stack([f.relative_v for f in feet]),
                                 np.column_stack([f.surface_v for f in feet]), feet[0].heading,
                                 np.array([f.height_target - f.centre_offset_z for f in feet]))

    def _template(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The rows of ``k`` feet (3 velocity rows and a height row each, foot after foot): H without
        the board speed's column, the velocity rows' and the height rows' indices, the noise."""
        if k not in self._rows:
            s = self.s
            H = np.zeros((4 * k, self.N))
            vel = (4 * np.arange(k)[:, None] + np.arange(3)).ravel()
            height = 4 * np.arange(k) + 3
            H[vel, 3 + np.tile(np.arange(3), k)] = 1.0
            H[height, 2] = 1.0
            r = np.tile([s.foot_velocity**2] * 3 + [s.foot_height**2], k)
            self._rows[k] = (H, vel, height, r)
        return self._rows[k]

    def correct_feet(self, on_deck: np.ndarray, relative_v: np.ndarray, surface_v: np.ndarray, heading: np.ndarray,
                     height: np.ndarray) -> np.ndarray:
        """The rows of m stance feet: ``on_deck`` (m,), their contact points' velocities relative to
        the trunk's and their surfaces' (3, m, world), the board's heading, what the trunk's height
        p_z should be by each foot (m,). Returns which were used (within the gate)."""
        s, x, P = self.s, self.x, self.P
        d = on_deck.astype(float) if s.moving_deck else np.zeros(len(on_deck))
        target = surface_v - relative_v
        nu = target - x[3:6, None] + (d * x[6]) * heading[:, None]
        # Each foot's velocity innovation covariance G P G^T + sigma^2 I, G = [I, -d h] on (v, u).
        A = P[3:6, 3:6] + self._foot_noise
        S = A[None] if not d.any() else (A - d[:, None, None] * _sym_outer(heading, P[3:6, 6])
                                         + (d * d * P[6, 6])[:, None, None] * (heading[:, None] * heading))
        nu_t = nu.T
        maha = (nu_t * np.linalg.solve(S, nu_t[:, :, None])[:, :, 0]).sum(axis=1)
        used = ~(maha > s.gate)
        k = int(used.sum())
        if k:
            H0, vel, rows_h, r = self._template(k)
            H = H0.copy()
            H[vel, 6] = (-d[used][:, None] * heading).ravel()
            z = np.empty(4 * k)
            z[vel] = target[:, used].T.ravel()
            z[rows_h] = height[used]
            HP = H @ P
            K = np.linalg.solve(HP @ H.T + np.diag(r), HP).T
            self.x = x + K @ (z - H @ x)
            self.P = P - K @ HP
        return used
