"""A config of your own, built, validated and ridden in closed loop with the Python API: the shipped
default config with a sweep of your own (here 0.3 and 0.5 m/s in 2 strides, and the transitions
between them and to rest). Any other key of the shipped ``cyberdog2.toml`` can be set the same
way; an unknown key or a value out of range is refused, naming the file and the key.

    python examples/custom_config.py [--out out/custom.h5] [--speeds 0.3 0.5] [--strides 2]
                                     [--interpreted] [--plant model|mujoco] [--perturb none]

The config file is written next to the library (``extends = "skatelib:cyberdog2.toml"`` names the
shipped default wherever skatelib is installed), so that you can edit and rebuild it with
``skatelib build out/custom.toml``. Each entry is printed as it starts and finishes; pass
``progress=True`` to ``skatelib.build`` for the command line's progress bar instead. The entries
are then ridden in closed loop on the plant as planned (``--perturb`` adds model errors, as
``skatelib track`` does by default; on the twin the controller rides on its estimator, the sensors'
default errors included); the exit code is 1 when a build, a check or a ride failed.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import skatelib


def write_config(path: Path, speeds: list[float], strides: int, compile_c: bool) -> Path:
    """A TOML config that extends the shipped default and changes only what it names."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f'''extends = "skatelib:cyberdog2.toml"

[meta]
kind = "quadruped"
name = "{path.stem}"

[optimization]
compile = {str(compile_c).lower()}

[sweep]
velocities_mps = [{", ".join(f"{v:g}" for v in speeds)}]
strides = [{strides}]

[transitions]  # between the same speeds, and a stop from each
speeds_mps = [{", ".join(f"{v:g}" for v in speeds)}]
strides = [{strides}, {strides + 1}]
''')
    return path


def show(event: skatelib.EntryEvent) -> None:
    """Each entry as it starts and as it finishes (solves run in worker processes)."""
    if not event.done:
        print(f"  solving {event.key}", flush=True)
    else:
        outcome = "ok" if event.success else f"FAILED ({event.status})"
        print(f"  {event.key}: {outcome}{' (cached)' if event.cached else ''}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=Path("out/custom.h5"))
    ap.add_argument("--speeds", type=float, nargs="+", default=[0.3, 0.5])
    ap.add_argument("--strides", type=int, default=2)
    ap.add_argument("--interpreted", action="store_true", help="do not compile the stage functions")
    ap.add_argument("--plant", choices=["model", "mujoco"], default="model", help="where to ride the entries")
    ap.add_argument("--perturb", default="none",
                    help="the plant's model errors, KEY=VALUE,... (default: none, the plant as planned; "
                         "skatelib track --help lists the keys)")
    args = ap.parse_args()

    config = write_config(args.out.with_suffix(".toml"), args.speeds, args.strides, not args.interpreted)
    print(f"building {config} -> {args.out}")
    report = skatelib.build(config, args.out, jobs=2, progress=show)
    print(f"wrote {report.path} in {report.wall_time_s:.1f} s; {len(report.failed)} entries failed")

    checked = skatelib.validate(report.path, on_entry=lambda v: print(f"validate {v.key}: {v.status}: {v.message}"))
    runs = skatelib.track(report.path, plant=args.plant, perturb=args.perturb, jobs=2,
                          progress=lambda done, total: print(f"  ridden {done} of {total}", flush=True))
    for r in runs:
        why = "" if r.passed else f": {r.reasons}"
        print(f"track {r.key} ({args.plant} plant, errors: {args.perturb}): delivered {r.delivered_mps:.3f} m/s, "
              f"{'passed' if r.passed else 'FAILED'}{why}")
    ok = not report.failed and checked.valid and all(r.passed for r in runs)
    raise SystemExit(0 if ok else 1)


if __name__ == "__main__":
    main()
