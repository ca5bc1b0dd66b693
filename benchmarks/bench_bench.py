"""Throughput of ``ftc-mj bench`` next to a plain study of the same runs, in the same invocation.

The bench path: the runs of ``ftc-mj bench safe --split dev --draws N`` on the study runner, each scored in its
worker (:func:`ftc_mj.benchmark.run.bench_run`), then the outputs (draws, scores, report, figures; no Rerun
comparison). The plain path: the same run configs on the same runner with the study's default worker function
(metrics only, no scoring, no report). Each path starts its own LocalCluster of ``--workers`` processes, so
both pay the workers' start-up and solver loading; the paths run in the order plain, bench, bench, plain
(``--repeats 2``) so that a drift of the machine's load falls on both, and each path's best wall time counts.

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
    ap.add_argument("--repeats", type=int, default=2, help="Runs of each path (alternating order).")
    args = ap.parse_args()
    bp = plan_bench(load_methods(args.methods), "dev", args.draws)
    for r in bp.plan.runs:
        r.config["duration"] = args.duration
    order = [("plain study", None), ("bench", bench_run)]
    sequence = [p for k in range(args.repeats) for p in (order if k % 2 == 0 else order[::-1])]
    walls: dict[str, list[float]] = {label: [] for label, _ in order}
    with tempfile.TemporaryDirectory() as tmp:
        for i, (label, fn) in enumerate(sequence):
            out = Path(tmp) / f"{i}-{label.replace(' ', '_')}"
            t0 = time.perf_counter()
            prepare_output(bp, out)  # bench.json, the file the study store copies
            rep = run_study(bp.plan, out, workers=args.workers, run_fn=fn, analyse=False)
            if fn is not None:
                assert rep.results is not None
                write_outputs(bp, rep.results, out, compare=0)
            assert len(rep.computed) == len(bp.plan.runs)
            walls[label].append(time.perf_counter() - t0)
    rows = [(label, len(bp.plan.runs), min(w)) for label, w in walls.items()]
    print(f"{len(bp.plan.runs)} runs of {args.duration:g} s ({', '.join(args.methods)}; dev draws 0-{args.draws - 1}), "
          f"{args.workers} worker(s)")
    print(f"{'path':<12} {'runs':>5} {'best wall s':>12} {'runs/s':>8}   (each path {args.repeats}x)")
    for label, n, wall in rows:
        print(f"{label:<12} {n:>5} {wall:>12.1f} {n / wall:>8.3f}   all: "
              + ", ".join(f"{w:.1f}" for w in walls[label]))


if __name__ == "__main__":
    main()
