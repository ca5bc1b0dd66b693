"""Path-following metrics on a synthetic trace with known answers."""

import math

import numpy as np
import pytest

from ftc_mj.config import RunConfig
from ftc_mj.metrics.path import feasible_speed, path_following_metrics
from ftc_mj.sim.record import build_record


def _trace() -> dict[str, np.ndarray]:
    t = np.arange(4000) / 100.0
    ct = np.where(t < 20.0, 1.0, np.where(t < 25.0, -0.3, 0.1))
    v = np.where(t < 30.0, 10.0, 2.0)
    tr = {"t": t, "cross_track_error": ct, "v": v, "yaw_rate": v / 50.0,
          "R_R": np.full(t.size, 2.0), "R_L": np.where(t < 10.0, 2.0, 0.1),
          "pf_lateral_accel": np.full(t.size, np.nan), "pf_lateral_bound": np.full(t.size, np.nan)}
    rows = np.arange(0, t.size, 10)  # controller samples at 10 Hz
    tr["pf_lateral_bound"][rows] = 3.0
    tr["pf_lateral_accel"][rows] = 2.0
    tr["pf_lateral_accel"][rows[:4]] = [-2.99, 3.0, 2.5, 2.96]  # within 1 % of the bound (≥ 2.97): 2 of them
    return tr


def test_path_following_metrics_known_values() -> None:
    cfg = RunConfig()
    rec = build_record(cfg)
    m = path_following_metrics(rec, _trace(), {"left": 10.0, "right": 15.0})
    after = np.where(np.arange(4000) / 100.0 < 25.0, 0.3, 0.1)[2000:]  # from 5 s after the last onset (15 s)
    assert m["contouring_max_recovered"] == pytest.approx(0.3)
    assert m["contouring_rms_recovered"] == pytest.approx(np.sqrt(np.mean(after**2)))
    assert m["speed_mean_after_fault"] == pytest.approx((20.0 * 10.0 + 10.0 * 2.0) / 30.0)
    assert m["speed_mean_final"] == pytest.approx(2.0)
    V_f = 0.1 * cfg.robot.omega_max / (1.0 - cfg.plant_half_track / cfg.reference.radius)
    assert m["feasible_speed_final"] == pytest.approx(V_f)
    assert m["speed_ratio_final"] == pytest.approx(2.0 / V_f)
    assert m["lateral_accel_max"] == pytest.approx(2.0)
    assert m["lateral_bound_time_s"] == pytest.approx(0.2)
    no_fault = path_following_metrics(rec, _trace(), {"left": None, "right": None})
    assert no_fault["contouring_max_recovered"] == pytest.approx(1.0)  # from 5 s
    del_tr = {k: v for k, v in _trace().items() if not k.startswith("pf_")}
    assert math.isnan(path_following_metrics(rec, del_tr, {"left": 10.0})["lateral_bound_time_s"])


def test_feasible_speed_of_every_path_kind() -> None:
    cfg = RunConfig()
    rec = build_record(cfg)
    assert feasible_speed(rec, 2.0, 2.0) == pytest.approx(10.0)  # the desired speed caps it
    om = cfg.robot.omega_max
    assert feasible_speed(rec, 2.0, 0.1) == pytest.approx(0.1 * om / (1 - 1 / 50))  # inner (left) tyre punctured
    assert feasible_speed(rec, 0.1, 2.0) == pytest.approx(0.1 * om / (1 + 1 / 50))  # outer (right) tyre punctured
    cfg.reference.kind = "figure8"  # both turning senses: the punctured left tyre is the outer one in lobe 2
    assert feasible_speed(build_record(cfg), 2.0, 0.1) == pytest.approx(0.1 * om / (1 + 1 / 50))
    cfg.reference.kind = "line"
    assert feasible_speed(build_record(cfg), 0.1, 2.0) == pytest.approx(0.1 * om)
