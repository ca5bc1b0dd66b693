"""The fast tyre detector's no-fault alarms under drawn conditions, and the threshold offset that makes its mean
time to a false alarm the design's.

    .venv/bin/python benchmarks/tyre_change_calibration.py [--method pathfollow] [--start 0] [--draws 240]
                                                           [--jobs 2] [--write]

Runs ``--method`` with the diagnoser's fast tyre detector on (``diagnosis.tyre_change``,
:mod:`ftc_mj.estimation.diagnosis.change`) on the **healthy** versions of ftc-v2 *development* draws ``--start``…
(every fault dropped: the drawn path, speed, friction, payload, actuator gain, sensor noises and pose fixes kept),
as a bench worker runs them (``--split test``: the shipped offsets validated on the test split's draws, printed
with the shipped offset marked, nothing written). The detector's statistic (``diag_stat_tyre_change``) does not
depend on its threshold: its alarms restart nothing and no controller reads them (only declarations and the
estimator's own decision do). So one run per draw gives its alarms at every threshold: for each offset δ (LLR
units) added to the estimator's calibrated CUSUM threshold (:func:`~ftc_mj.wiring.decision.calibrated_threshold`),
per sensor set (speed; speed + gyro; every ftc-v2 draw has a pose sensor):

- **first alarm after the launch**: the time from :data:`~ftc_mj.metrics.alarm_rates.LAUNCH_S` to the statistic's
  first crossing, censored by the run's end; the censored-exponential rate (alarms / seconds watched) with
  Garwood's exact interval (:func:`~ftc_mj.metrics.alarm_rates.censored_rate`). Its inverse is the mean time to a
  false alarm, the ARL0 of Lorden's bound; the offset is chosen on it
  (:func:`~ftc_mj.metrics.alarm_rates.chosen_offset`, nearest the design on the log scale);
- **episodes**: up-crossings after the launch per second (what ``metrics.json`` counts as alarms; clustered, so
  the Poisson interval of this column is too narrow and it is shown without one).

``--write`` stores the chosen offsets, the rate at each and every offset's counts in
``ftc_mj/data/calibration/tyre_change.json`` (:func:`~ftc_mj.estimation.calibration.tyre_change_offset` reads it;
the benchmark's ``tyre_alarm_bound`` takes its measured ARL0). Development draws only: the test split validates
it.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from ftc_mj.benchmark.draws import draw
from ftc_mj.benchmark.methods import load_methods
from ftc_mj.config import validate_config
from ftc_mj.estimation.calibration import TYRE_CHANGE_FILE, sensor_set, tyre_change_offset
from ftc_mj.metrics.alarm_rates import LAUNCH_S, RULE_SETTINGS, Rate, censored_rate, chosen_offset
from ftc_mj.sim.run import execute
from ftc_mj.wiring.decision import calibrated_threshold

OFFSETS = tuple(round(-1.0 + 0.25 * k, 2) for k in range(21))
"""Offsets (LLR units) tried: -1 … +4."""


def healthy_run(method_spec: str, split: str, index: int) -> dict[str, Any]:
    """Draw ``index``'s healthy run by the method with the fast tyre detector on: its sensor set, the statistic's
    excess over the calibrated CUSUM threshold after the launch, the times (s) and the run's end (s)."""
    method = load_methods([method_spec])[0]
    data = method.apply(draw(split, index).scenario(with_faults=False)).model_dump(mode="json")
    data["diagnosis"]["tyre_change"] = True
    cfg = validate_config(data)
    out = execute(cfg, None, rrd=False)
    tr = out.result.trace
    t = np.asarray(tr["t"], float)
    keep = t >= LAUNCH_S
    excess = np.asarray(tr["diag_stat_tyre_change"], float)[keep] - calibrated_threshold(cfg, "cusum")
    declared = int(np.nan_to_num(np.asarray(tr["diag_count"], float))[-1])
    return {"index": index, "gyro": cfg.sensors.yaw_rate_sigma is not None, "t": t[keep], "excess": excess,
            "end": float(t[-1]), "declared": declared,
            "settings": {k: float(getattr(cfg.estimator.decision, k)) for k in RULE_SETTINGS}}


def first_alarm(run: dict[str, Any], offset: float) -> tuple[float, bool]:
    """``(s from the launch to the first crossing of offset, crossed)``; the run's end censors it."""
    up = np.flatnonzero(run["excess"] > offset)
    if up.size:
        return float(run["t"][up[0]] - LAUNCH_S), True
    return run["end"] - LAUNCH_S, False


def episodes(run: dict[str, Any], offset: float) -> int:
    """Up-crossings of ``offset`` after the launch (a first row already above counts)."""
    f = run["excess"] > offset
    return int(np.sum(f[1:] & ~f[:-1]) + (1 if f.size and f[0] else 0))


def curve(runs: list[dict[str, Any]]) -> dict[float, dict[str, Any]]:
    """Per offset: the first-alarm rate and the episode count over the runs."""
    out = {}
    for d in OFFSETS:
        r = censored_rate(first_alarm(run, d) for run in runs)
        out[d] = {"first": r, "episodes": sum(episodes(run, d) for run in runs),
                  "exposure": sum(run["end"] - LAUNCH_S for run in runs)}
    return out


def rate_json(r: Rate) -> dict[str, float]:
    return {"alarms": r.alarms, "exposure": round(r.exposure, 2), "rate": r.rate, "lo": r.lo, "hi": r.hi}


def arl0_cell(r: Rate) -> str:
    lo, hi = r.arl0_interval
    return f"{r.arl0:.0f} [{lo:.0f}, {hi:.0f}]" if r.alarms else f"> {lo:.0f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", default="pathfollow")
    ap.add_argument("--split", choices=("dev", "test"), default="dev",
                    help="dev to calibrate; test to validate the shipped offsets (no --write)")
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--draws", type=int, default=240)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--design", type=float, default=100.0, help="design mean time to a false alarm (s)")
    ap.add_argument("--write", action="store_true")
    args = ap.parse_args()
    if args.write and args.split != "dev":
        ap.error("--write calibrates on development draws only (--split dev)")
    indices = range(args.start, args.start + args.draws)
    with ProcessPoolExecutor(args.jobs) as pool:
        runs = list(pool.map(healthy_run, [args.method] * len(indices), [args.split] * len(indices), indices))
    result: dict[str, Any] = {"offsets": {}, "after_launch": {}, "curves": {}}
    for gyro in (False, True):
        mine = [r for r in runs if r["gyro"] == gyro]
        key = sensor_set(gyro)
        c = curve(mine)
        chosen = chosen_offset({d: v["first"] for d, v in c.items()}, args.design)
        shipped = tyre_change_offset(gyro)
        declared = sum(r["declared"] > 0 for r in mine)
        print(f"\n{key}: {len(mine)} healthy runs, {c[OFFSETS[0]]['exposure']:.0f} s after the launch, "
              f"{declared} with a declaration; chosen offset {chosen:+.2f} (←), shipped {shipped:+.2f} (=)\n")
        print("| offset | first alarms | mean time to the first alarm (s) [95 %] | episodes | s per episode |")
        print("|---|---|---|---|---|")
        for d, v in c.items():
            per = v["exposure"] / v["episodes"] if v["episodes"] else math.inf
            mark = (" ←" if d == chosen else "") + (" =" if d == shipped else "")
            print(f"| {d:+.2f}{mark} | {v['first'].alarms} | {arl0_cell(v['first'])} "
                  f"| {v['episodes']} | {per:.0f} |")
        result["offsets"][key] = chosen
        result["after_launch"][key] = {**rate_json(c[chosen]["first"]), "episodes": c[chosen]["episodes"]}
        result["curves"][key] = {str(d): {**rate_json(v["first"]), "episodes": v["episodes"]} for d, v in c.items()}
    if args.write:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
        doc = {"written_by": "benchmarks/tyre_change_calibration.py --write", "commit": commit,
               "design_arl0": args.design, "settings": runs[0]["settings"],
               "conditions": {"benchmark": "ftc-v2", "split": args.split,
                              "draws": [args.start, args.start + args.draws - 1], "healthy": True,
                              "method": args.method, "launch_s": LAUNCH_S}, **result}
        path = Path(__file__).resolve().parents[1] / "ftc_mj" / TYRE_CHANGE_FILE
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        with os.fdopen(fd, "w") as f:
            json.dump(doc, f, indent=1)
            f.write("\n")
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
        print(f"\nwrote {path}")


if __name__ == "__main__":
    main()
