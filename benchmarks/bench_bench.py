"""Throughput of ``ftc-mj bench`` next to a plain study of the same runs, in the same invocation.

The bench path: the runs of ``ftc-mj bench safe --split dev --draws N`` on the study runner, each scored in its
worker (:func:`ftc_mj.benchmark.run.bench_run`), then the outputs (draws, scores, report, figures; no Rerun
comparison). The plain path: the same run configs on the same runner with the study's default worker function
(metrics only, no scoring, no report). Each path starts its own LocalCluster of ``--workers`` processes, so
both pay the workers' start-up and solver loading.

    .venv/bin/python benchmarks/bench_bench.py [--draws 4] [--workers 2] [--duration 10]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from ftc_mj.benchmark.methods import load_methods
from ftc_mj.benchmark.report import write_outputs
from ftc_mj.benchmark.run import bench_run, plan_bench, prepare_output
from ftc_mj.study.runner import run_study


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=4)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--duration", type=float, default=10.0, help="Shorten every run to this many seconds.")
    ap.add_argument("--methods", nargs="+", default=["safe"])
    args = ap.parse_args()
    bp = plan_bench(load_methods(args.methods), "dev", args.draws)
    for r in bp.plan.runs:
        r.config["duration"] = args.duration
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, fn in (("plain study", None), ("bench", bench_run)):
            out = Path(tmp) / label.replace(" ", "_")
            t0 = time.perf_counter()
            if fn is not None:
                prepare_output(bp, out)
            rep = run_study(bp.plan, out, workers=args.workers, run_fn=fn, analyse=False)
            if fn is not None:
                assert rep.results is not None
                write_outputs(bp, rep.results, out, compare=0)
            wall = time.perf_counter() - t0
            rows.append((label, len(rep.computed), wall))
    print(f"{len(bp.plan.runs)} runs of {args.duration:g} s ({', '.join(args.methods)}; dev draws 0-{args.draws - 1}), "
          f"{args.workers} worker(s)")
    print(f"{'path':<12} {'runs':>5} {'wall s':>8} {'runs/s':>8}")
    for label, n, wall in rows:
        print(f"{label:<12} {n:>5} {wall:>8.1f} {n / wall:>8.3f}")


if __name__ == "__main__":
    main()
