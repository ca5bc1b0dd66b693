"""Run lengths of the change detectors under no fault on the physical (MuJoCo) plant, against their design.

Plain script: ``.venv/bin/python benchmarks/calibration.py [--runs N] [--jobs J] [--write]``.

Per sensor set (speed; speed + a 0.01 rad/s gyro): ``--runs`` no-fault runs of scenario 1 (the 50 m circle
at 10 m/s) on MuJoCo, 30 s each, feedback off (policy none, the setting of the FDI studies), development
seeds 0, 1, ...; the decision statistics are logged (``estimator.decision.statistics``). The CUSUM and GLR
are replayed on each run's logged wheel rates and measurements (the replay's statistic is checked equal to
the logged one step for step up to its first alarm), restarted

- **from the start**: at 0 s; the first alarm only (the run length from a fresh start at the launch);
- **after the launch**: at :data:`~ftc_mj.metrics.alarm_rates.LAUNCH_S` and after every alarm (renewal: each
  run length from a fresh start).

Rate: the censored-exponential maximum-likelihood estimate (alarms / seconds watched; a run's end censors its
last run length), 95 % interval exact (Garwood) on the count (:func:`~ftc_mj.metrics.alarm_rates.censored_rate`);
ARL0 = 1 / rate against the design ``estimator.decision.arl0``. The ``sigma`` rule (the default UKF's, at
``k_sigma``) is measured the same way on its logged statistic (an alarm: an up-crossing). Lorden's bound is
given for the 50 % left puncture at 10 s of one fault run per sensor set, at the measured ARL0 and at the
design's. ``--write`` stores the after-launch rates in ``ftc_mj/data/calibration/alarm_rates.json``, which
the benchmark's ``lorden_delay_bound`` reads. ``--first-seed`` moves the runs' seeds (held-out seeds measure
the shipped detectors without tuning them).

``--calibrate`` chooses the detectors' threshold offsets under the physical null model: on the no-fault runs
of development seeds 0..``--runs``-1, each detector is replayed at its threshold on ``N(0, I)`` innovations
plus each of :data:`OFFSETS`, and the offset whose after-launch mean time between false alarms is nearest the
design (log scale) is written to ``ftc_mj/data/calibration/physical_offsets.json``, with every offset's counts
(:func:`~ftc_mj.estimation.calibration.physical_offset` reads it; the decision factory adds it to the threshold).
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from ftc_mj.config import RunConfig, load_config
from ftc_mj.estimation.base import Measurement
from ftc_mj.estimation.calibration import OFFSETS_FILE
from ftc_mj.metrics.alarm_rates import (
    LAUNCH_S,
    RATES_FILE,
    RULE_SETTINGS,
    Rate,
    censored_rate,
    chosen_offset,
    run_lengths,
)
from ftc_mj.metrics.fdi import cumulative_kl, lorden_delays
from ftc_mj.sim.loop import simulate
from ftc_mj.wiring.decision import build_change_detectors, calibrated_threshold, nominal_threshold
from ftc_mj.wiring.estimation import setup_from_config

SENSORS = {"speed": {}, "speed+yaw": {"sensors.yaw_rate_sigma": 0.01}}
BASE = {"plant.kind": "mujoco", "reconfiguration.policy": "none", "duration": 30.0,
        "estimator.decision.statistics": True}
DETECTORS = ("cusum", "glr")


def config(sensors: str, seed: int, **extra: Any) -> RunConfig:
    """Scenario 1 on MuJoCo with the sensor set ``sensors`` and the noise ``seed`` (:data:`BASE`)."""
    return load_config("scenario1", {**BASE, **SENSORS[sensors], "seed": seed, **extra})


def replay(cfg: RunConfig, tr: dict[str, np.ndarray], kind: str, h: float, start: float, renew: bool,
           logged: bool = False, peak: list[float] | None = None) -> list[float]:
    """Alarm times (s) of detector ``kind`` at threshold ``h`` replayed on the run's trace ``tr``: the residual
    generator from 0 s, the statistic restarted at ``start`` (s) and, with ``renew``, after every alarm;
    ``logged``: check the statistic against the trace's logged one up to the first alarm (start 0 only);
    ``peak``: a list that gets the statistic's largest value from ``start`` on."""
    det = build_change_detectors(cfg, setup_from_config(cfg))
    t, v = tr["t"], tr["v_meas"]
    yaw = tr["yaw_rate_meas"] if cfg.sensors.yaw_rate_sigma is not None else None
    om = np.column_stack([tr["omega_R_meas"], tr["omega_L_meas"]])
    radii = np.column_stack([tr["R_R_hat"], tr["R_L_hat"]])  # the estimator's, the null model reads the demand at
    alarms: list[float] = []
    fresh = start <= 0.0
    for k in range(t.size):
        if not fresh and t[k] >= start - 1e-9:
            det.restart()
            fresh = True
        det.step(float(t[k]), om[k - 1] if k else om[0], Measurement(
            speed=float(v[k]), yaw_rate=None if yaw is None else float(yaw[k])), radii[k])
        g = det.cusum_stat if kind == "cusum" else det.glr_stat
        if logged and not alarms and not math.isclose(g, float(tr[f"{kind}_stat"][k]), rel_tol=1e-9, abs_tol=1e-9):
            raise AssertionError(f"{kind} replay differs from the logged statistic at t = {t[k]:.2f} s")
        if fresh and peak is not None:
            peak[:] = [max(peak[0], g)] if peak else [g]
        if fresh and g >= h:
            alarms.append(float(t[k]))
            if not renew:
                break
            det.restart()
    return alarms


def crossings(tr: dict[str, np.ndarray], column: str, h: float, start: float) -> list[float]:
    """Times (s) from ``start`` at which the logged statistic ``column`` crosses ``h`` upwards."""
    t, g = tr["t"], np.nan_to_num(np.asarray(tr[column], float), nan=-np.inf)
    on = (g >= h) & (t >= start)
    up = on & ~np.r_[False, on[:-1]]
    return [float(x) for x in t[up]]


def measure(sensors: str, seeds: range) -> dict[str, dict[str, Rate]]:
    """Rates per cell (``start``, ``after_launch``) and rule over the no-fault runs of ``seeds`` (module
    docstring)."""
    cells: dict[str, dict[str, list[tuple[float, bool]]]] = {"start": {}, "after_launch": {}}
    for seed in seeds:
        cfg = config(sensors, seed)
        res = simulate(cfg, strict=True)
        tr = {k: np.asarray(v) for k, v in res.trace.items()}
        end = float(tr["t"][-1])
        th = {k: calibrated_threshold(cfg, k) for k in DETECTORS}
        for kind in DETECTORS:
            first = replay(cfg, tr, kind, th[kind], 0.0, renew=False, logged=True)
            after = replay(cfg, tr, kind, th[kind], LAUNCH_S, renew=True)
            cells["start"].setdefault(kind, []).extend(run_lengths(first[:1], 0.0, first[0] if first else end))
            cells["after_launch"].setdefault(kind, []).extend(run_lengths(after, LAUNCH_S, end))
        ks = cfg.estimator.decision.k_sigma
        up0, up = crossings(tr, "sigma_stat", ks, 0.0), crossings(tr, "sigma_stat", ks, LAUNCH_S)
        cells["start"].setdefault("sigma", []).extend(run_lengths(up0[:1], 0.0, up0[0] if up0 else end))
        cells["after_launch"].setdefault("sigma", []).extend(run_lengths(up, LAUNCH_S, end))
    return {cell: {rule: censored_rate(rl) for rule, rl in rules.items()} for cell, rules in cells.items()}


OFFSETS = tuple(round(-3.0 + 0.25 * i, 2) for i in range(19))
"""Threshold offsets (LLR units) tried by ``--calibrate``: -3 to +1.5 in steps of 0.25 (a step moves the mean time
between false alarms by about e^0.25 = 1.28)."""


def calibrate(sensors: str, seeds: range) -> dict[str, dict[float, dict[str, Rate]]]:
    """Rates per detector, offset and cell (``start``, ``after_launch``) over no-fault runs of ``seeds``, at
    the nominal threshold plus each of :data:`OFFSETS`: the first alarm from the run's logged statistic, the
    renewed alarms after the launch by replay (only where the statistic reaches the threshold at all)."""
    cells: dict[str, dict[float, dict[str, list[tuple[float, bool]]]]] = {k: {} for k in DETECTORS}
    for seed in seeds:
        cfg = config(sensors, seed)
        res = simulate(cfg, strict=True)
        tr = {k: np.asarray(v) for k, v in res.trace.items()}
        end = float(tr["t"][-1])
        for kind in DETECTORS:
            h0, top = nominal_threshold(cfg, kind), []
            replay(cfg, tr, kind, math.inf, LAUNCH_S, renew=False, peak=top)
            for d in OFFSETS:
                first = crossings(tr, f"{kind}_stat", h0 + d, 0.0)[:1]
                after = replay(cfg, tr, kind, h0 + d, LAUNCH_S, renew=True) if top[0] >= h0 + d else []
                cell = cells[kind].setdefault(d, {"start": [], "after_launch": []})
                cell["start"].extend(run_lengths(first, 0.0, first[0] if first else end))
                cell["after_launch"].extend(run_lengths(after, LAUNCH_S, end))
    return {kind: {d: {c: censored_rate(rl) for c, rl in cl.items()} for d, cl in by.items()}
            for kind, by in cells.items()}


def calibrate_main(seeds: range, jobs: int) -> None:
    """``--calibrate``: the offsets' curves on the development ``seeds``, printed, and the chosen offsets
    written to :data:`~ftc_mj.estimation.calibration.OFFSETS_FILE`."""
    with ProcessPoolExecutor(min(jobs, len(SENSORS))) as ex:
        curves = dict(zip(SENSORS, ex.map(calibrate, SENSORS, [seeds] * len(SENSORS)), strict=True))
    design = config("speed", 0).estimator.decision.arl0
    out: dict[str, Any] = {"written_by": "benchmarks/calibration.py --calibrate", "commit": _commit(),
                           "runs": len(seeds), "design_arl0": design,
                           "conditions": {"scenario": "scenario1", **BASE, "launch_s": LAUNCH_S,
                                          "seeds": [seeds[0], seeds[-1]]},
                           "offsets": {}, "curves": {}}
    print("| sensors | rule | offset | first alarm: alarms / s, ARL0 [95 %] | after launch: alarms / s, ARL0 [95 %] |")
    print("|---|---|---|---|---|")
    for sensors, by_kind in curves.items():
        for kind, curve in by_kind.items():
            pick = chosen_offset({d: cells["after_launch"] for d, cells in curve.items()}, design)
            out["offsets"].setdefault(sensors, {})[kind] = pick
            out["curves"].setdefault(sensors, {})[kind] = {
                f"{d:g}": {c: [r.alarms, round(r.exposure, 3)] for c, r in cells.items()} for d, cells in curve.items()}
            for d, cells in curve.items():
                a, b = cells["start"], cells["after_launch"]
                print(f"| {sensors} | {kind} | {'**' if d == pick else ''}{d:+.2f}{'**' if d == pick else ''} | "
                      f"{a.alarms} / {a.exposure:.0f}, {_fmt(a.arl0)} [{_fmt(a.arl0_interval[0])}, "
                      f"{_fmt(a.arl0_interval[1])}] | {b.alarms} / {b.exposure:.0f}, {_fmt(b.arl0)} "
                      f"[{_fmt(b.arl0_interval[0])}, {_fmt(b.arl0_interval[1])}] |")
    path = Path(__file__).resolve().parents[1] / "ftc_mj" / OFFSETS_FILE
    path.write_text(json.dumps(out, indent=1) + "\n")
    print(f"\noffsets {out['offsets']}\nwrote {path}")


def _commit() -> str:
    """The checkout's commit, ``-dirty`` when its working tree has changes (the data then came from neither)."""
    return subprocess.run(["git", "describe", "--always", "--dirty", "--abbrev=7"], capture_output=True, text=True,
                          cwd=Path(__file__).parent).stdout.strip()


def lorden(sensors: str, arl0: dict[str, float]) -> dict[str, float]:
    """Lorden's bound (s) for a 50 % left puncture at 10 s (one run, seed 0) at each given ARL0 (s)."""
    cfg = config(sensors, 0, **{"faults.left": [[10.0, 2.0], [10.0, 1.0]]})
    res = simulate(cfg, strict=True)
    tr = {k: np.asarray(v) for k, v in res.trace.items()}
    K = np.asarray(cumulative_kl(res.record.setup, tr, 10.0), float)
    dt = 1.0 / cfg.estimator.rate
    return {k: float(lorden_delays(K, np.array([a]), dt)[0]) for k, a in arl0.items()}


def _fmt(x: float) -> str:
    return "inf" if not math.isfinite(x) else f"{x:.3g}"


def table(rates: dict[str, dict[str, dict[str, Rate]]], design: float) -> list[str]:
    """Markdown rows: sensor set, cell, rule, alarms, exposure, ARL0 [95 %], ARL0 / design [95 %]."""
    rows = ["| sensors | measured | rule | alarms | exposure (s) | ARL0 s [95 %] | ARL0 / design [95 %] |",
            "|---|---|---|---|---|---|---|"]
    for sensors, cells in rates.items():
        for cell, rules in cells.items():
            for rule, r in rules.items():
                lo, hi = r.arl0_interval
                where = "from the start" if cell == "start" else f"after {LAUNCH_S:g} s, renewed"
                ratio = "—" if rule == "sigma" else (f"{_fmt(r.arl0 / design)} [{_fmt(lo / design)}, "
                                                     f"{_fmt(hi / design)}]")
                rows.append(f"| {sensors} | {where} | {rule} | {r.alarms} | {r.exposure:.0f} | {_fmt(r.arl0)} "
                            f"[{_fmt(lo)}, {_fmt(hi)}] | {ratio} |")
    return rows


def stored(rates: dict[str, dict[str, dict[str, Rate]]], cfg: RunConfig, seeds: range) -> dict[str, Any]:
    """The data file's content: the after-launch rates per sensor set and rule, with the settings they hold for."""
    d = cfg.estimator.decision
    settings = {k: float(getattr(d, k)) for k in RULE_SETTINGS}
    out: dict[str, Any] = {"written_by": "benchmarks/calibration.py", "commit": _commit(), "runs": len(seeds),
                           "conditions": {"scenario": "scenario1", **BASE, "launch_s": LAUNCH_S,
                                          "seeds": [seeds[0], seeds[-1]], "estimator": cfg.estimator.kind},
                           "after_launch": {}}
    for sensors, cells in rates.items():
        out["after_launch"][sensors] = {rule: {"alarms": r.alarms, "exposure": r.exposure, "rate": r.rate,
                                               "lo": r.lo, "hi": r.hi, "settings": settings}
                                        for rule, r in cells["after_launch"].items()}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=40, help="no-fault runs of 30 s per sensor set")
    ap.add_argument("--first-seed", type=int, default=0, help="the first run's seed (then +1 each run)")
    ap.add_argument("--jobs", type=int, default=2, help="processes (one sensor set each)")
    ap.add_argument("--write", action="store_true", help=f"store the after-launch rates in ftc_mj/{RATES_FILE}")
    ap.add_argument("--calibrate", action="store_true",
                    help=f"choose the threshold offsets on the (development) seeds, write ftc_mj/{OFFSETS_FILE}")
    args = ap.parse_args()
    t0 = time.perf_counter()
    seeds = range(args.first_seed, args.first_seed + args.runs)
    if args.calibrate:
        if seeds[-1] >= 1000:
            raise SystemExit("--calibrate: the offsets are chosen on development seeds (< 1000) only")
        calibrate_main(seeds, args.jobs)
        print(f"\nwall {time.perf_counter() - t0:.0f} s")
        return
    with ProcessPoolExecutor(min(args.jobs, len(SENSORS))) as ex:  # one sensor set per process
        rates = dict(zip(SENSORS, ex.map(measure, SENSORS, [seeds] * len(SENSORS)), strict=True))
    cfg = config("speed", 0)
    design = cfg.estimator.decision.arl0
    print(f"{args.runs} no-fault runs x 30 s per sensor set (seeds {seeds[0]}-{seeds[-1]}), MuJoCo, scenario 1, "
          f"feedback off; design ARL0 "
          f"{design:g} s\n")
    print("\n".join(table(rates, design)))
    print("\nLorden's bound (s), 50 % left puncture at 10 s, at the measured after-launch ARL0 and at the design:\n")
    print("| sensors | rule | measured ARL0 (s) | bound at it (s) | bound at the design ARL0 (s) |")
    print("|---|---|---|---|---|")
    for s in SENSORS:
        after = rates[s]["after_launch"]
        arl = {r: (v.arl0 if v.alarms else v.arl0_interval[0]) for r, v in after.items()}
        b = lorden(s, {**arl, "design": design})
        for r in after:
            print(f"| {s} | {r} | {_fmt(arl[r])} | {_fmt(b[r])} | {_fmt(b['design'])} |")
    if args.write:
        path = Path(__file__).resolve().parents[1] / "ftc_mj" / RATES_FILE
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(stored(rates, cfg, seeds), indent=1) + "\n")
        print(f"\nwrote {path}")
    print(f"\nwall {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
