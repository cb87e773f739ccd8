"""The closed-loop verdicts ``track`` and ``validate --closed-loop`` print: entries on the model
plant and on the twin, the estimator's errors, a chained ride's stages, the steering maneuver. Every
header carries its unit in brackets; the tables fit the console (:mod:`.fitted`)."""

from __future__ import annotations

from typing import Any

from rich.markup import escape
from skatelib.pipeline.views.console import console, label_error, print_failures
from skatelib.pipeline.views.fitted import Col, print_table

PASS, FAIL = "[green]pass[/]", "[red]FAIL[/]"


def verdict(passed: bool) -> str:
    return PASS if passed else FAIL


def track_table(results: list[Any], perturb: str) -> int:
    """Print the closed-loop verdicts; returns how many failed."""
    rows = [[escape(r.key), f"{r.target_velocity_mps:.2f}", f"{r.momentum_at_end_mps:.3f}",
             f"{r.speed_after_1s_mps:.3f}", f"{r.delivered_mps:.3f}",
             label_error(r.target_velocity_mps, r.delivered_mps), f"{r.max_deck_roll_rad:.3f}",
             f"{1e3 * r.max_position_error_m:.1f}", f"{r.max_attitude_error_rad:.3f}",
             f"{r.min_normal_N:.1f}", f"{r.min_friction_margin_N:.2f}", str(r.slips), f"{r.max_joint_torque_Nm:.1f}",
             f"{r.mpc_median_ms:.1f}/{r.mpc_max_ms:.1f}", verdict(r.passed)] for r in results]
    print_table(console, f"closed loop, plant: {perturb}",
                ("entry", "label [m/s]", "p/m end [m/s]", "v+1s [m/s]", "delivered [m/s]", "error [%]",
                 "roll max [rad]", "pos err [mm]", "att err [rad]", "min f_n [N]", "fric margin [N]", "slips [steps]",
                 "tau max [Nm]", "MPC med/max [ms]", "verdict"), rows,
                "p/m end: momentum speed (m_R v_R + m_B v_B) / (m_R + m_B) when the entry ends; v+1s: the board's "
                "speed 1 s later; delivered: the momentum speed 1 s later plus what rolling friction took meanwhile; "
                "error: delivered against the label (a stop's, label 0: see delivered); roll max: the deck's; pos "
                "err, att err: the trunk against the reference; min f_n: the smallest normal force of a stance foot; "
                "fric margin: the smallest mu f_n - |f_t| of a commanded foot force in the plant's cone (< 0: "
                "clipped, a slip); slips: plant steps with a foot force outside the cone; tau max: the largest "
                "stance-joint torque at the inverse-kinematics angles; MPC: the solve's median and largest time")
    return print_failures(results, lambda r: str(r.reasons))


def ride_table(result: Any, perturb: str) -> bool:
    """Print a ride's stages and its verdict; returns whether it passed."""
    def reached(s: Any) -> bool:  # the run got to the stage's end (a fall before leaves its speed NaN)
        return bool(s.momentum_at_end_mps == s.momentum_at_end_mps)

    rows = [[f"{s.from_velocity_mps:g} -> {s.target_velocity_mps:g}", escape(", ".join(s.keys)), f"{s.t_end_s:.2f}",
             f"{s.momentum_at_end_mps:.3f}" if reached(s) else "not reached", verdict(s.passed)]
            for s in result.stages]
    print_table(console, f"ride in closed loop, plant: {perturb}",
                ("stage [m/s]", Col("entries", text=True), "ends at [s]", "momentum speed [m/s]", "verdict"), rows)
    r = result.run
    name = [f"{s.from_velocity_mps:g} -> {s.target_velocity_mps:g}" for s in result.stages]
    late = [n for n, s in zip(name, result.stages, strict=True) if not s.passed and reached(s)]
    unreached = [n for n, s in zip(name, result.stages, strict=True) if not reached(s)]
    outcome = "pass" if result.passed else "FAIL: " + "; ".join(
        ([f"stage {', '.join(late)} off its target"] if late else [])
        + ([f"stage {', '.join(unreached)} not reached (the run stopped)"] if unreached else [])
        + ([r.reasons] if r.reasons else []))
    delivered = f"{r.delivered_mps:.3f} m/s" if r.delivered_mps == r.delivered_mps else "not measured"
    console.print(escape(f"{r.key}: {outcome} (each stage within 5 % of its target at its end, a stop below "
                         f"0.05 m/s); after the last: delivered {delivered}, deck roll max "
                         f"{r.max_deck_roll_rad:.3f} rad"))
    return bool(result.passed)


def _estimator_table(results: list[Any]) -> None:
    """The estimator's error against the twin's truth, for the runs fed the estimate."""
    estimated = [r for r in results if r.est_trunk_v_rms == r.est_trunk_v_rms]  # not NaN: fed the estimate
    if not estimated:
        return
    rows = [[escape(r.key), f"{r.est_trunk_v_rms:.4f} / {r.est_trunk_v_worst:.3f}",
             f"{r.est_board_speed_rms:.4f} / {r.est_board_speed_worst:.3f}",
             f"{r.est_board_roll_rms:.4f} / {r.est_board_roll_worst:.3f}"] for r in estimated]
    print_table(console, "the estimator against the twin's truth (RMS / worst)",
                ("entry", "trunk v [m/s]", "board speed [m/s]", "board roll [rad]"), rows)


def twin_table(results: list[Any], perturb: str) -> int:
    """Print the verdicts of the runs on the twin; returns how many failed."""
    rows = [[escape(r.key), f"{r.target_velocity_mps:.2f}", f"{r.momentum_at_end_mps:.3f}", f"{r.delivered_mps:.3f}",
             label_error(r.target_velocity_mps, r.delivered_mps), f"{100 * r.max_slip_m:.2f}",
             str(r.floor_touch_ticks), str(r.wheel_lift_ticks), f"{r.heading_error_rad:+.3f}",
             f"{100 * r.lateral_drift_m:+.1f}", f"{r.max_crab_rad:.3f}", f"{r.max_deck_roll_rad:.3f}",
             f"{r.max_torque_Nm:.1f}", f"{100 * r.saturated_share:.1f}", f"{r.wbc_median_ms:.2f}/{r.mpc_median_ms:.1f}",
             verdict(r.passed)] for r in results]
    print_table(console, f"full physics (MuJoCo twin, MPC 30 Hz + whole-body 510 Hz), errors: {perturb}",
                ("entry", "label [m/s]", "p/m end [m/s]", "delivered [m/s]", "error [%]", "slip max [cm]",
                 "floor [ticks]", "wheel lift [ticks]", "heading err [rad]", "lateral [cm]", "crab max [rad]",
                 "roll max [rad]", "tau max [Nm]", "sat [%]", "WBC/MPC med [ms]", "verdict"), rows,
                "p/m end, delivered: the momentum speed of robot and board when the entry ends, and 1 s later plus "
                "what the floor's force on the wheels took; error: delivered against the label (a stop's, label 0: "
                "see delivered); slip max: the largest slip of a stance at its contact point; floor, wheel lift: "
                "ticks (2 ms) of unplanned floor contact and with a wheel off the floor; heading err, lateral: the "
                "board against the plan when the entry ends; crab max: the deck's velocity from its heading; roll "
                "max: the deck's; sat: the share of ticks with a joint at its torque limit; WBC/MPC: the whole-body "
                "controller's and the MPC's median solve times")
    _estimator_table(results)
    return print_failures(results, lambda r: str(r.reasons))


def steer_table(results: list[Any], perturb: str) -> int:
    """Print the steering verdicts, on the twin in its own units (:func:`_twin_steer_table`); returns
    how many failed."""
    from skatelib.proving.twin.steer import TwinSteerResult

    if results and all(isinstance(r, TwinSteerResult) for r in results):
        _twin_steer_table(results, perturb)
    else:
        rows = [[f"{r.target_velocity_mps:.2f}", f"{r.roll_rms_error_rad:.4f}", f"{r.max_roll_rad:.3f}",
                 f"{r.max_lateral_shift_m:.3f}", f"{r.min_normal_N:.2f}", str(r.unloaded_steps), str(r.slips),
                 f"{r.mpc_median_ms:.1f}", verdict(r.passed)] for r in results]
        print_table(console, f"four-leg steering, deck roll 0.1 rad sine, 3 s period; plant: {perturb}",
                    ("speed [m/s]", "roll RMS err [rad]", "roll max [rad]", "torso shift [m]", "min f_n [N]",
                     "unloaded [steps]", "slips [steps]", "MPC med [ms]", "verdict"), rows,
                    "unloaded: plant steps in which a deck foot carried no load; slips: plant steps with a foot force "
                    "outside the cone")
    failed = [r for r in results if not r.passed]
    for r in failed:
        console.print(escape(f"{r.target_velocity_mps:.2f} m/s: {r.reasons}"))
    return len(failed)


def _twin_steer_table(results: list[Any], perturb: str) -> None:
    """The steering verdicts on the twin: its contacts are counted in whole-body ticks (2 ms) and its
    slips per stance, as its entries' are."""
    rows = [[f"{r.target_velocity_mps:.2f}", f"{r.roll_rms_error_rad:.4f}", f"{r.max_roll_rad:.3f}",
             f"{r.max_lateral_shift_m:.3f}", f"{r.min_normal_N:.2f}", str(r.unloaded_steps),
             f"{100 * r.max_slip_m:.2f}", str(r.slips), str(r.floor_touch_ticks), str(r.wheel_lift_ticks),
             f"{r.mpc_median_ms:.1f}", verdict(r.passed)] for r in results]
    print_table(console, f"four-leg steering, deck roll 0.1 rad sine, 3 s period; plant: {perturb}",
                ("speed [m/s]", "roll RMS err [rad]", "roll max [rad]", "torso shift [m]", "min f_n [N]",
                 "off deck [ticks]", "slip max [cm]", "slips [stances]", "floor [ticks]", "wheel lift [ticks]",
                 "MPC med [ms]", "verdict"), rows,
                "min f_n: the smallest normal force of a foot on the twin's contacts; off deck: ticks (2 ms) with a "
                "foot touching nothing; slip max: the largest slip of a stance at its contact point against the deck; "
                "slips: stances that slipped more than 1 cm; floor, wheel lift: ticks with a foot or link on the "
                "floor and with a wheel off the floor for 10 ms or more (each fails the maneuver)")
