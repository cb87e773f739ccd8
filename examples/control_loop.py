"""A 500 Hz control loop on the runtime: what a robot's controller does with a motion library.

Every 2 ms the loop samples the entry's reference (the whole-body controller's tick); every 1/30 s
it takes the MPC's 10-step window. It runs on numpy and h5py alone, as on the robot, and reports
how long the runtime's part of each tick took: the first tick on its own, then the median, the 99th
percentile and the maximum of the others, and the MPC's window calls apart. ``select`` (and
``lib[key]``) hands out an entry with its interpolation tables built, so the first tick costs about
what the others do; the maximum includes the operating system's scheduling (a robot runs its loop
on a core of its own, at real-time priority).

    python examples/control_loop.py [LIB] [--speed 0.5] [--strides 2]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from skatelib.runtime import MotionLibrary

WBC_DT_S = 0.002  # 500 Hz
MPC_EVERY = 17  # ticks per MPC update: 500 / 17 = 29.4 Hz, the nearest to the paper's 30 Hz


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("library", nargs="?", type=Path, default=Path("out/cyberdog2-default.h5"))
    ap.add_argument("--speed", dest="target_velocity_mps", type=float, default=0.5, help="target speed [m/s]")
    ap.add_argument("--strides", type=int, default=None, help="stride count (default: any)")
    args = ap.parse_args()

    lib = MotionLibrary.open(args.library)
    if lib.kind != "quadruped":
        raise SystemExit(f"{args.library}: a {lib.kind} library; this loop reads a quadruped's board and feet")
    entry = lib.select(args.target_velocity_mps, strides=args.strides, clamp=True)
    print(f"{args.library}: riding {entry.key} ({entry.duration_s:.2f} s, then its end state)")
    ticks = int((entry.duration_s + 0.5) / WBC_DT_S)
    busy = np.empty(ticks)
    windows = []  # the ticks' durations that include an MPC window
    window = None
    for k in range(ticks):
        t = k * WBC_DT_S
        t0 = time.perf_counter()
        if k % MPC_EVERY == 0:
            window = entry.window(t, 10, MPC_EVERY * WBC_DT_S)  # the MPC's reference and contact plan
        ref = entry.sample(t)  # the whole-body controller's reference at this tick
        busy[k] = time.perf_counter() - t0
        if k % MPC_EVERY == 0:
            windows.append(busy[k])
        # A controller would track ref.state / ref.control here, with window for its MPC.
    assert window is not None
    us = busy * 1e6
    print(f"{ticks} ticks at 500 Hz; runtime per tick: first {us[0]:.1f} us, then median {np.median(us[1:]):.1f} us, "
          f"99th percentile {np.percentile(us[1:], 99):.1f} us, max {us[1:].max():.1f} us "
          f"(budget {WBC_DT_S * 1e6:.0f} us)")
    print(f"ticks with an MPC window ({len(windows)}): first {windows[0] * 1e6:.1f} us, "
          f"median of the others {np.median(windows[1:]) * 1e6:.1f} us")
    contact = ref.contact.tolist() if ref.contact is not None else "none (a humanoid entry)"
    print(f"end: board {ref['board_vx']:.3f} {ref.unit('board_vx')}, contact {contact} (0 swing, 1 board, 2 ground)")


if __name__ == "__main__":
    main()
