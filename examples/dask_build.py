"""A build on a dask cluster: the same chains as ``skatelib build``, solved on the cluster's
workers. Without ``--scheduler`` the script starts a local cluster of two worker processes (what a
laptop has); give the address of your own cluster to use it. A dask scheduler runs code on its
workers: connect only to a cluster you run.

    python examples/dask_build.py [CONFIG] [--scheduler tcp://HOST:8786] [--out out/dask.h5]

Same as ``skatelib build CONFIG --backend dask --scheduler tcp://HOST:8786``, with the command line's
progress bar (``progress=True``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import skatelib


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("config", nargs="?", type=Path, default=None, help="default: the shipped default config")
    ap.add_argument("--scheduler", default=None, help="tcp://HOST:PORT of a running cluster")
    ap.add_argument("--out", type=Path, default=Path("out/dask.h5"))
    args = ap.parse_args()

    from distributed import Client, LocalCluster  # pip install 'skatelib[dask]'

    if args.scheduler is None:
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
            report = build(args.config, args.out, cluster.scheduler_address)
    else:
        with Client(args.scheduler):  # fails early when the scheduler cannot be reached
            pass
        report = build(args.config, args.out, args.scheduler)
    print(f"wrote {report.path}: {len(report.outcomes) - len(report.failed)} of {len(report.outcomes)} entries "
          f"succeeded in {report.wall_time_s:.1f} s")
    raise SystemExit(1 if report.failed else 0)


def build(config: Path | None, out: Path, scheduler: str) -> skatelib.BuildReport:
    return skatelib.build(config, out, backend="dask", scheduler=scheduler, progress=True)


if __name__ == "__main__":
    main()
