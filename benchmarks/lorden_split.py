"""The diagnoser's first tyre alarm against Lorden's bound, split by sensor set, with the bound under the
physical null model and the bound with the pose fixes' information beside the benchmark's.

    .venv/bin/python benchmarks/lorden_split.py [--method pathfollow] [--start 0] [--draws 100]

Runs ``--method`` on ftc-v2 development draws ``--start``… as a bench worker runs them and, for every draw with a
tyre puncture that has both a first tyre alarm (``tyre_alarm_delay``) and a bound, prints the alarm's delay, the
benchmark's bound (``lorden_delay_bound``: the information of the true speed and yaw-rate departure at the sensors'
σ, :func:`~ftc_mj.metrics.fdi.cumulative_kl`) and the same bound with the information counted under the detectors'
physical null model (:mod:`ftc_mj.estimation.null_model`: each wheel's slip noise at the demanded lateral
acceleration added along the radius columns, a channel whose slip noise exceeds twice its sensor's σ left out) and
the bound with the pose fixes' information added (:func:`pose_kl`), then the median ratio alarm / bound per sensor
set with the 95 % order-statistic interval of the median (:func:`~ftc_mj.benchmark.stats.median_ci`). Every rule's
statistics are logged (which changes no decision of the run), so the estimator's CUSUM and GLR first alarms after
the onset (at their calibrated thresholds) are printed too, each against the bound at its own measured no-fault
alarm rate (:func:`~ftc_mj.metrics.alarm_rates.measured_arl0`). The questions it answers: is the gap between the
alarm and the bound the bound's null model (the healthy robot's slip counted as information) or the detector's
information; does a detector that reads the pose fixes beat a bound that leaves them out; how near the bound do the
estimator's own change detectors come?
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from ftc_mj.benchmark.draws import draw
from ftc_mj.benchmark.methods import load_methods
from ftc_mj.benchmark.score import bound_arl0, score_run
from ftc_mj.benchmark.stats import median_ci
from ftc_mj.config import RunConfig, validate_config
from ftc_mj.estimation.null_model import HOLD_S, NullModel
from ftc_mj.estimation.setup import FilterSetup
from ftc_mj.metrics.alarm_rates import RULE_SETTINGS, measured_arl0
from ftc_mj.metrics.fdi import KL_PROFILE_S, cumulative_kl, lorden_delays
from ftc_mj.model.kinematics import body_rates
from ftc_mj.sim.run import execute
from ftc_mj.wiring.decision import calibrated_threshold


def physical_kl(setup: FilterSetup, trace: dict[str, np.ndarray], onset: float) -> np.ndarray:
    """``K_n`` as :func:`~ftc_mj.metrics.fdi.cumulative_kl` counts it (the departure from the no-slip model less
    its mean over the second before ``onset`` (s)), with the innovation covariance of the physical null model:
    ``R + s(q)² H_r H_rᵀ`` at the demand ``q`` (g, the largest of the last ``HOLD_S``, at nominal radii from the
    true wheel rates), channels the null model drops left out (nats, per row)."""
    t = np.asarray(trace["t"], float)
    R0, b = setup.nominal_radius, setup.model.b
    w = np.column_stack([np.asarray(trace["omega_R"], float), np.asarray(trace["omega_L"], float)])
    V0, yr0 = body_rates(R0, R0, w[:, 0], w[:, 1], b)
    nm = NullModel(R0, b, setup.dt)
    channels = [("speed", np.asarray(trace["v"], float) - V0, setup.speed_sigma, (0.5, 0.5))]
    if setup.yaw_rate_sigma is not None:
        channels.append(("yaw", np.asarray(trace["yaw_rate"], float) - yr0, setup.yaw_rate_sigma,
                         (0.5 / b, -0.5 / b)))
    k0 = int(np.searchsorted(t, onset - 1e-9))
    pre = (t >= onset - 1.0) & (t < onset)
    bias = {name: float(r[pre].mean()) for name, r, _, _ in channels}
    demand = np.array([nm.demand(u, np.array([R0, R0])) for u in w])
    hold = max(1, int(round(HOLD_S / setup.dt)))
    K, total = [], 0.0
    for k in range(k0, min(t.size, k0 + int(round(KL_PROFILE_S / setup.dt)))):
        q = float(demand[max(0, k - hold + 1): k + 1].max())
        used = [(r[k] - bias[name], s, g) for name, r, s, g in channels if not nm.drops(q, w[k], s, name)]
        if used:
            H = np.array([[g[0] * w[k, 0], g[1] * w[k, 1]] for _, _, g in used])
            S = np.diag([s * s for _, s, _ in used]) + nm.slip_sigma(q) ** 2 * (H @ H.T)
            d = np.array([v for v, _, _ in used])
            total += 0.5 * float(d @ np.linalg.solve(S, d))
        K.append(total)
    return np.asarray(K)


def pose_kl(setup: FilterSetup, trace: dict[str, np.ndarray], onset: float, n: int) -> np.ndarray:
    """The pose fixes' share of the information, per row from ``onset`` (s) over ``n`` rows (nats): at each row
    with a fix, ``½ (δx² + δy²)/σ_p² + ½ δψ²/σ_ψ²`` added, ``δ`` the true pose's departure from the pose the no-slip
    model dead-reckons from the onset's true pose with the true wheel rates and the nominal radius, its speed and
    yaw rate shifted by their mean departure over the second before the onset (as :func:`cumulative_kl` takes
    it off); zero without a pose sensor. The fixes' noise is independent of the speed sensor's and the gyro's,
    so the two informations add."""
    if setup.position_sigma is None:
        return np.zeros(n)
    t = np.asarray(trace["t"], float)
    R0, b, dt = setup.nominal_radius, setup.model.b, setup.dt
    V0, yr0 = body_rates(R0, R0, np.asarray(trace["omega_R"], float), np.asarray(trace["omega_L"], float), b)
    V, yr = np.asarray(trace["v"], float), np.asarray(trace["yaw_rate"], float)
    k0 = int(np.searchsorted(t, onset - 1e-9))
    pre = (t >= onset - 1.0) & (t < onset)
    V0, yr0 = V0 + (V - V0)[pre].mean(), yr0 + (yr - yr0)[pre].mean()
    x, y, psi = (np.asarray(trace[c], float) for c in ("x", "y", "psi"))
    fixes = np.isfinite(np.asarray(trace["x_meas"], float))
    xd, yd, pd = x[k0], y[k0], psi[k0]
    K, total = [], 0.0
    for k in range(k0, min(t.size, k0 + n)):
        if k > k0:  # the model's pose at row k from the rates of row k - 1
            xd, yd, pd = xd + V0[k - 1] * math.cos(pd) * dt, yd + V0[k - 1] * math.sin(pd) * dt, pd + yr0[k - 1] * dt
        if fixes[k]:
            total += 0.5 * ((x[k] - xd) ** 2 + (y[k] - yd) ** 2) / setup.position_sigma**2
            if setup.heading_sigma is not None:
                total += 0.5 * (psi[k] - pd) ** 2 / setup.heading_sigma**2
        K.append(total)
    return np.asarray(K)


def measure(cfg: RunConfig) -> dict[str, float] | None:
    """One run of ``cfg`` with every rule's statistics logged (logging only: the run's decisions are its
    rule's): the first tyre alarm and the three bounds (s), and the estimator's CUSUM and GLR first alarms at
    their calibrated thresholds with the bound at each one's measured no-fault alarm rate; ``None`` for a run
    without a tyre alarm and a bound."""
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
    row = {"gyro": float(gyro), "alarm": alarm, "bound": float(lorden_delays(K, arl0, dt)[0]),
           "physical": float(lorden_delays(physical_kl(rec.setup, trace, onset), arl0, dt)[0]),
           "every": float(lorden_delays(K + pose_kl(rec.setup, trace, onset, K.size), arl0, dt)[0])}
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
    print("| draw | sensors | first tyre alarm | bound | bound, physical null | bound, with the pose | CUSUM | GLR |")
    print("|---|---|---|---|---|---|---|---|")
    rows: dict[str, list[dict[str, float]]] = {"speed": [], "speed+yaw": []}
    for i in range(args.start, args.start + args.draws):
        r = measure(method.apply(draw("dev", i).scenario()))
        if r is None:
            continue
        sensors = "speed+yaw" if r["gyro"] else "speed"
        rows[sensors].append(r)
        print(f"| {i} | {sensors} | {r['alarm']:.2f} | {r['bound']:.2f} | {r['physical']:.2f} | {r['every']:.2f} "
              f"| {r['cusum']:.2f} | {r['glr']:.2f} |", flush=True)
    print("\nMedian ratio to the bound [95 %]:\n")
    print("| sensors | punctures | bound moved by the null model | tyre alarm / bound | / physical-null bound "
          "| / bound with the pose | CUSUM / its bound | GLR / its bound |")
    print("|---|---|---|---|---|---|---|---|")
    for sensors, v in rows.items():
        if v:
            moved = sum(1 for r in v if r["bound"] != r["physical"])
            cells = [ratio_cell(v, "alarm", d) for d in ("bound", "physical", "every")]
            cells += [ratio_cell(v, k, f"{k}_bound") for k in ("cusum", "glr")]
            print(f"| {sensors} | {len(v)} | {moved} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
