"""The diagnoser's first tyre alarm against Lorden's bound, split by sensor set, with the bound without the pose
fixes' information beside the benchmark's.

    .venv/bin/python benchmarks/lorden_split.py [--method pathfollow] [--start 0] [--draws 100]

Runs ``--method`` on ftc-v2 development draws ``--start``… as a bench worker runs them and, for every draw with a
tyre puncture that has both a first tyre alarm (``tyre_alarm_delay``) and a bound, prints the alarm's delay, the
benchmark's bound (``lorden_delay_bound``: the information of the true speed and yaw-rate departure at the sensors'
σ and of the pose fixes' departure from the dead reckoning at theirs, :func:`~ftc_mj.metrics.fdi.cumulative_kl`)
and the same bound without the pose fixes (the bound the benchmark published before it counted them), then the
median ratio alarm / bound per sensor set with the 95 % order-statistic interval of the median
(:func:`~ftc_mj.benchmark.stats.median_ci`). Every rule's statistics are logged (which changes no decision of the
run), so the estimator's CUSUM and GLR first alarms after the onset (at their calibrated thresholds) are printed
too, each against the bound at its own measured no-fault alarm rate
(:func:`~ftc_mj.metrics.alarm_rates.measured_arl0`). The questions it answers: how near the bound does the
diagnoser's tyre alarm come with and without a gyro; does any detector beat the bound (it must not: a detector
that does shows information the bound leaves out); how near do the estimator's own change detectors come?
"""

from __future__ import annotations

import argparse
import dataclasses
import math

import numpy as np

from ftc_mj.benchmark.draws import draw
from ftc_mj.benchmark.methods import load_methods
from ftc_mj.benchmark.score import bound_arl0, score_run
from ftc_mj.benchmark.stats import median_ci
from ftc_mj.config import RunConfig, validate_config
from ftc_mj.metrics.alarm_rates import RULE_SETTINGS, measured_arl0
from ftc_mj.metrics.fdi import cumulative_kl, lorden_delays
from ftc_mj.sim.run import execute
from ftc_mj.wiring.decision import calibrated_threshold


def measure(cfg: RunConfig) -> dict[str, float] | None:
    """One run of ``cfg`` with every rule's statistics logged (logging only: the run's decisions are its
    rule's): the first tyre alarm and the bounds with and without the pose fixes (s), and the estimator's CUSUM
    and GLR first alarms at their calibrated thresholds with the bound at each one's measured no-fault alarm
    rate; ``None`` for a run without a tyre alarm and a bound."""
    data = cfg.model_dump(mode="json")
    data["estimator"]["decision"]["statistics"] = True
    cfg = validate_config(data)
    out = execute(cfg, None, rrd=False)
    rec, trace = out.result.record, out.result.trace
    score = score_run(cfg, trace, out.result.events, status="ok", record=rec)
    alarm, onset = score.get("tyre_alarm_delay"), rec.first_onset
    if alarm is None or onset is None or score.get("lorden_delay_bound") is None:
        return None
    dt, gyro = rec.setup.dt, rec.setup.yaw_rate_sigma is not None
    K = np.asarray(cumulative_kl(rec.setup, trace, onset))
    arl0 = np.array([bound_arl0(cfg)])
    speed_only = np.asarray(cumulative_kl(dataclasses.replace(rec.setup, position_sigma=None), trace, onset))
    row = {"gyro": float(gyro), "alarm": alarm, "bound": float(lorden_delays(K, arl0, dt)[0]),
           "no_pose": float(lorden_delays(speed_only, arl0, dt)[0])}
    t = np.asarray(trace["t"], float)
    k0 = int(np.searchsorted(t, onset - 1e-9))
    settings = {k: float(getattr(cfg.estimator.decision, k)) for k in RULE_SETTINGS}
    for kind in ("cusum", "glr"):
        up = np.flatnonzero(np.asarray(trace[f"{kind}_stat"], float)[k0:] >= calibrated_threshold(cfg, kind))
        row[kind] = float(t[k0 + up[0]] - onset) if up.size else math.nan
        rate = measured_arl0(kind, gyro, settings) or cfg.estimator.decision.arl0
        row[f"{kind}_bound"] = float(lorden_delays(K, np.array([rate]), dt)[0])
    return row


def ratio_cell(rows: list[dict[str, float]], num: str, den: str) -> str:
    """The median of ``num / den`` over ``rows`` with its 95 % order-statistic interval
    (:func:`~ftc_mj.benchmark.stats.median_ci`; a zero or missing bound left out)."""
    ratios = [r[num] / r[den] for r in rows if r[den] > 0 and math.isfinite(r[den]) and math.isfinite(r[num])]
    if not ratios:
        return "—"
    m = median_ci(ratios)
    return f"{m.mean:.1f} [{m.lo:.1f}, {m.hi:.1f}]"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", default="pathfollow")
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--draws", type=int, default=100)
    args = ap.parse_args()
    method = load_methods([args.method])[0]
    print(f"{args.method} on ftc-v2 dev draws {args.start}-{args.start + args.draws - 1}: tyre punctures with a "
          "first tyre alarm and a bound (s)\n")
    print("| draw | sensors | first tyre alarm | bound | bound without the pose | CUSUM | GLR |")
    print("|---|---|---|---|---|---|---|")
    rows: dict[str, list[dict[str, float]]] = {"speed": [], "speed+yaw": []}
    for i in range(args.start, args.start + args.draws):
        r = measure(method.apply(draw("dev", i).scenario()))
        if r is None:
            continue
        sensors = "speed+yaw" if r["gyro"] else "speed"
        rows[sensors].append(r)
        print(f"| {i} | {sensors} | {r['alarm']:.2f} | {r['bound']:.2f} | {r['no_pose']:.2f} "
              f"| {r['cusum']:.2f} | {r['glr']:.2f} |", flush=True)
    print("\nMedian ratio to the bound [95 %]:\n")
    print("| sensors | punctures | alarms under the bound | tyre alarm / bound | / bound without the pose "
          "| CUSUM / its bound | GLR / its bound |")
    print("|---|---|---|---|---|---|---|")
    for sensors, v in rows.items():
        if v:
            under = sum(1 for r in v if r["alarm"] < r["bound"])
            cells = [ratio_cell(v, "alarm", d) for d in ("bound", "no_pose")]
            cells += [ratio_cell(v, k, f"{k}_bound") for k in ("cusum", "glr")]
            print(f"| {sensors} | {len(v)} | {under} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
