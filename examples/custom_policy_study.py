"""A small study of a custom reconfiguration policy against the built-in ones, on a Dask LocalCluster
(2 workers by default): the study's base names the plug-in module (``plugins``), so each worker imports
``my_components`` (this folder is on their ``sys.path``) before it validates a run.

    python examples/custom_policy_study.py [--duration 20] [--seeds 2] [--workers 2] [--out runs/out/examples/study]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import polars as pl

import ftc_mj

STUDY = """
name = "late_handover"
scenario = "scenario2"
seeds = {seeds}
[base]
duration = {duration}
plugins = ["my_components"]
"sensors.yaw_rate_sigma" = 0.01
"controller.rate_penalty" = 1.0
[[axes]]
key = "reconfiguration.policy"
values = ["none", "safe", "late-handover"]
"""


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--duration", type=float, default=20.0)
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--workers", type=int, default=2, help="worker processes of the LocalCluster")
    parser.add_argument("--out", type=Path, default=Path("runs/out/examples/study"))
    args = parser.parse_args()
    study = args.out.with_suffix(".toml")
    study.parent.mkdir(parents=True, exist_ok=True)
    study.write_text(STUDY.format(seeds=args.seeds, duration=args.duration))
    result = ftc_mj.run_study(study, args.out, workers=args.workers)
    print(result.results.group_by("reconfiguration.policy", maintain_order=True).agg(
        pl.len().alias("runs"), pl.col("status").eq("ok").sum().alias("ok"),
        pl.col("cross_track_rms").mean(), pl.col("detection_delay").mean()))


if __name__ == "__main__":  # the cluster's worker processes import this file: they must not run it
    main()
