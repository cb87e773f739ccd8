"""The table of humanoid runs on the twin (``skatelib track HUMANOID_LIB --plant mujoco``)."""

from __future__ import annotations

from typing import Any

from rich.markup import escape
from skatelib.pipeline.views.console import console, print_failures
from skatelib.pipeline.views.fitted import Col, print_table


def _cm(x: float) -> str:
    return f"{100 * x:.1f}"


def humanoid_table(results: list[Any], perturb: str) -> int:
    """Print one row per entry (fall, ZMP, COM, slips, board speed, torque); returns how many failed."""
    rows = []
    for r in results:
        v = r.verdict
        board = "-" if v.board_mps is None else f"{v.board_mps:.3f}/{r.label_mps:.2f}"
        skate = v.label_mps is not None
        rows.append([escape(r.key), escape(v.fell) or "no", f"{_cm(v.zmp_outside_m)} ({_cm(v.zmp_outside_clock_m)})",
                     f"{_cm(v.zmp_rms_m)}/{_cm(v.zmp_max_m)}", f"{_cm(v.com_rms_m)}/{_cm(v.com_max_m)}",
                     _cm(v.slip_m), f"{v.yaw_slip_rad:.3f}", board,
                     _cm(v.deck_slip_m) if skate else "-", f"{v.deck_yaw_slip_rad:.3f}" if skate else "-",
                     f"{100 * v.torque_ratio:.0f}", "[green]pass[/]" if r.passed else "[red]FAIL[/]"])
    print_table(console, f"humanoid on the MuJoCo twin (stabilizer 500 Hz, servos 1 kHz), errors: {perturb}",
                ("entry", Col("fell", text=True), "ZMP out (clock) [cm]", "ZMP err RMS/max [cm]",
                 "COM err RMS/max [cm]", "slip [cm]", "yaw slip [rad]", "board/label [m/s]", "deck slip [cm]",
                 "deck yaw slip [rad]", "tau/limit [%]", "verdict"), rows,
                "ZMP: the soles' contact forces' against the plan's; out: the most it left the support polygon (the "
                "planned places of the soles down: the plan's, and any landed early within 1 cm of its touchdown; "
                "in brackets: of the soles the plan's clock alone has down); slip, yaw slip: a support sole's motion "
                "over the floor from 50 ms after it landed (a skate's: the pushing sole while it pushed); "
                "board/label: the deck's speed when the push ends and the entry's label (within 5 %); deck slip, "
                "deck yaw slip: the soles' motion over the deck while they stood on it; tau/limit: the largest joint "
                "torque in % of the joint's limit. A skate's COM, ZMP and polygon are taken relative to the board sole")
    return print_failures(results, lambda r: "; ".join(r.failures))
