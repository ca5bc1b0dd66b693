"""The old and the new input-rate formulation side by side (docs/findings.md, "The input-rate bound").

    .venv/bin/python docs/tools/rate_bound_table.py [--seeds 10] [--workers 2]

MuJoCo plant, scenario 2, UKF, NMPC, 40 s; sensing (speed, speed + yaw rate) × NMPC cost (paper,
actuation-rate term 1) × feedback (policy none, direct), each run with the first planned input free
relative to the command in force (``controller.rate_bound_from_applied = false``, the old formulation)
and bound to it (the default). Per run: the yaw-rate standard deviation over 1–10 s (before the
fault: the limit cycle), the command's total variation per second, the time a wheel command moved at
the rate limit, the largest command step between two samples and the largest |cross-track error|
after 15 s. Prints the seed-0 table and the means over seeds 0..N-1 with Student-t 95 % intervals.
"""

from __future__ import annotations

import argparse
import itertools
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from ftc_mj.config import load_config
from ftc_mj.sim.run import execute
from ftc_mj.study.analysis import mean_ci

CONFIGS = list(itertools.product((False, True), (0.0, 1.0), (False, True)))
"""(yaw-rate gyro, rate penalty, feedback) of each row."""
FORMULATIONS = {"old": False, "new": True}
COLUMNS = ("yaw-rate std 1–10 s (rad/s)", "command TV (rad/s²)", "at rate limit (s)", "largest step (rad/s)",
           "max \\|cte\\| after 15 s (m)")


def one(job: tuple[bool, float, bool, bool, int]) -> tuple[float, ...]:
    """The five figures of one run."""
    yaw, rp, fb, bound, seed = job
    ov = {"plant.kind": "mujoco", "controller.rate_penalty": rp, "reconfiguration.policy": "direct" if fb else "none",
          "controller.rate_bound_from_applied": bound, "seed": seed, "duration": 40.0}
    if yaw:
        ov["sensors.yaw_rate_sigma"] = 0.01
    o = execute(load_config("scenario2", ov), rrd=False)
    tr, m = o.result.trace, o.metrics
    t = tr["t"]
    early = (t >= 1) & (t < 10)
    return (float(np.std(tr["yaw_rate"][early])), float(m["command_total_variation_per_s"]),
            float(m["command_at_rate_limit_s"]), float(m["command_step_max"]),
            float(np.max(np.abs(tr["cross_track_error"][t >= 15]))))


def label(cfg: tuple[bool, float, bool]) -> str:
    yaw, rp, fb = cfg
    return f"{'speed+yaw' if yaw else 'speed'} | {'rate penalty 1' if rp else 'paper'} | {'on' if fb else 'off'}"


def header(title: str) -> str:
    cols = " | ".join(f"{c}: old / new" for c in COLUMNS)
    return f"\n{title}\n\n| sensors | NMPC cost | feedback | {cols} |\n|---|---|---|" + "---|" * len(COLUMNS)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args()
    jobs = [(*cfg, bound, s) for cfg in CONFIGS for bound in FORMULATIONS.values() for s in range(a.seeds)]
    with ProcessPoolExecutor(a.workers) as ex:
        res = dict(zip(jobs, ex.map(one, jobs), strict=True))
    print(header("Seed 0:"))
    for cfg in CONFIGS:
        cells = [f"{res[(*cfg, False, 0)][i]:.3g} / {res[(*cfg, True, 0)][i]:.3g}" for i in range(len(COLUMNS))]
        print(f"| {label(cfg)} | " + " | ".join(cells) + " |")
    print(header(f"Means over seeds 0–{a.seeds - 1} (± Student-t 95 % half-width):"))
    for cfg in CONFIGS:
        cells = []
        for i in range(len(COLUMNS)):
            e = [mean_ci(np.array([res[(*cfg, b, s)][i] for s in range(a.seeds)])) for b in (False, True)]
            cells.append(" / ".join(f"{x.mean:.3g} ± {x.half:.2g}" for x in e))
        print(f"| {label(cfg)} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
