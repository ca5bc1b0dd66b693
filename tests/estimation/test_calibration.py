"""Thresholds of the change detectors: the null innovations, Siegmund's ARL0, the log(ARL0) growth and the
threshold the factory calibrates and passes to the change rules."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ftc_mj.estimation.calibration import NullInnovations, null_threshold, siegmund_arl0
from ftc_mj.estimation.decision import ChangeRule
from ftc_mj.estimation.decision_factory import build_decision_rule, calibrated_threshold, nominal_point_of
from ftc_mj.registry import decision_rules
from tests.estimation.filters import decision_cfg


def test_null_innovations_are_white_under_the_filters_own_model_and_smaller_with_constant_radii() -> None:
    """With the filters' random-walk radius noise (σ 2 m/s · dt per step) as the truth, the nominal filter's
    whitened innovations are N(0, I): variance 1 and no lag-1 correlation (1e5 samples: standard errors
    0.0045 and 0.003, tolerances 0.02). With constant radii — the no-fault truth — the gyro channel's
    variance is a small fraction of 1 (S counts a radius random walk that is not there)."""
    cfg = decision_cfg("cusum", 0.01)
    point = nominal_point_of(cfg)
    q_own = (cfg.estimator.q_diffusion[3] / cfg.estimator.rate) ** 0.5
    for q in (q_own, 0.0):
        null = NullInnovations(point, 200, np.random.default_rng(4), q)
        E = np.array([null.next() for _ in range(500)])  # (steps, chains, channels)
        var = E.reshape(-1, 2).var(axis=0)
        lag1 = np.mean(E[1:] * E[:-1], axis=(0, 1)) / np.mean(E * E, axis=(0, 1))
        if q == q_own:
            assert np.all(np.abs(var - 1.0) < 0.02) and np.all(np.abs(lag1) < 0.015)
        else:
            assert var[1] < 0.2 and var[0] < 0.97


def test_cusum_calibration_reproduces_siegmund() -> None:
    """Speed only, all three hypotheses have the same signature (every drop lowers the speed), so the
    rule is one CUSUM; on N(0, 1) innovations (the filters' own model as the truth) its Monte-Carlo
    threshold must give Siegmund's ARL0. ±10 % (1σ) Monte-Carlo rate and a few % approximation error:
    the bound allows 30 %."""
    cfg = decision_cfg("cusum", None)
    q_own = (cfg.estimator.q_diffusion[3] / cfg.estimator.rate) ** 0.5
    arl0_steps = 5000
    h = null_threshold("cusum", nominal_point_of(cfg), 1.0, 50, arl0_steps, q_radius=q_own)
    assert 0.7 < siegmund_arl0(h, 1.0) / arl0_steps < 1.3


def test_threshold_grows_with_the_log_of_arl0() -> None:
    """Beyond the Monte-Carlo horizon the threshold grows as log(ARL0) (LLR units)."""
    h1 = calibrated_threshold(decision_cfg("cusum", None, arl0=200.0), "cusum")
    h2 = calibrated_threshold(decision_cfg("cusum", None, arl0=2000.0), "cusum")
    assert h2 - h1 == pytest.approx(math.log(10.0), abs=1e-12)


def test_change_rule_gets_its_threshold_from_the_factory() -> None:
    """The rule holds the threshold it is given; the factory calibrates it at the nominal point of the
    run's reference path (a line and a circle give different nominal points)."""
    assert ChangeRule("glr", 0.5, 7.25).threshold == 7.25
    cfg = decision_cfg("cusum", 0.01)
    rule = build_decision_rule(cfg)
    assert isinstance(rule, ChangeRule) and rule.threshold == calibrated_threshold(cfg, "cusum")
    line = cfg.model_copy(update={"reference": cfg.reference.model_copy(update={"kind": "line"})})
    assert nominal_point_of(line) != nominal_point_of(cfg)
    assert not decision_rules.get("cusum").legacy and decision_rules.get("cusum").meta["calibrate"] == "cusum"
