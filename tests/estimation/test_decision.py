"""Fault-decision layer: sigma and mode rules, dwell, isolation, severity, clears and events."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.config import RunConfig
from ftc_mj.estimation import FaultDecision, FilterOutput, Hypothesis
from ftc_mj.estimation.imm import BANK_4, BANK_5
from ftc_mj.wiring.decision import build_fault_decision


def out(RR: float, RL: float, sigma: float = 0.02, mu: list[float] | None = None,
        bank: tuple[Hypothesis, ...] | None = None) -> FilterOutput:
    """An estimator output; with ``mu``, an IMM's, declaring ``bank`` (default: the paper's bank of that size)."""
    P = np.diag([1.0, 1.0, 0.01, sigma**2, sigma**2])
    hyps = None if mu is None else bank if bank is not None else (BANK_4 if len(mu) == 4 else BANK_5)
    return FilterOutput(
        x=np.array([0.0, 0.0, 0.0, RR, RL]), P=P, innovation=np.zeros(1), S=np.eye(1), nis=0.0,
        speed_innovation=0.0, speed_innovation_std=0.5, mode_probs=None if mu is None else np.array(mu),
        hypotheses=hyps,
    )


def feed(dec: FaultDecision, t0: float, t1: float, o: FilterOutput, dt: float = 0.01):
    state = None
    for t in np.arange(t0, t1, dt):
        state = dec.update(float(round(t, 6)), o)
    return state


def test_sigma_rule_dwell_isolation_severity_and_clear() -> None:
    dec = build_fault_decision(RunConfig.model_validate({"estimator": {"decision": {"dwell": 0.5}}}))  # ukf → sigma
    s = feed(dec, 0.0, 5.0, out(2.0, 1.99))
    assert not s.detected and s.time is None and s.wheel is None and dec.events == []
    s = feed(dec, 5.0, 5.4, out(2.0, 1.0))  # shorter than the 0.5 s dwell
    assert not s.detected
    s = feed(dec, 5.4, 6.0, out(2.0, 1.0))  # the 5.0..5.4 episode still counts: continuous
    assert s.detected and s.wheel == "left" and abs(s.time - 5.5) < 1e-9
    assert abs(s.severity_L - 0.5) < 1e-12 and s.severity_R == 0.0 and s.active_mode is None
    s = feed(dec, 6.0, 7.0, out(1.2, 1.0))
    assert s.wheel == "both"
    s = feed(dec, 7.0, 8.0, out(2.0, 2.0))
    assert not s.detected and s.time is not None  # first declaration time is kept
    assert [e[1] for e in dec.events] == ["declare left", "change both", "clear"]
    assert dec.n_declarations == 1


def test_sigma_rule_needs_k_sigma_and_min_drop() -> None:
    dec = build_fault_decision(RunConfig())
    s = feed(dec, 0.0, 2.0, out(2.0, 1.5, sigma=0.3))  # 0.5 m drop but only 1.7 σ
    assert not s.detected
    s = feed(dec, 2.0, 4.0, out(2.0, 1.95, sigma=0.001))  # 50 σ but below min_drop 0.1 m
    assert not s.detected


def test_mode_rule_classes_threshold_and_radius_guard() -> None:
    cfg = RunConfig.model_validate({"estimator": {"kind": "imm-ukf", "imm_models": 5}})
    dec = build_fault_decision(cfg)
    # P(left) = 0.5 + 0.45 (50 % left + ramp) > 0.9, radius dropped → left
    s = feed(dec, 0.0, 1.0, out(2.0, 1.5, mu=[0.05, 0.0, 0.5, 0.0, 0.45]))
    assert s.detected and s.wheel == "left" and s.active_mode == 2
    dec = build_fault_decision(cfg)
    # ramp member dominant but the left radius has not dropped by min_drop: no declaration
    s = feed(dec, 0.0, 2.0, out(2.0, 1.97, mu=[0.02, 0.0, 0.0, 0.0, 0.98]))
    assert not s.detected and s.active_mode == 4
    dec = build_fault_decision(cfg)
    s = feed(dec, 0.0, 2.0, out(1.0, 2.0, mu=[0.15, 0.85, 0.0, 0.0, 0.0]))  # below threshold
    assert not s.detected
    # the sigma rule can be forced on an IMM output
    cfg_s = RunConfig.model_validate({"estimator": {"kind": "imm-ukf", "decision": {"rule": "sigma"}}})
    s = feed(build_fault_decision(cfg_s), 0.0, 1.0, out(1.0, 2.0, mu=[1.0, 0.0, 0.0, 0.0]))
    assert s.detected and s.wheel == "right"


def test_no_false_alarm_from_noise() -> None:
    rng = np.random.default_rng(0)
    dec = build_fault_decision(RunConfig())
    for k in range(3000):
        o = out(2.0 + 0.02 * rng.normal(), 2.0 + 0.02 * rng.normal(), sigma=0.02)
        s = dec.update(k * 0.01, o)
    assert not s.detected and dec.events == []


def test_sigma_rule_isolates_only_an_identified_split() -> None:
    """Speed only, constant wheel-rate ratio: the filter's covariance along the split the speed cannot
    see stays large; a departure is then declared as a fault of unknown wheel, not isolated."""
    dec = build_fault_decision(RunConfig())
    omega = np.array([5.0, 10.0])
    o = out(2.9, 0.55, sigma=0.3)
    w = omega / np.linalg.norm(omega)
    d = np.array([w[1], -w[0]])
    # covariance: tight along the observed combination w, 0.6 m along the split d
    o.P[3:5, 3:5] = 0.02**2 * np.outer(w, w) + 0.6**2 * np.outer(d, d)
    s = None
    for t in np.arange(0.0, 1.0, 0.01):
        s = dec.update(float(round(t, 6)), o, omega)
    assert s.detected and s.wheel == "unknown" and s.suspected and s.split_std == pytest.approx(0.6)
    # the same estimate with the split identified (yaw-rate sensing): isolated as the left wheel
    dec = build_fault_decision(RunConfig())
    o.P[3:5, 3:5] = 0.02**2 * np.eye(2)
    for t in np.arange(0.0, 1.0, 0.01):
        s = dec.update(float(round(t, 6)), o, omega)
    # 2.9 m is a 0.9 m departure too, but upwards: not a puncture, an anomaly
    assert s.detected and s.wheel == "left" and not s.suspected and s.anomaly
    dec = build_fault_decision(RunConfig())
    o = out(2.0, 1.0, sigma=0.02)
    for t in np.arange(0.0, 1.0, 0.01):
        s = dec.update(float(round(t, 6)), o, omega)
    assert s.wheel == "left" and not s.suspected


def test_isolated_wheel_changes_only_after_the_dwell() -> None:
    dec = build_fault_decision(RunConfig.model_validate({"estimator": {"decision": {"dwell": 0.3}}}))
    s = feed(dec, 0.0, 1.0, out(2.0, 1.0))
    assert s.wheel == "left"
    s = feed(dec, 1.0, 1.2, out(1.2, 1.0))  # a 0.2 s blip of the right estimate: no change
    assert s.wheel == "left"
    s = feed(dec, 1.2, 1.4, out(2.0, 1.0))
    s = feed(dec, 1.4, 2.0, out(1.2, 1.0))  # held for 0.6 s: changes after the 0.3 s dwell
    assert s.wheel == "both" and [e for e in dec.events if e[1] == "change both"][0][0] == pytest.approx(1.7)


def test_an_upward_radius_drift_is_an_anomaly_not_a_puncture() -> None:
    """A puncture makes a radius smaller: a radius estimate 0.5 m (25 σ) above nominal is never declared,
    with the wheel identified or not, and is reported as an anomaly; the same drift downwards is a fault."""
    dec = build_fault_decision(RunConfig())
    s = feed(dec, 0.0, 3.0, out(2.0, 2.5))
    assert not s.detected and s.anomaly and not s.suspected and dec.events == []
    # speed only, split unidentified: the observed combination moves up (both radii up) -> not a fault
    omega = np.array([5.0, 5.0])
    o = out(2.3, 2.3, sigma=0.5)
    o.P[3:5, 3:5] = 0.02**2 * np.full((2, 2), 0.5) + 0.6**2 * np.array([[0.5, -0.5], [-0.5, 0.5]])
    dec = build_fault_decision(RunConfig())
    for t in np.arange(0.0, 2.0, 0.01):
        s = dec.update(float(round(t, 6)), o, omega)
    assert not s.detected and not s.suspected
    # the same combination moved down: an evident fault of unknown wheel
    o.x[3:5] = [1.7, 1.7]
    dec = build_fault_decision(RunConfig())
    for t in np.arange(0.0, 2.0, 0.01):
        s = dec.update(float(round(t, 6)), o, omega)
    assert s.detected and s.wheel == "unknown"
    # reversing (w ∝ -ω, so smaller radii move w·(R - R0) up): larger radii are still no fault, smaller are
    for radii, fault in (([2.3, 2.3], False), ([1.7, 1.7], True)):
        o.x[3:5] = radii
        dec = build_fault_decision(RunConfig())
        for t in np.arange(0.0, 2.0, 0.01):
            s = dec.update(float(round(t, 6)), o, -omega)
        assert s.detected is fault
    s = feed(build_fault_decision(RunConfig()), 0.0, 3.0, out(2.0, 1.5))
    assert s.detected and s.wheel == "left" and not s.anomaly


def test_mode_rule_reads_the_declared_hypotheses_not_the_bank_size() -> None:
    """A 4-member bank of 30 % punctures in another order than the paper's, and a 3-member bank: the
    class probabilities come from each member's hypothesis. (Guessing the paper's bank from the size
    would read member 1 of the permuted bank, ``left 30 %``, as the right wheel.)"""
    bank4 = (Hypothesis("both 30%", 0.7, 0.7, False), Hypothesis("left 30%", 1.0, 0.7, False),
             Hypothesis("no fault", 1.0, 1.0, False), Hypothesis("right 30%", 0.7, 1.0, False))
    cfg = RunConfig.model_validate({"estimator": {"kind": "imm-ukf", "decision": {"rule": "mode"}}})
    s = feed(build_fault_decision(cfg), 0.0, 1.0, out(2.0, 1.4, mu=[0.02, 0.95, 0.02, 0.01], bank=bank4))
    assert s.detected and s.wheel == "left" and s.active_mode == 1
    s = feed(build_fault_decision(cfg), 0.0, 1.0, out(1.4, 1.4, mu=[0.93, 0.03, 0.02, 0.02], bank=bank4))
    assert s.detected and s.wheel == "both"
    bank3 = (Hypothesis("no fault", 1.0, 1.0, False), Hypothesis("right 30%", 0.7, 1.0, False),
             Hypothesis("left 30%", 1.0, 0.7, False))
    s = feed(build_fault_decision(cfg), 0.0, 1.0, out(1.4, 2.0, mu=[0.04, 0.95, 0.01], bank=bank3))
    assert s.detected and s.wheel == "right"
    s = feed(build_fault_decision(cfg), 0.0, 1.0, out(1.4, 1.4, mu=[0.98, 0.01, 0.01], bank=bank3))
    assert not s.detected  # no member hypothesises both wheels: that class has probability 0
    # several members of one class add up: two left severities of 0.5 each exceed the 0.9 threshold
    two_left = (Hypothesis("no fault", 1.0, 1.0, False), Hypothesis("left 30%", 1.0, 0.7, False),
                Hypothesis("left 60%", 1.0, 0.4, False))
    s = feed(build_fault_decision(cfg), 0.0, 1.0, out(2.0, 1.0, mu=[0.06, 0.47, 0.47], bank=two_left))
    assert s.detected and s.wheel == "left"


def test_mode_rule_refuses_mode_probabilities_without_hypotheses() -> None:
    cfg = RunConfig.model_validate({"estimator": {"kind": "imm-ukf", "decision": {"rule": "mode"}}})
    o = out(2.0, 1.0, mu=[0.1, 0.0, 0.9, 0.0])
    o.hypotheses = None
    with pytest.raises(ValueError, match="needs an estimator that declares the hypotheses"):
        build_fault_decision(cfg).update(0.0, o)
    # auto reads such an output with the sigma rule (it says nothing about what its modes mean)
    s = feed(build_fault_decision(RunConfig.model_validate({"estimator": {"kind": "imm-ukf"}})), 0.0, 1.0, o)
    assert s.detected and s.wheel == "left" and s.active_mode == 2
