"""The scorer: its FDI and reconfiguration scores agree with the run metrics they reuse, the isolation
verdict treats a fault the filters cannot model as a false isolation, Lorden's bound follows its formula,
the PCRB is a bound, and the paired statistics are right on constructed data."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ftc_mj.benchmark.score import SCORE_COLUMNS, fault_truth, isolation_verdict, score_run, sensor_kl
from ftc_mj.benchmark.stats import paired, rank_biserial
from ftc_mj.config import load_config
from ftc_mj.metrics.fdi import lorden_delays
from ftc_mj.telemetry.columns import WHEEL_CODES


def test_scores_of_a_puncture_run_agree_with_its_metrics(shared_runs):
    run = shared_runs["s2-puncture-5s-safe"]
    cfg = shared_runs.config("s2-puncture-5s-safe")
    s = score_run(cfg, run.result.trace, run.result.events, status=run.metrics["status"])
    assert set(s) == set(SCORE_COLUMNS)
    m = run.metrics
    assert s["detected"] and not s["false_alarm"]
    assert s["detection_delay"] == pytest.approx(m["detection_delay"], abs=1e-9)
    assert s["reconfig_delay"] == pytest.approx(m["reconfig_handover_delay"], abs=1e-9)
    assert s["isolation"] == ("correct" if m["isolated_wheel"] == "left" else "unknown")
    assert s["tipped"] == m["tipped"]
    # 5 s run, puncture at 3 s: no sample 5 s after the onset, so no contouring score and no success
    assert s["contouring_max"] is None and s["success"] is False
    assert 0.0 < s["lorden_delay_bound"] <= 5.0
    # the bound for constant radii after the puncture is below the filter's prior σ (0.5 m): information adds up
    assert 0.0 < s["radius_pcrb_L"] < cfg.estimator.p0_sigma[4]
    # a run that recorded the data model's bound: the scorer reads it instead of computing its own
    trace = {**run.result.trace, "R_R_pcrb_const_std": np.full(len(run.result.trace["t"]), 0.123),
             "R_L_pcrb_const_std": np.full(len(run.result.trace["t"]), 0.456)}
    s2 = score_run(cfg, trace, run.result.events)
    assert (s2["radius_pcrb_R"], s2["radius_pcrb_L"]) == (0.123, 0.456)


def test_fault_truth_of_a_double_puncture():
    cfg = load_config("scenario3")
    f = fault_truth(cfg)
    assert [(x["fault_class"], x["target"], x["onset"]) for x in f] == [("puncture", "left", 5.0),
                                                                        ("puncture", "right", 10.0)]
    assert f[0]["size"] == pytest.approx(1.0)  # radius lost (m)
    ramp = fault_truth(load_config("scenario4"))[0]
    assert ramp["onset"] == 10.0 and ramp["end"] == 29.0 and ramp["size"] == pytest.approx(1.9)


def _verdict(codes: list[str], faults: list[dict]) -> str:
    t = np.arange(len(codes), dtype=float)
    code = np.array([WHEEL_CODES[c] if c else 0 for c in codes])
    return isolation_verdict(code, t, faults)


def test_isolation_verdict_counts_unmodelled_faults_as_wrong():
    left = [{"fault_class": "puncture", "target": "left", "onset": 1.0}]
    both = left + [{"fault_class": "puncture", "target": "right", "onset": 2.0}]
    speed = [{"fault_class": "speed_bias", "target": "speed", "onset": 1.0}]
    lock = [{"fault_class": "wheel_lock", "target": "left", "onset": 1.0}]
    assert _verdict(["", "", "left", "left"], left) == "correct"
    assert _verdict(["", "", "right", "right"], left) == "wrong"
    assert _verdict(["", "", "unknown", "unknown"], left) == "unknown"
    assert _verdict(["", "", "", ""], left) == "none"
    assert _verdict(["", "", "left", "both"], both) == "correct"
    assert _verdict(["", "", "left", "left"], speed) == "wrong"  # a sensor fault declared as a puncture
    assert _verdict(["", "", "left", "left"], lock) == "wrong"  # an actuator fault declared as a puncture
    assert _verdict(["", "", "unknown", ""], speed) == "unknown"
    assert _verdict(["left", "", "", ""], []) == "n/a"


def test_lorden_bound_of_a_constant_information_rate():
    """K_n = c (n + 1): the bound is the first row with c (j + 1) ≥ log(ARL0/dt), i.e. j = ⌈log(ARL0/dt)/c⌉ − 1."""
    dt, c = 0.01, 0.3
    K = c * np.arange(1, 501)
    arl0 = np.array([1.0, 100.0, 1e80])  # log(1e80 / dt) = 189 nats > K[-1] = 150: beyond the profile
    expect = [(math.ceil(math.log(a / dt) / c) - 1) * dt for a in arl0[:2]]
    got = lorden_delays(K, arl0, dt)
    assert got[:2] == pytest.approx(expect) and math.isinf(got[2])


def test_sensor_bias_information_is_half_the_squared_snr_per_row():
    cfg = load_config("scenario1", {"sensors.speed_sigma": 0.5})
    trace = {"t": np.arange(0, 20, 0.01)}
    K = sensor_kl(cfg, trace, {"fault_class": "speed_bias", "target": "speed", "onset": 10.0, "size": 0.25})
    assert K[:3] == pytest.approx(0.5 * (0.25 / 0.5) ** 2 * np.arange(1, 4))
    drift = sensor_kl(cfg, trace, {"fault_class": "speed_drift", "target": "speed", "onset": 10.0, "size": 1.0})
    assert drift[1] - drift[0] == pytest.approx(0.5 * (0.02 / 0.5) ** 2)
    assert sensor_kl(cfg, trace, {"fault_class": "speed_dropout", "target": "speed", "onset": 10.0,
                                  "size": 0.0}).size == 0


def test_paired_statistics_on_constructed_pairs():
    """Differences +0.5 on 15 draws, −0.5 on 5: the median +0.5 with its order-statistic interval [x(6), x(15)]
    of the sorted differences (both +0.5), the exact sign-test p = 2·P(Bin(20, ½) ≥ 15) = 2·21700/2²⁰, and the
    rank-biserial r of equal |d| (all ranks tied): (15 − 5)/20; from fewer than 10 non-zero pairs no r."""
    rows = [{"method": m, "draw": d, "x": v} for d in range(20)
            for m, v in (("a", d + 1.0), ("b", d + (0.5 if d < 15 else 1.5)))]
    p = paired(rows, "x", "a", "b")
    assert p.estimate == pytest.approx(0.5) and p.n == 20 and not p.binary
    assert (p.a_larger, p.b_larger) == (15, 5)
    assert p.lo == pytest.approx(0.5) and p.hi == pytest.approx(0.5)
    assert p.p_value == pytest.approx(2 * 21700 / 2**20, rel=1e-9) and p.effect == pytest.approx(0.5)
    assert math.isnan(rank_biserial(np.array([1.0, 1.0, -1.0, 0.0])))
    assert rank_biserial(np.array([1.0] * 8 + [-1.0] * 2 + [0.0])) == pytest.approx((8 - 2) / 10)
