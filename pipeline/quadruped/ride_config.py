"""How entries end and start riding: the riding end state every entry reaches (``[terminal]``) and
the transitions from riding at one speed to another (``[transitions]``), tables of
:class:`skatelib.pipeline.quadruped.config.QuadrupedConfig`."""

from __future__ import annotations

from dataclasses import dataclass

from skatelib.pipeline.config_tables import setting as _f


@dataclass(frozen=True)
class TerminalConfig:
    """The riding state every push-off ends in, from which three-leg transfer and balancing begin."""

    relative_speed_tol_mps: float = _f(1e-4, 0.5, "Largest lateral COM speed relative to the board at the end [m/s].",
                                       default=0.005)
    vertical_speed_tol_mps: float = _f(1e-4, 0.5, "Largest |vertical COM speed| at the end [m/s].", default=0.005)
    angular_speed_tol_radps: float = _f(1e-4, 1.0, "Largest |body angular velocity| per axis at the end [rad/s].",
                                    default=0.005)
    height_tol_m: float = _f(1e-4, 0.1, "Largest COM height error from the riding stance at the end [m].", default=0.01)
    attitude_tol_rad: float = _f(1e-4, 0.5, "Largest |body roll| and |pitch| at the end [rad].", default=0.03)
    joint_velocity_tol_radps: float = _f(1e-3, 10.0, "Largest |joint velocity| over the last interval [rad/s].",
                                         default=0.05)
    push_foot_height_m: float = _f(0.0, 0.2, "Push foot's lift-off clearance above the ground at the end [m].",
                                   default=0.02)
    position_tol_m: float = _f(1e-4, 1.0, "Largest |COM x, y over the deck - riding stance's| at the end [m].",
                               default=1.0)
    joint_tol_rad: float = _f(1e-3, 1.0, "Largest |joint angle - riding stance's| at the end (the push leg lifted "
                              "beside the deck): where a transition from riding starts [rad].", default=1.0)


@dataclass(frozen=True)
class TransitionsConfig:
    """Entries that start riding: speed-ups and slow-downs between the ``speeds_mps`` and a stop from
    each (an optional table; without ``speeds_mps`` the library holds start-ups only)."""

    speeds_mps: tuple[float, ...] = _f(0.05, 3.0, "Riding speeds: a speed-up or slow-down from each to each [m/s].",
                                       default=())
    stops: bool = _f(doc="A stop (to rest) from each of the speeds.", default=True)
    strides: tuple[int, ...] = _f(1, 20, "Stride counts tried in this order; a transition keeps the first that passes "
                                  "[-].", default=(1, 2, 3))
    touchdown_s: float = _f(0.03, 2.0, "From the riding start (push foot lifted) to its first touchdown [s].",
                            default=0.3)
    ground_sweep_m: float = _f(0.05, 0.6, "How far the trunk rides over a pushing foot: a ground phase lasts at most "
                               "this over the faster of the two speeds [m].", default=0.30)
    brake_sweep_m: float = _f(0.05, 0.6, "The same for a braking foot (it reaches forward, nearer the joints' limits) "
                              "[m].", default=0.26)
    brake_friction_margin: float = _f(0.3, 1.0, "A braking foot plans with this x mu (pushes: optimization."
                                      "friction_margin): the controller can brake harder where the board rolls "
                                      "easier than planned [-].", default=0.65)
    stop_speed_tol_mps: float = _f(1e-3, 0.2, "A stop ends with board and robot below this speed [m/s].",
                                   default=0.02)
    twin_judge: tuple[str, ...] = _f(doc="Model-error sets (skatelib track --perturb's, for the twin; 'none': the "
                                     "board as it is) under each of which a transition that passes the physics "
                                     "checks is ridden on the MuJoCo twin; a stride count it fails is not kept (the "
                                     "next is tried). Empty: the physics checks alone.", default=())
    twin_speed_share: float = _f(0.1, 1.0, "The share of the twin verdict's speed tolerance (5 % of the label; a "
                                 "stop 0.05 m/s) a judged transition may use: the judge rides each error set once, "
                                 "and a candidate that uses more passes on one draw of the closed loop [-].",
                                 default=0.8)

    def pairs(self) -> list[tuple[float, float]]:
        """(from, to) of every transition: each speed to each other, then to rest when ``stops``."""
        v = sorted(self.speeds_mps)
        out = [(a, b) for a in v for b in v if a != b]
        return out + ([(a, 0.0) for a in v] if self.stops else [])
