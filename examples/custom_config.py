"""A config of your own, built and validated: the shipped default config with a sweep of your own
(here 0.3 and 0.5 m/s in 2 strides, and the transitions between them and to rest). Any other key
of ``configs/cyberdog2.toml`` can be set the same way; an unknown key or a value out of range is
refused, naming the file and the key.

    python examples/custom_config.py [--out out/custom.h5] [--speeds 0.3 0.5] [--strides 2]

The config file is written next to the library so that you can edit and rebuild it with
``skatelib build out/custom.toml``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from skatelib.pipeline.build.contract import BuildOptions
from skatelib.pipeline.build.orchestrate import build_library
from skatelib.pipeline.config import CONFIG_DIR, load_config
from skatelib.pipeline.validate import validate_library


def write_config(path: Path, speeds: list[float], strides: int, compile_c: bool) -> Path:
    """A TOML config that extends the shipped default and changes only what it names."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f'''extends = "{(CONFIG_DIR / "cyberdog2.toml").as_posix()}"

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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=Path("out/custom.h5"))
    ap.add_argument("--speeds", type=float, nargs="+", default=[0.3, 0.5])
    ap.add_argument("--strides", type=int, default=2)
    ap.add_argument("--interpreted", action="store_true", help="do not compile the stage functions")
    args = ap.parse_args()

    cfg = load_config(write_config(args.out.with_suffix(".toml"), args.speeds, args.strides, not args.interpreted))
    report = build_library(cfg, args.out, BuildOptions(jobs=2, progress=False))
    for o in report.outcomes:
        print(f"{o.key}: {'ok' if o.success else 'FAILED'}")

    def show(key: str, verdict: str, message: str, figures: dict[str, float]) -> None:
        print(f"validate {key}: {verdict}: {message}")

    failures = validate_library(report.path, show)
    print(f"wrote {report.path} in {report.wall_time_s:.1f} s; {failures} entries failed validation")
    raise SystemExit(1 if failures or report.failed else 0)


if __name__ == "__main__":
    main()
