"""The ``skatelib`` command line. Each command parses, calls one library function and prints."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table
from skatelib.library.errors import SkatelibError

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="Offline motion-library pipeline for legged robots on skateboards.")
console = Console()

# Vendor single-rigid-body figures (ROBOT_DATA.md), printed beside ours for comparison.
VENDOR_MASS_KG = 8.3644
VENDOR_INERTIA_KGM2 = (0.07641, 0.17843, 0.19758)



@app.callback()
def _root() -> None:
    """Offline motion-library pipeline for legged robots on skateboards."""


ConfigArg = Annotated[Path | None, typer.Argument(help="Build config (TOML); the shipped default when omitted.")]


@app.command()
def model(config: ConfigArg = None) -> None:
    """Print the robot and board model of a config: SRB mass and inertia from the URDF, board figures."""
    from skatelib.pipeline.config import load_config
    from skatelib.pipeline.system import SkateSystem

    cfg = load_config(config)
    s = SkateSystem.from_config(cfg)
    t = Table(title=f"{cfg.meta.name}: single rigid body at the nominal stance (pinocchio ccrba)")
    t.add_column("quantity")
    t.add_column("skatelib (from URDF)", justify="right")
    t.add_column("vendor MPC", justify="right")
    t.add_row(escape("mass [kg]"), f"{s.srb.mass_kg:.4f}", f"{VENDOR_MASS_KG:.4f}")
    for i, axis in enumerate("xyz"):
        t.add_row(escape(f"I{axis}{axis} [kg m^2]"), f"{s.srb.inertia_kgm2[i, i]:.5f}", f"{VENDOR_INERTIA_KGM2[i]:.5f}")
    t.add_row(escape("COM in trunk frame [m]"), escape(np.array2string(s.srb.com_offset_m, precision=4)), "-")
    console.print(t)
    b = s.board
    bt = Table(title="skateboard (Eq. 6, 9-14)")
    bt.add_column("parameter")
    bt.add_column("value", justify="right")
    for name, value in (
        ("board mass m_B [kg]", b.mass_kg), ("roll inertia I_Bx [kg m^2]", b.roll_inertia_kgm2),
        ("roll stiffness K_B [N m/rad] (calibrated)", b.roll_stiffness_Nm_per_rad),
        ("roll damping B_B [N m s/rad]", b.roll_damping_Nms_per_rad),
        ("rolling friction f_fri [N]", b.rolling_friction_N), ("K_board [m]", b.K_board_m),
        ("l_f, l_r [m]", f"{b.l_front_m:.3f}, {b.l_rear_m:.3f}"), ("deck height [m]", b.deck_height_m),
    ):
        bt.add_row(escape(name), f"{value:.5g}" if isinstance(value, float) else str(value))
    console.print(bt)
    q = np.round(s.stance.q_board, 3)
    console.print(escape(f"nominal stance q [rad] (FL FR RL RR x abad hip knee): {q.tolist()}"))


def main() -> None:
    """Entry point: turn skatelib errors into a message and exit code 2, not a traceback."""
    try:
        app()
    except SkatelibError as e:
        console.print(f"[bold red]error:[/] {escape(str(e))}")
        raise SystemExit(2) from None
