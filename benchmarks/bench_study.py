"""Study throughput on a LocalCluster: runs/min with 1 and 2 worker processes, and per-worker peak
memory (psutil RSS of each worker process, sampled every 50 ms).

Targets: 2 workers ≥ 1.8 × the runs/min of 1 worker; peak ≤ 600 MB per worker.

    .venv/bin/python benchmarks/bench_study.py [--runs 24] [--duration 12] [--workers 1 2]

Each configuration gets a fresh cluster. The cluster start-up and a warm-up (one 1-s run on every
worker: imports, first solver/model builds, paid once per worker process) are timed separately and
excluded from runs/min, which is the steady-state throughput of the study itself. The study is the
scenario-2 puncture with the default NMPC and UKF, feedback off, varying only the seed, so every run
costs about the same (with feedback on, some seeds send the loop into IPOPT re-seeds and one run
can cost 15× another: the makespan then measures load imbalance, not the cluster).
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import textwrap
import threading
import time
from pathlib import Path
from typing import Any

import psutil

from ftc_mj.study.cluster import open_client
from ftc_mj.study.plan import plan_study
from ftc_mj.study.runner import run_study
from ftc_mj.study.worker import run_one

STUDY = """
name = "bench"
scenario = "scenario2"
seeds = {runs}
[base]
duration = {duration}
"faults.left" = [[{t_fault}, 2.0], [{t_fault}, 1.0]]
"estimator.kind" = "{estimator}"
"sensors.yaw_rate_sigma" = 0.01
feedback = false
"""


class RssSampler:
    """Samples the RSS of the given processes (and their children) in a background thread."""

    def __init__(self, pids: list[int], period: float = 0.05) -> None:
        self.procs = {pid: psutil.Process(pid) for pid in pids}
        self.peak = dict.fromkeys(pids, 0)
        self.period = period
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)

    def _loop(self) -> None:
        while not self._stop.is_set():
            for pid, p in self.procs.items():
                try:
                    rss = p.memory_info().rss + sum(c.memory_info().rss for c in p.children(recursive=True))
                except psutil.Error:
                    continue
                self.peak[pid] = max(self.peak[pid], rss)
            self._stop.wait(self.period)

    def __enter__(self) -> RssSampler:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()


def bench(n_workers: int, study_file: Path) -> dict[str, Any]:
    """Run the study on a fresh LocalCluster of ``n_workers``; return its figures."""
    plan = plan_study(study_file)
    t0 = time.perf_counter()
    with open_client(n_workers, None) as client:
        startup = time.perf_counter() - t0
        pids = list(client.run(os.getpid).values())
        with RssSampler(pids) as rss:
            # warm-up: one short run on every worker (imports, solver and model builds: once per process)
            t1 = time.perf_counter()
            warm_cfg = {**plan.runs[0].config, "duration": 1.0}
            client.run(run_one, warm_cfg, "warm-up")
            warmup = time.perf_counter() - t1
            with tempfile.TemporaryDirectory() as tmp:
                rep = run_study(plan, Path(tmp), client=client, analyse=False)
        assert not rep.failed, rep.results["error"].to_list() if rep.results is not None else None
    tasks = rep.results["task_wall_s"].to_list() if rep.results is not None else [float("nan")]
    return {"workers": n_workers, "runs": len(rep.computed), "startup_s": startup, "warmup_s": warmup,
            "task_median_s": statistics.median(tasks), "task_max_s": max(tasks),
            "wall_s": rep.wall_time_s, "runs_per_min": rep.runs_per_min,
            "peak_mb": [v / 2**20 for v in rss.peak.values()]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=24)
    ap.add_argument("--duration", type=float, default=12.0)
    ap.add_argument("--estimator", default="ukf")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = ap.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    with tempfile.TemporaryDirectory() as tmp:
        study = Path(tmp) / "bench.toml"
        study.write_text(textwrap.dedent(STUDY.format(runs=args.runs, duration=args.duration,
                                                      t_fault=args.duration / 2, estimator=args.estimator)))
        rows = [bench(w, study) for w in args.workers]
    base = rows[0]["runs_per_min"]
    print(f"\nstudy throughput: {args.runs} runs of {args.duration:g} s (scenario-2 puncture, NMPC + "
          f"{args.estimator}, speed + yaw rate, feedback off); {psutil.cpu_count()} CPUs")
    print(f"load average before: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")
    print(f"{'workers':>7} {'runs':>5} {'startup s':>9} {'warm-up s':>9} {'run s med/max':>13} {'wall s':>8} "
          f"{'runs/min':>9} {'speed-up':>8} {'peak MB/worker':>16}")
    for r in rows:
        peaks = "/".join(f"{p:.0f}" for p in r["peak_mb"])
        med = f"{r['task_median_s']:.2f}/{r['task_max_s']:.2f}"
        print(f"{r['workers']:>7} {r['runs']:>5} {r['startup_s']:>9.1f} {r['warmup_s']:>9.1f} {med:>13} "
              f"{r['wall_s']:>8.1f} {r['runs_per_min']:>9.1f} {r['runs_per_min'] / base:>7.2f}x {peaks:>16}")
    if len(rows) > 1:
        sp = rows[-1]["runs_per_min"] / base
        peak = max(max(r["peak_mb"]) for r in rows)
        print(f"targets: speed-up {sp:.2f}x (target >= 1.8x: {'met' if sp >= 1.8 else 'NOT met'}); "
              f"peak {peak:.0f} MB/worker (target <= 600 MB: {'met' if peak <= 600 else 'NOT met'})")


if __name__ == "__main__":
    main()
