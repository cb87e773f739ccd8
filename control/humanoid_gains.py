"""The humanoid balance stabilizer's figures (:class:`skatelib.control.humanoid_stabilizer.LipStabilizer`'s
gains, limits and switches), refused outside their ranges: a figure that divides at every tick, a
filter that never moves or a correction of the wrong sign would make its joint targets NaN or
silently wrong."""

from __future__ import annotations

from dataclasses import dataclass, fields

from skatelib.runtime.references import real

COM_MODES = ("velocity", "lip")
# The figures that divide (a damping, a time constant) or set a rate the tick needs (the DCM error's
# decay, the velocity filter's): above 0. The others scale or bound a correction (0 turns it off) or
# set a threshold: at least 0.
POSITIVE = frozenset({"dcm_gain_per_s", "velocity_cutoff_hz", "ankle_damping_Nms_per_rad", "ankle_return_s",
                      "swing_return_s"})


@dataclass(frozen=True)
class StabilizerGains:
    """The stabilizer's figures (chosen; docs/humanoid-twin.md says how they were found)."""

    dcm_gain_per_s: float = 3.0  # k: the desired ZMP's DCM feedback
    velocity_cutoff_hz: float = 15.0  # the COM velocity's low-pass filter
    offset_rate_per_s: float = 1.0  # the COM offset observer's rate
    polygon_margin_m: float = 0.01  # the desired ZMP this far inside the support polygon
    ankle_damping_Nms_per_rad: float = 400.0  # D
    ankle_return_s: float = 0.5  # T
    ankle_tilt_max_rad: float = 0.1
    com_shift_max_m: float = 0.08
    com_mode: str = "velocity"  # or "lip"
    com_velocity_gain_per_s: float = 2.0  # k_c
    landing_load_N: float = 50.0  # a swing sole this loaded near its touchdown has landed
    landing_window_m: float = 0.01  # near: the plan has it this low over its foothold
    swing_height_gain_per_s: float = 30.0  # a swing sole's height error (measured: encoders, IMU) integrated
    swing_return_s: float = 0.1  # a support sole's lift returns to the plan at this time constant
    landing: bool = True  # the landing detection (off: the clock alone says when a sole lands)
    enabled: bool = True
    compiled: bool = True  # the tick's arithmetic in C (humanoid_native) when a C compiler is there

    def __post_init__(self) -> None:
        """Refuse figures the tick cannot run on: a division by 0, a filter that never moves, a
        correction of the wrong sign, a mode that is not one (``"LIP"`` would run the velocity mode).

        Raises:
            ValueError: Naming the figure and its range (see :data:`POSITIVE`, :data:`COM_MODES`).
        """
        if self.com_mode not in COM_MODES:
            raise ValueError(f"StabilizerGains(com_mode={self.com_mode!r}): one of {', '.join(map(repr, COM_MODES))}")
        for f in fields(self):
            value, positive = getattr(self, f.name), f.name in POSITIVE
            if isinstance(f.default, bool) and not isinstance(value, bool):
                raise ValueError(f"StabilizerGains({f.name}={value!r}): True or False")
            if type(f.default) is float and not (real(value) and (value > 0 if positive else value >= 0)):
                raise ValueError(f"StabilizerGains({f.name}={value!r}): a finite number "
                                 f"{'above 0 (it divides or sets a rate)' if positive else 'of at least 0'}")
