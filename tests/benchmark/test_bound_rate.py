"""Lorden's bound of the benchmark's score is taken at the decision rule's no-fault alarm rate measured on the
MuJoCo plant (``ftc_mj/data/calibration/alarm_rates.json``, written by ``benchmarks/calibration.py``); the tyre
detectors' first alarm is scored beside the first declaration; the null model is the method's setting."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.benchmark.score import bound_arl0, tyre_alarm_delay
from ftc_mj.config import RunConfig
from ftc_mj.metrics.alarm_rates import RULE_SETTINGS, _table, measured_arl0, tyre_change_arl0
from ftc_mj.wiring.decision import build_change_detectors, physical_null_model


def _cfg(gyro: float | None, **decision: object) -> RunConfig:
    return RunConfig.model_validate({"sensors": {"yaw_rate_sigma": gyro}, "estimator": {"decision": decision}})


def test_the_shipped_rates_cover_both_sensor_sets_and_the_rules() -> None:
    """The data file holds the after-launch rates of cusum, glr and sigma with and without the gyro, measured
    with the default decision settings, each over 40 runs watched from 5 s to their last row (29.99 s): 999.6 s."""
    table = _table()["after_launch"]
    defaults = RunConfig().estimator.decision
    for sensors in ("speed", "speed+yaw"):
        for rule in ("cusum", "glr", "sigma"):
            row = table[sensors][rule]
            assert row["exposure"] >= 999.0
            assert row["settings"] == {k: float(getattr(defaults, k)) for k in RULE_SETTINGS}


def test_bound_at_the_measured_rate_of_the_run_rule_and_sensors() -> None:
    """``auto`` with the UKF is the sigma rule; cusum/glr are looked up by name; the gyro picks the sensor set;
    settings other than those measured (another ARL0) fall back to the configured ``arl0``."""
    settings = {k: float(getattr(RunConfig().estimator.decision, k)) for k in RULE_SETTINGS}
    for gyro in (None, 0.01):
        assert bound_arl0(_cfg(gyro)) == measured_arl0("sigma", gyro is not None, settings)
        for rule in ("cusum", "glr"):
            got = bound_arl0(_cfg(gyro, rule=rule))
            assert got == measured_arl0(rule, gyro is not None, settings) and got > 0.0
    assert bound_arl0(_cfg(0.01, rule="glr", arl0=500.0)) == 500.0
    assert measured_arl0("mode", True, settings) is None


def test_tyre_alarm_delay_is_the_first_tyre_alarm_from_the_onset() -> None:
    """The first row from the first onset on with either tyre detector's alarm up; an alarm that fell before
    the onset is not it; ``None`` without a fault, without the columns or without an alarm after the onset."""
    t = np.arange(0.0, 10.0, 0.01)
    R = np.where((t > 2.0) & (t < 2.5), 1.0, 0.0)  # an alarm before the onset, down again at it
    L = np.where(t >= 5.47, 1.0, 0.0)
    trace = {"t": t, "diag_alarm_tyre_R": R, "diag_alarm_tyre_L": L}
    faults = [{"onset": 5.0}]
    assert tyre_alarm_delay(trace, faults) == pytest.approx(0.47, abs=1e-9)
    assert tyre_alarm_delay(trace, []) is None
    assert tyre_alarm_delay({"t": t}, faults) is None
    assert tyre_alarm_delay({**trace, "diag_alarm_tyre_L": np.zeros_like(t)}, faults) is None


def test_null_model_is_the_method_setting_never_the_plant() -> None:
    """The detectors' null model follows ``estimator.decision.null_model`` whatever ``plant.kind`` is."""
    for plant in ("kinematic", "mujoco"):
        for null, physical in (("physical", True), ("ideal", False)):
            cfg = RunConfig.model_validate({"plant": {"kind": plant}, "estimator": {"decision": {"null_model": null}}})
            assert physical_null_model(cfg) is physical
            assert (build_change_detectors(cfg).null_model is not None) is physical


def test_the_bounds_table_gives_medians_with_intervals_and_counts_zero_bounds_apart() -> None:
    """Eleven draws of one method with ratios 1…11 (delay k·0.1 s over a bound of 0.1 s), one more with a zero
    bound: the median is 6 and its distribution-free 95 % interval for n = 11 the 2nd and 10th order statistics
    (P(B(11, ½) ≤ 1) = 0.6 % per tail); the zero bound is counted apart, not divided by. The radius column takes each
    draw's worse wheel (here the left wheel's 2·k)."""
    from ftc_mj.benchmark.report import bounds_table

    rows = [{"method": "m", "detection_delay": 0.1 * k, "tyre_alarm_delay": None, "lorden_delay_bound": 0.1,
             "radius_error_R": 1.0 * k, "radius_pcrb_R": 1.0, "radius_error_L": 2.0 * k, "radius_pcrb_L": 1.0}
            for k in range(1, 12)]
    rows.append({"method": "m", "detection_delay": 0.3, "tyre_alarm_delay": None, "lorden_delay_bound": 0.0})
    cells = [c.strip() for c in bounds_table(rows, ["m"])[-1].strip("|").split("|")]
    assert cells == ["m", "11 (+1 with a zero bound)", "6 [2, 10]", "0", "—", "12 [4, 20]"]


def test_the_tyre_alarms_are_bounded_at_the_fast_detectors_measured_rate() -> None:
    """With the fast tyre detector (``diagnosis.tyre_change``) the tyre alarms' bound is taken at its own no-fault
    rate measured under drawn conditions, with or without the gyro; without it, or without a filter, at the
    decision rule's; with other threshold settings than those measured, at the configured ARL0."""
    from ftc_mj.benchmark.score import tyre_alarm_arl0

    for gyro in (None, 0.01):
        base = _cfg(gyro).model_dump(mode="json")
        off = RunConfig.model_validate({**base, "diagnosis": {"tyre_change": False}})
        on = RunConfig.model_validate({**base, "diagnosis": {"tyre_change": True}})
        settings = {k: float(getattr(on.estimator.decision, k)) for k in RULE_SETTINGS}
        assert tyre_alarm_arl0(on) == tyre_change_arl0(gyro is not None, settings) > 0.0
        other = RunConfig.model_validate({**on.model_dump(mode="json"), "estimator": {"decision": {"arl0": 500.0}}})
        assert tyre_alarm_arl0(other) == 500.0
        assert tyre_alarm_arl0(off) == bound_arl0(off) != tyre_alarm_arl0(on)
        no_filter = RunConfig.model_validate({**on.model_dump(mode="json"), "estimator": {"kind": "none"},
                                              "reconfiguration": {"policy": "none"}})
        assert tyre_alarm_arl0(no_filter) == bound_arl0(no_filter)
