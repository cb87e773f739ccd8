"""The robot's state estimator (the paper's Sec. V-A): the trunk's attitude and angular velocity
from the IMU, its position and velocity by a Kalman filter fusing the IMU with leg kinematics
(a foot on the ground stays put, a foot on the deck moves with the deck), the deck's pose from
the feet on it, the board's speed and roll rate from their velocities."""
