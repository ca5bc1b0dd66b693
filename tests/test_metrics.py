"""Metrics computed from constructed traces whose answers are known exactly."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.config import load_config
from ftc_mj.sim.columns import BASE_COLUMNS
from ftc_mj.sim.metrics import compute_metrics, fault_onsets


def _trace(n: int = 1000, dt: float = 0.01) -> dict[str, np.ndarray]:
    tr = {c: np.zeros(n) for c in BASE_COLUMNS}
    tr["t"] = np.arange(n) * dt
    for c in ("R_R", "R_L", "R_R_hat", "R_L_hat"):
        tr[c][:] = 2.0
    tr["R_R_std"][:] = tr["R_L_std"][:] = 0.1
    tr["innovation_std"][:] = 1.0
    tr["solve_time_ms"][:] = np.nan
    tr["solver_iterations"][:] = np.nan
    return tr


def test_fault_onsets_step_and_ramp() -> None:
    assert fault_onsets(load_config("scenario1")) == {"right": None, "left": None}
    assert fault_onsets(load_config("scenario2")) == {"right": None, "left": 10.0}
    assert fault_onsets(load_config("scenario3")) == {"right": 10.0, "left": 5.0}
    assert fault_onsets(load_config("scenario4")) == {"right": None, "left": 10.0}


def test_innovation_fraction_and_rmse() -> None:
    cfg = load_config("scenario1")
    tr = _trace()
    tr["innovation"][:] = 1.0
    tr["innovation"][:50] = 3.0  # 5 % outside 2 sigma
    tr["R_L_hat"][:] = 2.0 + 0.3  # constant error 0.3 m
    m = compute_metrics(cfg, tr, fault_onsets(cfg), {})
    assert m["innovation_in_2sigma"] == pytest.approx(0.95)
    assert m["radius_rmse_L"] == pytest.approx(0.3)
    assert m["radius_final_error_L"] == pytest.approx(0.3)
    assert m["radius_rmse_R"] == 0.0
    assert m["radius_nees_mean"] == pytest.approx(9.0)


def test_detection_delay_false_alarm_and_limits() -> None:
    cfg = load_config("scenario2", {"duration": 20.0})
    tr = _trace(2000)
    tr["fault_detected"][tr["t"] >= 10.5] = 1.0
    wmax = cfg.robot.omega_max
    tr["omega_R_cmd"][:200] = wmax  # 10 % of rows at the limit
    m = compute_metrics(cfg, tr, fault_onsets(cfg), {})
    assert m["detection_delay"] == pytest.approx(0.5)
    assert m["false_alarm"] is False and m["missed_detection"] is False
    assert m["true_fault_wheel"] == "left"
    assert m["omega_at_limit_fraction"] == pytest.approx(0.1)
    # total variation: one jump of wmax over 19.99 s
    assert m["command_total_variation_per_s"] == pytest.approx(wmax / 19.99)
    tr["fault_detected"][100:120] = 1.0  # declared before the onset
    m = compute_metrics(cfg, tr, fault_onsets(cfg), {})
    assert m["false_alarm"] is True and m["declarations"] == 2


def test_missed_detection() -> None:
    cfg = load_config("scenario2", {"duration": 20.0})
    m = compute_metrics(cfg, _trace(2000), fault_onsets(cfg), {})
    assert m["missed_detection"] is True and m["detection_delay"] is None
