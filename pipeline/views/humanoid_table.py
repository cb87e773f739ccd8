"""The table of humanoid runs on the twin (``skatelib track HUMANOID_LIB --plant mujoco``)."""

from __future__ import annotations

from typing import Any

from rich.markup import escape
from skatelib.pipeline.views.console import console, entry_table, print_failures


def _cm(x: float) -> str:
    return f"{100 * x:.1f}"


def humanoid_table(results: list[Any], perturb: str) -> int:
    """Print one row per entry (fall, ZMP, COM, slips, board speed, torque); returns how many failed."""
    t = entry_table(escape(f"humanoid on the MuJoCo twin (stabilizer 500 Hz, servos 1 kHz), errors: {perturb}"),
                    ("entry", "fell", "ZMP out (clock) [cm]", "ZMP err RMS/max [cm]", "COM err RMS/max [cm]",
                     "slip [cm]", "yaw slip [rad]", "board at push end [m/s]", "on deck slip [cm] / yaw [rad]",
                     "tau/limit", "verdict"))
    for r in results:
        v = r.verdict
        board = "-"
        if v.board_mps is not None:
            board = f"{v.board_mps:.3f} / {r.label_mps:.2f} ({(v.board_mps / r.label_mps - 1) * 100:+.1f} %)"
        deck = "-" if v.label_mps is None else f"{_cm(v.deck_slip_m)} / {v.deck_yaw_slip_rad:.3f}"
        out = f"{_cm(v.zmp_outside_m)} ({_cm(v.zmp_outside_clock_m)})"
        t.add_row(r.key, escape(v.fell) or "no", out, f"{_cm(v.zmp_rms_m)} / {_cm(v.zmp_max_m)}",
                  f"{_cm(v.com_rms_m)} / {_cm(v.com_max_m)}", _cm(v.slip_m), f"{v.yaw_slip_rad:.3f}", board, deck,
                  f"{v.torque_ratio:.2f}", "[green]pass[/]" if r.passed else "[red]FAIL[/]")
    console.print(t)
    console.print(escape("ZMP: the soles' contact forces' against the plan's; out: the most it left the support "
                         "polygon (the planned places of the soles down: the plan's, and any landed early within 1 cm "
                         "of its touchdown; in brackets: of the soles the plan's clock alone has down); slip, yaw "
                         "slip: a support sole's motion over the floor from 50 ms after it landed (a skate's: the "
                         "pushing sole while it pushed); board: the deck's speed when the push ends against the "
                         "entry's label (5 %); on deck: the soles' motion over the deck while they stood on it. A "
                         "skate's COM, ZMP and polygon are taken relative to the board sole"))
    return print_failures(results, lambda r: "; ".join(r.failures))
