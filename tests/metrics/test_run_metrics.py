"""Metrics computed from constructed traces whose answers are known exactly."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.config import load_config
from ftc_mj.metrics.run import compute_metrics
from ftc_mj.plant import LIFTOFF
from ftc_mj.sim.loop import simulate
from ftc_mj.sim.record import build_record, fault_onsets
from ftc_mj.sim.run import run_metrics
from ftc_mj.telemetry.columns import BASE_COLUMNS, WHEEL_CODES


def _trace(n: int = 1000, dt: float = 0.01) -> dict[str, np.ndarray]:
    tr = {c: np.zeros(n) for c in BASE_COLUMNS}
    tr["t"] = np.arange(n) * dt
    for c in ("R_R", "R_L", "R_R_hat", "R_L_hat"):
        tr[c][:] = 2.0
    for c in ("x_std", "y_std", "psi_std", "R_R_std", "R_L_std"):
        tr[c][:] = 0.1
    tr["innovation_std"][:] = 1.0
    tr["nis_dof"][:] = 1.0
    tr["solve_time_ms"][:] = np.nan
    tr["solver_iterations"][:] = np.nan
    return tr


def _declare(tr: dict[str, np.ndarray], t0: float, t1: float, wheel: str) -> None:
    sel = (tr["t"] >= t0) & (tr["t"] < t1)
    tr["fault_detected"][sel] = 1.0
    tr["declared_wheel"][sel] = WHEEL_CODES[wheel]


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
    m = compute_metrics(build_record(cfg), tr, {})
    assert m["innovation_in_2sigma"] == pytest.approx(0.95)
    assert m["radius_rmse_L"] == pytest.approx(0.3)
    assert m["radius_final_error_L"] == pytest.approx(0.3)
    assert m["radius_rmse_R"] == 0.0
    assert m["radius_nees_mean"] == pytest.approx(9.0)  # (0.3 / 0.1)², no cross-covariance
    assert m["nees_mean"] == pytest.approx(9.0)


def test_radius_nees_uses_the_cross_covariance() -> None:
    """Speed-only radius covariance: σ 0.5 m each, correlation -0.999, so the sum direction (1, 1)/√2 has
    σ = 0.5·sqrt(0.001) = 0.0158 m. An error of +0.05 m on both radii is 0.0707 m = 4.47 σ along it:
    ε = eᵀP⁻¹e = 20.0, where the diagonal formula (e_R/σ_R)² + (e_L/σ_L)² gives 0.02."""
    cfg = load_config("scenario1")
    tr = _trace()
    tr["R_R_std"][:] = tr["R_L_std"][:] = 0.5
    tr["R_RL_cov"][:] = -0.999 * 0.25
    tr["R_R_hat"][:] += 0.05
    tr["R_L_hat"][:] += 0.05
    P = np.array([[0.25, -0.24975], [-0.24975, 0.25]])
    e = np.array([0.05, 0.05])
    expected = float(e @ np.linalg.solve(P, e))
    assert expected == pytest.approx(20.0, rel=1e-9)  # 2 · 0.05² / (0.25 · (1 - 0.999))
    m = compute_metrics(build_record(cfg), tr, {})
    assert m["radius_nees_mean"] == pytest.approx(expected, rel=1e-9)
    # the full-state NEES adds the three pose terms (zero errors here): the same value
    assert m["nees_mean"] == pytest.approx(expected, rel=1e-9)
    # χ² bounds for the run: a constant statistic has τ = 1, so n_eff = samples = 1000 and the
    # two-sided 95 % bounds of the mean of 1000 χ²_2 samples are χ²_2000(0.025, 0.975) / 1000 =
    # [1.878, 2.126] (the normal approximation 2 ± 1.96·sqrt(4/1000) gives [1.876, 2.124])
    test = m["radius_nees_test"]
    assert test["samples"] == 1000 and test["n_eff"] == pytest.approx(1000)
    assert (test["lo"], test["hi"]) == pytest.approx((1.8779, 2.1258), abs=1e-4)


def test_nis_is_normalised_per_measurement_dimension() -> None:
    cfg = load_config("scenario1")
    tr = _trace()
    tr["nis_dof"][:] = 1.0
    tr["nis_dof"][::100] = 3.0  # a position fix every second: speed + x + y
    tr["nis"][:] = tr["nis_dof"]  # every step's NIS equals its dimension: 1 per dimension
    tr["nis"][5] = np.nan  # a rejected step
    tr["nis_dof"][5] = 0.0
    m = compute_metrics(build_record(cfg), tr, {})
    assert m["nis_mean"] == pytest.approx(1.0)
    # 990 speed-only steps (one rejected) and 10 with a fix: 1019 channel samples in 999 steps
    assert m["nis_test"]["samples"] == 999 and m["nis_test"]["dof"] == pytest.approx(1019 / 999)


def test_detection_delay_and_limits() -> None:
    cfg = load_config("scenario2", {"duration": 20.0})
    tr = _trace(2000)
    _declare(tr, 10.5, 20.0, "left")
    wmax = cfg.robot.omega_max
    tr["omega_R_cmd"][:200] = wmax  # 10 % of rows at the limit
    m = compute_metrics(build_record(cfg), tr, {})
    assert m["detection_delay"] == pytest.approx(0.5) and m["time_to_correct_isolation"] == pytest.approx(0.5)
    assert m["false_alarm"] is False and m["false_alarms"] == 0 and m["missed_detection"] is False
    assert m["true_fault_wheel"] == "left" and m["isolated_wheel"] == "left" and m["isolation_correct"] is True
    assert m["isolation_correct_fraction"] == pytest.approx(0.95)  # correct from 10.5 s of [10, 20)
    assert m["omega_at_limit_fraction"] == pytest.approx(0.1)
    # total variation: one jump of wmax over 19.99 s
    assert m["command_total_variation_per_s"] == pytest.approx(wmax / 19.99)
    _declare(tr, 1.0, 1.2, "right")  # an earlier false alarm, cleared
    m = compute_metrics(build_record(cfg), tr, {})
    assert m["false_alarm"] is True and m["false_alarms"] == 1 and m["declarations"] == 2
    assert m["detection_delay"] == pytest.approx(0.5) and m["first_declaration_time"] == pytest.approx(1.0)


def test_false_alarm_active_at_the_onset_is_not_a_zero_delay() -> None:
    """Declared (wheel unknown) from 8 s to the end: the declaration began before the 10 s onset, so it is
    a false alarm, and the fault was never detected — not detected with a 0 s delay."""
    cfg = load_config("scenario2", {"duration": 20.0})
    tr = _trace(2000)
    _declare(tr, 8.0, 20.0, "unknown")
    m = compute_metrics(build_record(cfg), tr, {})
    assert m["false_alarm"] is True and m["false_alarms"] == 1
    assert m["detection_delay"] is None and m["missed_detection"] is True and m["missed_detections"] == 1
    assert m["onsets"][0]["declared_at_onset"] == "unknown"
    # the false alarm clears at 10.2 s and a new declaration starts at 10.6 s: that one is the detection
    tr["fault_detected"][(tr["t"] >= 10.2) & (tr["t"] < 10.6)] = 0.0
    tr["declared_wheel"][(tr["t"] >= 10.2) & (tr["t"] < 10.6)] = 0.0
    m = compute_metrics(build_record(cfg), tr, {})
    assert m["detection_delay"] == pytest.approx(0.6) and m["false_alarms"] == 1 and m["declarations"] == 2
    assert m["time_to_correct_isolation"] is None  # 'unknown' never isolates
    # a wrong-wheel false alarm that switches to the right wheel after the onset: detected then
    tr = _trace(2000)
    _declare(tr, 8.0, 10.3, "right")
    _declare(tr, 10.3, 20.0, "left")
    m = compute_metrics(build_record(cfg), tr, {})
    assert m["false_alarms"] == 1 and m["detection_delay"] == pytest.approx(0.3)
    assert m["time_to_correct_isolation"] == pytest.approx(0.3) and m["false_isolations"] == 0


def test_wrong_wheel_declarations_after_the_onset_are_false_isolations() -> None:
    cfg = load_config("scenario2", {"duration": 20.0})
    tr = _trace(2000)
    _declare(tr, 10.4, 11.0, "right")  # the healthy wheel
    _declare(tr, 11.0, 12.0, "both")   # names the healthy wheel too
    _declare(tr, 12.0, 13.0, "left")
    _declare(tr, 13.0, 14.0, "right")  # and back to the wrong one
    m = compute_metrics(build_record(cfg), tr, {})
    assert m["false_isolations"] == 3 and m["onsets"][0]["false_isolations"] == 3
    assert m["detection_delay"] == pytest.approx(0.4)  # 'right' is a declaration: the fault was detected
    assert m["time_to_correct_isolation"] == pytest.approx(2.0)
    assert m["isolation_correct_fraction"] == pytest.approx(0.1)  # 1 s of 10
    assert m["isolated_wheel"] is None and m["isolation_correct"] is False  # nothing declared at the end


def test_scenario3_reports_both_onsets() -> None:
    """Left at 5 s, right at 10 s: each onset has its own window and metrics."""
    cfg = load_config("scenario3", {"duration": 20.0})
    tr = _trace(2000)
    _declare(tr, 5.3, 10.7, "left")
    _declare(tr, 10.7, 20.0, "both")
    m = compute_metrics(build_record(cfg), tr, {})
    first, second = m["onsets"]
    assert (first["wheel"], first["time"], second["wheel"], second["time"]) == ("left", 5.0, "right", 10.0)
    assert first["detection_delay"] == pytest.approx(0.3) and first["time_to_correct_isolation"] == pytest.approx(0.3)
    # the 'left' declaration active at 10 s does not detect the right fault; the change to 'both' does
    assert second["declared_at_onset"] == "left"
    assert second["detection_delay"] == pytest.approx(0.7) and second["time_to_correct_isolation"] == pytest.approx(0.7)
    assert m["detection_delay"] == pytest.approx(0.3) and m["true_fault_wheel"] == "both"
    assert m["false_isolations"] == 0 and m["missed_detections"] == 0 and m["isolation_correct"] is True
    # correct: 5.3..10 (left) and 10.7..20 (both) of the 15 s after the first onset
    assert m["isolation_correct_fraction"] == pytest.approx((4.7 + 9.3) / 15.0)
    # 'both' before the right onset names a healthy wheel: a false isolation in the first window
    _declare(tr, 6.0, 7.0, "both")
    m = compute_metrics(build_record(cfg), tr, {})
    assert m["onsets"][0]["false_isolations"] == 1 and m["onsets"][1]["false_isolations"] == 0


def test_fault_after_the_end_is_neither_detected_nor_missed() -> None:
    cfg = load_config("scenario2", {"duration": 8.0})
    tr = _trace(800)
    m = compute_metrics(build_record(cfg), tr, {})
    assert m["onsets"] == [{"wheel": "left", "time": 10.0, "status": "after end"}]
    assert m["missed_detection"] is None and m["detection_delay"] is None and m["missed_detections"] is None
    assert m["fault_onset_time"] is None and m["true_fault_wheel"] is None and m["isolation_correct"] is None
    assert m["false_alarm"] is False and "cross_track_max_after_fault" not in m


def test_no_fault_run_has_nothing_to_detect() -> None:
    cfg = load_config("scenario1", {"duration": 10.0})
    tr = _trace(1000)
    m = compute_metrics(build_record(cfg), tr, {"exceptions": 1})
    assert m["onsets"] == [] and m["missed_detection"] is None and m["isolation_correct_fraction"] is None
    assert m["false_alarm"] is False and m["exceptions"] == 1
    _declare(tr, 2.0, 3.0, "left")
    _declare(tr, 4.0, 5.0, "left")
    m = compute_metrics(build_record(cfg), tr, {})
    assert m["false_alarms"] == 2 and m["false_isolations"] is None


def test_missed_detection() -> None:
    cfg = load_config("scenario2", {"duration": 20.0})
    m = compute_metrics(build_record(cfg), _trace(2000), {})
    assert m["missed_detection"] is True and m["detection_delay"] is None


def test_after_the_fault_counts_from_a_servo_or_sensor_onset() -> None:
    """``servo_loss30`` has no tyre fault: its servo's onset (10 s) starts the recovery window (15 s on), the
    tracking after the fault and the lift-off transient (10-11 s), exactly as a tyre's onset would. A 0.4 m error
    before 15 s and 0.1 m after, a lift-off from 10.0 to 10.5 s: the recovered maximum is 0.1 m and the lift-off
    after the transient 0 s; without the servo's onset the run's metrics read 0.4 m from 5 s, and 0.5 s."""
    cfg = load_config("servo_loss30")
    tr = _trace(2000)
    t = tr["t"]
    tr["cross_track_error"][:] = np.where(t < 15.0, 0.4, 0.1)
    tr["plant_flags"] = np.where((t >= 10.0) & (t < 10.5), LIFTOFF, 0).astype(np.int64)
    m = compute_metrics(build_record(cfg), tr, {}, other_onsets=[10.0])
    assert m["contouring_max_recovered"] == pytest.approx(0.1)
    assert m["cross_track_max_recovered"] == pytest.approx(0.1)
    assert m["cross_track_max_after_fault"] == pytest.approx(0.4)
    assert m["liftoff_time_s"] == pytest.approx(0.5)
    assert m["liftoff_time_post_transient_s"] == 0.0
    assert m["reconfig_handover_delay"] is None  # the hand-over delay is the tyres' (none here)
    bare = compute_metrics(build_record(cfg), tr, {})
    assert bare["contouring_max_recovered"] == pytest.approx(0.4)
    assert bare["liftoff_time_post_transient_s"] == pytest.approx(0.5)
    assert "cross_track_max_recovered" not in bare


def test_a_run_of_servo_loss30_measures_its_recovery_from_the_servo_onset() -> None:
    """The run's own metrics (:func:`~ftc_mj.sim.run.run_metrics`) hand the servo's onset over: the recovered
    maximum is the largest error of the trace from 15 s (10 s + 5 s), not from 5 s."""
    cfg = load_config("servo_loss30", {"duration": 16.0, "controller.kind": "open-loop",
                                       "controller.open_loop_omega": [4.0, 4.2], "estimator.kind": "none"})
    res = simulate(cfg)
    t, ct = res.trace["t"], np.abs(res.trace["cross_track_error"])
    m = run_metrics(cfg, res)
    def rms(sel: np.ndarray) -> float:
        return float(np.sqrt(np.mean(ct[sel] ** 2)))

    assert m["contouring_max_recovered"] == float(np.nanmax(ct[t >= 15.0]))
    assert m["contouring_rms_recovered"] == pytest.approx(rms(t >= 15.0), rel=1e-12)
    assert rms(t >= 5.0) < 0.9 * rms(t >= 15.0)  # the open loop drifts off the path: the windows differ
