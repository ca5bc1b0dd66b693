"""A bench worker's memory and CPU over new draws: one process runs ``--draws`` draws of one method as
``ftc-mj bench`` runs them (:func:`~ftc_mj.benchmark.run.bench_run`, the per-process cache of
:mod:`ftc_mj.sim.cache` kept between runs as a worker keeps it; ``--clear``: emptied before every draw),
and prints each draw's CPU seconds, the resident set after it and the solver and cache counters.

    .venv/bin/python benchmarks/bench_worker_memory.py --method safe [--draws 12] [--duration 10] [--clear]

The target of the performance issue: the resident set stays flat across draws (a bench never runs a draw
twice, so the cache must hold only what a new draw reuses: the solvers).
"""

from __future__ import annotations

import argparse
import resource
import time
from pathlib import Path

from ftc_mj.benchmark.draws import draw
from ftc_mj.benchmark.methods import load_methods
from ftc_mj.benchmark.run import bench_run
from ftc_mj.control import solver_cache
from ftc_mj.sim import cache


def rss_mib() -> float:
    """This process's resident set now (MiB), from ``/proc/self/statm``."""
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    return pages * resource.getpagesize() / 2**20


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", default="safe")
    ap.add_argument("--draws", type=int, default=12)
    ap.add_argument("--duration", type=float, default=10.0, help="Shorten every run to this many seconds.")
    ap.add_argument("--clear", action="store_true", help="Empty the per-process cache before every draw.")
    args = ap.parse_args()
    method = load_methods([args.method])[0]
    print(f"{args.method}: {args.draws} dev draws of {args.duration:g} s in one process"
          f"{', cache cleared before each' if args.clear else ''}; RSS at start {rss_mib():.0f} MiB")
    print(f"{'draw':>4} {'cpu s':>7} {'rss MiB':>8}  counters")
    for i in range(args.draws):
        scenario = draw("dev", i).scenario()
        scenario["duration"] = args.duration
        cfg = method.apply(scenario)
        if args.clear:
            cache.clear()
        t = time.process_time()
        bench_run(cfg, None, False)
        cpu = time.process_time() - t
        print(f"{i:>4} {cpu:>7.2f} {rss_mib():>8.0f}  solvers {solver_cache.stats}, cache {cache.stats}", flush=True)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak RSS {peak:.0f} MiB")


if __name__ == "__main__":
    main()
