"""Lorden's bound of the benchmark's score is taken at the decision rule's no-fault alarm rate measured on the
MuJoCo plant (``ftc_mj/data/calibration/alarm_rates.json``, written by ``benchmarks/calibration.py``)."""

from __future__ import annotations

from ftc_mj.benchmark.score import bound_arl0
from ftc_mj.config import RunConfig
from ftc_mj.metrics.alarm_rates import RULE_SETTINGS, _table, measured_arl0


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
