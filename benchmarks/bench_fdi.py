"""Cost of the FDI statistics: every rule's per-step statistic (CUSUM, GLR, sigma and mode scores), the
posterior Cramér–Rao bound of a run, the detectors' threshold calibration, and a whole run with and
without the statistics.

Plain script: ``.venv/bin/python benchmarks/bench_fdi.py [--steps N] [--repeats R]``.
The filter inputs are those of ``bench_filters.py`` (excited wheel rates, R_L 2 → 1 m over 10–12 s).
The per-step rows time ``FaultDecision.update`` with the statistics on and off, interleaved, the UKF
step next to them for scale; the run rows are scenario 2 on the kinematic and MuJoCo plants (20 s,
policy none). CPU time (``time.process_time``) so that other load on a shared machine counts less;
minimum over the repeats (the run rows) or median and p95 over steps (the step rows).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from bench_filters import scenario

from ftc_mj.config import RunConfig, load_config
from ftc_mj.estimation import UKF, Measurement
from ftc_mj.estimation.calibration import null_threshold
from ftc_mj.estimation.pcrb import pcrb_columns
from ftc_mj.sim.loop import simulate
from ftc_mj.wiring.decision import build_fault_decision, calibrated_threshold
from ftc_mj.wiring.estimation import setup_from_config


def step_costs(steps: int, gyro: float | None) -> dict[str, np.ndarray]:
    """µs per step of the UKF and of the decision with and without the statistics, interleaved."""
    u, z, zy = scenario(steps)
    base = {"sensors": {"yaw_rate_sigma": gyro}}
    cfg_on = RunConfig.model_validate({**base, "estimator": {"decision": {"statistics": True}}})
    cfg_off = RunConfig.model_validate({**base, "estimator": {"decision": {"statistics": False}}})
    f = UKF(setup_from_config(cfg_on))
    dec_on, dec_off = build_fault_decision(cfg_on), build_fault_decision(cfg_off)
    out: dict[str, list[float]] = {"ukf step": [], "decision, statistics on": [], "decision, statistics off": []}
    for k in range(steps):
        meas = Measurement(speed=float(z[k]), yaw_rate=None if gyro is None else float(zy[k]))
        t0 = time.process_time()
        o = f.step(u[k], meas)
        t1 = time.process_time()
        dec_on.update(k * 0.01, o, u[k])
        t2 = time.process_time()
        dec_off.update(k * 0.01, o, u[k])
        t3 = time.process_time()
        out["ukf step"].append(t1 - t0)
        out["decision, statistics on"].append(t2 - t1)
        out["decision, statistics off"].append(t3 - t2)
    return {k: np.asarray(v[100:]) * 1e6 for k, v in out.items()}


def run_costs(repeats: int) -> list[tuple[str, float, float]]:
    """CPU s of a 20 s scenario 2 run per plant, statistics off / on (minimum over repeats)."""
    rows = []
    for plant in ("kinematic", "mujoco"):
        best = {}
        for stats in (False, True):
            cfg = load_config("scenario2", {"plant.kind": plant, "reconfiguration.policy": "none", "duration": 20.0,
                                            "sensors.yaw_rate_sigma": 0.01, "estimator.decision.statistics": stats})
            simulate(cfg)  # warm: plant, controller and compiled kernels
            ts = []
            for _ in range(repeats):
                t0 = time.process_time()
                simulate(cfg)
                ts.append(time.process_time() - t0)
            best[stats] = min(ts)
        rows.append((plant, best[False], best[True]))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=4000)
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    print("| sensors | timed | median µs/step | p95 µs/step |")
    print("|---|---|---|---|")
    for gyro in (None, 0.01):
        for name, v in step_costs(a.steps, gyro).items():
            print(f"| {'speed+yaw' if gyro else 'speed'} | {name} | {np.median(v):.1f} | {np.percentile(v, 95):.1f} |")
    cfg = load_config("scenario2", {"plant.kind": "kinematic", "reconfiguration.policy": "none", "duration": 40.0})
    tr = simulate(cfg).trace
    t0 = time.process_time()
    pcrb_columns(setup_from_config(cfg), tr)
    print(f"\nPCRB columns of a 40 s trace ({tr['t'].size} rows): {time.process_time() - t0:.3f} CPU s")
    for gyro in (None, 0.01):
        c = RunConfig.model_validate({"sensors": {"yaw_rate_sigma": gyro}})
        for kind in ("cusum", "glr"):
            null_threshold.cache_clear()
            t0 = time.process_time()
            h = calibrated_threshold(c, kind)
            print(f"calibration {kind:5s} {'speed+yaw' if gyro else 'speed':9s} ARL0 100 s: h = {h:.3f} in "
                  f"{time.process_time() - t0:.2f} CPU s")
    print("\n| plant | 20 s run, statistics off (CPU s) | statistics on (CPU s) | overhead |")
    print("|---|---|---|---|")
    for plant, off, on in run_costs(a.repeats):
        print(f"| {plant} | {off:.3f} | {on:.3f} | {100 * (on / off - 1):+.0f} % |")


if __name__ == "__main__":
    main()
