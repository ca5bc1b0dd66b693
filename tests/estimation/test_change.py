"""Change detectors (CUSUM, Willsky–Jones GLR): estimates, the live rules against their logged
statistics, and the first-alarm records that let a study sweep thresholds (calibration:
test_calibration.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ftc_mj.config import RunConfig
from ftc_mj.estimation import FaultDecision, FilterOutput, Measurement
from ftc_mj.estimation.imm import BANK_4
from ftc_mj.estimation.rule_statistics import sigma_isolation
from ftc_mj.metrics.fdi import first_alarm_records
from ftc_mj.model.kinematics import KinematicModel
from ftc_mj.wiring.decision import build_fault_decision
from tests.estimation.filters import decision_cfg, make_filter

ONSET = 300  # step of the puncture in the synthetic runs
DROP = 0.8  # m, left radius 2.0 -> 1.2


def _run(cfg: RunConfig, n: int = 500, seed: int = 1, after_first: int | None = None,
         drops: dict[int, tuple[int, float]] | None = None) -> tuple[list, FaultDecision]:
    """UKF + decision on the kinematic model with constant wheel rates (a 50 m circle at 10 m/s) and a left
    drop of ``DROP`` before step ``ONSET`` (or ``drops``: step -> (state index 3 = right / 4 = left, drop
    in m) applied before it); returns the decision states and the decision. The truth is the kinematic
    model, so the callers' detectors take it as their null model (``null_model = "ideal"``)."""
    drops = {ONSET: (4, DROP)} if drops is None else drops
    rng = np.random.default_rng(seed)
    m = KinematicModel(b=1.0, dt=0.01)
    u = np.array([5.1, 4.9])
    x = np.array([0.0, 0.0, 0.0, 2.0, 2.0])
    f, dec = make_filter("ukf", cfg), build_fault_decision(cfg)
    states = []
    for k in range(n):
        x = m.step(x, u)
        if k in drops:
            x[drops[k][0]] -= drops[k][1]
        z = Measurement(speed=float(m.speed(x, u)) + 0.5 * rng.normal(),
                        yaw_rate=None if cfg.sensors.yaw_rate_sigma is None
                        else float(m.yaw_rate(x, u)) + cfg.sensors.yaw_rate_sigma * rng.normal())
        states.append(dec.update(round(k * 0.01, 6), f.step(u, z), u, z))
        if after_first is not None and dec.first_time is not None and k >= round(dec.first_time / 0.01) + after_first:
            break  # stopped ``after_first`` steps after the first declaration
    return states, dec


@pytest.mark.parametrize("gyro", [0.01, None])
def test_glr_estimates_onset_size_and_wheel(gyro: float | None) -> None:
    """A 0.8 m drop of the left radius: the GLR alarms within 3 steps (the drop is 4σ of speed noise in one
    step, the gyro sees it at 30σ) and the rule declares when that alarm has settled (half the GLR window
    later; the estimated drop, 0.8 m, confirms it). At the declaration the onset estimate is within 2 steps
    of the truth and the size estimate ``ν̂ = D/C`` (σ ``1/√C``) within 3σ. With the gyro the leading
    hypothesis is the left wheel and it is isolated; with speed only the hypotheses' signatures are
    collinear: the wheel stays unknown and only the drop's effect on the speed is identified — the leading
    hypothesis (whichever leads by round-off) must explain the left drop's ``0.8 ω_L / 2`` through its own
    ``|H f|``."""
    states, dec = _run(decision_cfg("glr", gyro, null_model="ideal"), after_first=0)  # stopped at the declaration
    g = np.array([s.statistics["glr_stat"] for s in states])
    alarm = int(np.argmax(g >= dec.threshold))
    assert ONSET <= alarm <= ONSET + 3
    settle = round(dec.rule_impl.detectors.settle_time / 0.01)
    check = len(states) - 1
    assert check == alarm + settle and states[check].detected
    assert not any(s.detected for s in states[:check])
    assert dec.rule_impl.alarms[0][0] == pytest.approx(alarm * 0.01)
    s = states[check].statistics
    assert abs(s["glr_onset"] - ONSET * 0.01) <= 0.02 + 1e-9
    assert states[check].wheel == ("left" if gyro else "unknown")
    glr = dec.statistics.detectors.glr
    hyp, nu, _ = glr.estimate()
    slot, h = divmod(int(glr.best_index[0]), 3)
    sigma_nu = 1.0 / math.sqrt(glr.C[slot, h])
    speed_effect = {"right": 5.1 / 2, "left": 4.9 / 2, "both": (5.1 + 4.9) / 2 / math.sqrt(2)}
    if gyro:
        assert hyp == "left"
    assert abs(nu * speed_effect[hyp] - DROP * speed_effect["left"]) <= 3 * sigma_nu * speed_effect[hyp]


@pytest.mark.parametrize("rule", ["cusum", "glr"])
def test_change_rule_alarms_at_the_first_crossing_of_its_logged_statistic(rule: str) -> None:
    """The live rule and the sweep agree: the rule's first alarm is the first step whose logged statistic
    reaches the calibrated threshold; it declares when that alarm has settled, and stays declared."""
    states, dec = _run(decision_cfg(rule, 0.01, null_model="ideal"))
    g = np.array([s.statistics[f"{rule}_stat"] for s in states])
    alarm = int(np.argmax(g >= dec.threshold))
    assert dec.rule_impl.alarms[0][0] == pytest.approx(alarm * 0.01)
    first = next(k for k, s in enumerate(states) if s.detected)
    assert first == alarm + round(dec.rule_impl.detectors.settle_time / 0.01)
    assert all(s.detected for s in states[first:])  # latched


def _out(RR: float, RL: float, sigma: float, mu: list[float] | None = None) -> FilterOutput:
    P = np.diag([1.0, 1.0, 0.01, sigma**2, sigma**2])
    return FilterOutput(x=np.array([0.0, 0.0, 0.0, RR, RL]), P=P, innovation=np.zeros(1), S=np.eye(1), nis=0.0,
                        speed_innovation=0.0, speed_innovation_std=0.5,
                        mode_probs=None if mu is None else np.array(mu), hypotheses=None if mu is None else BANK_4)


def test_sigma_and_mode_statistics_reproduce_the_live_rules() -> None:
    """A slowly falling left radius (sigma rule) and a rising left-class probability (mode rule): the first
    declaration is the first step whose windowed statistic exceeds ``k_sigma`` / ``mode_threshold``."""
    n = 300
    RL = np.linspace(2.0, 1.4, n)
    p_left = np.minimum(np.linspace(0, 1.5, n), 1.0)
    for rule, outs, thr in (
        ("sigma", [_out(2.0, r, 0.1) for r in RL], 3.0),
        ("mode", [_out(2.0, r, 0.05, [1 - p, 0.0, p, 0.0]) for r, p in zip(RL, p_left, strict=True)], 0.9),
    ):
        cfg = RunConfig.model_validate({"estimator": {"kind": "imm-ukf" if rule == "mode" else "ukf",
                                                      "decision": {"rule": rule, "statistics": True}}})
        dec = build_fault_decision(cfg)
        states = [dec.update(round(k * 0.01, 6), o, np.array([5.1, 4.9])) for k, o in enumerate(outs)]
        first = next(k for k, s in enumerate(states) if s.detected)
        g = np.array([s.statistics[f"{rule}_stat"] for s in states])
        assert first == int(np.argmax(g > thr)), rule
        assert states[first].wheel == "left"  # sigma: split σ 0.1 m ≤ max_split_sigma, identified


def test_first_alarm_records_give_the_first_alarm_of_every_threshold() -> None:
    """The records of the running maximum — few, strictly increasing — give, for any threshold, the same first
    alarm (time and wheel) as scanning the whole trace."""
    rng = np.random.default_rng(5)
    n = 2000
    g = np.abs(np.cumsum(rng.standard_normal(n))) * 0.1
    code = rng.integers(0, 5, n).astype(float)
    trace = {"t": np.arange(n) * 0.01, "glr_stat": g, "glr_wheel": code}
    rec = np.array(first_alarm_records(trace, "glr", 0.15))
    assert np.all(np.diff(rec[:, 1]) > 0) and len(rec) < n // 10  # only the running maximum's records
    for h in rng.uniform(0.0, g.max(), 50):
        k = int(np.argmax(g >= h))
        j = int(np.argmax(rec[:, 1] >= h))
        assert rec[j, 0] == trace["t"][k] and rec[j, 2] == code[k]


def test_sigma_isolation_at_a_threshold() -> None:
    assert sigma_isolation(0.0, 5.0, True, 3.0) == "left"
    assert sigma_isolation(4.0, 5.0, True, 3.0) == "both"
    assert sigma_isolation(4.0, 5.0, True, 4.5) == "left"
    assert sigma_isolation(0.0, 5.0, False, 3.0) == "unknown"


def test_glr_declares_two_punctures_with_their_wheels() -> None:
    """Scenario 3's pattern on the kinematic model with the gyro: left 2 → 1.2 m before step 300, right
    2 → 1.2 m before step 700. The GLR alarms within 3 steps of the first, declares the left wheel when the
    alarm has settled (25 steps later), re-anchors its residual generator on the estimated jump (within
    3σ of 0.8 m; σ = 1/√C) and declares ``both`` after the second (a wheel change waits the decision
    dwell, 0.5 s): the detectors restart after each change."""
    wheels, dec = _wheels_after_drops({ONSET: (4, DROP), 700: (3, DROP)}, seed=2)
    first = wheels.index("left")
    assert ONSET + 25 <= first <= ONSET + 28 and set(wheels[:first]) == {None}
    assert set(wheels[first:700]) == {"left"}
    assert "both" in wheels[700:790] and wheels[-1] == "both"  # 0.25 s settling + 0.5 s dwell
    rule = dec.rule_impl
    for (_, wheel, drop, _), truth in zip(rule.alarms, ("left", "right"), strict=True):
        assert wheel == truth and abs(drop - DROP) < 0.1


def test_a_position_fix_without_speed_and_gyro_is_not_read_as_speed_and_gyro() -> None:
    """With speed, gyro and position fixes configured, a step whose speed and gyro dropped out carries
    two channels (x, y), as a step with speed and gyro does: the detectors skip it rather than whiten it
    with the speed/gyro Jacobian and noise. The same innovation with its channels named speed and gyro
    is used."""
    from ftc_mj.estimation.change import linearise_step
    from ftc_mj.estimation.kernels.layout import POS_X, POS_Y, SPEED, YAW
    from ftc_mj.wiring.estimation import setup_from_config

    setup = setup_from_config(RunConfig.model_validate({"sensors": {"yaw_rate_sigma": 0.01, "position_sigma": 1.0}}))
    x, u = np.array([0.0, 0.0, 0.0, 2.0, 2.0]), np.array([5.0, 5.0])
    y, S = np.array([0.1, -0.2]), np.diag([1.0, 2.0])
    assert linearise_step(setup, x, setup.P0, y, S, u, (POS_X, POS_Y)) is None
    assert linearise_step(setup, x, setup.P0, y, S, u, (SPEED, YAW)) is not None
    assert linearise_step(setup, x, setup.P0, y, S, u) is not None  # callers that do not know the channels


def _wheels_after_drops(drops: dict[int, tuple[int, float]], n: int = 1000,
                        seed: int = 3) -> tuple[list, FaultDecision]:
    """The GLR rule's declared wheel at each step of :func:`_run` with the gyro (σ 0.01 rad/s)."""
    states, dec = _run(decision_cfg("glr", 0.01, null_model="ideal"), n=n, seed=seed, drops=drops)
    return [s.wheel for s in states], dec


def test_an_alarm_smaller_than_min_drop_is_not_declared() -> None:
    """A 0.06 m left drop moves the yaw rate by 0.06 · 4.9 / 1 m = 0.29 rad/s (29σ of the gyro): the GLR
    alarms at once and sizes it (σ of the size ≈ 1 mm), but 0.06 m is below ``min_drop`` (0.1 m): the alarm
    re-anchors the generator and nothing is declared. A second 0.06 m drop 1.5 s later makes 0.12 m, but
    as a drift slower than a GLR window (0.5 s), not an abrupt change: still nothing."""
    wheels, dec = _wheels_after_drops({ONSET: (4, 0.06), ONSET + 150: (4, 0.06)}, n=700)
    assert set(wheels) == {None}
    sizes = [drop for _, wheel, drop, _ in dec.rule_impl.alarms if wheel == "left"]
    assert len(sizes) >= 2 and all(abs(d - 0.06) < 0.01 for d in sizes[:2])


def test_drops_within_a_glr_window_add_up_to_a_declaration() -> None:
    """Two 0.06 m left drops 0.3 s apart (a puncture reaching its size over several steps, as on the
    physical plant): each alarm is below ``min_drop`` but the two, within one GLR window (0.5 s), sum to
    0.12 m: the left wheel is declared when the second settles."""
    wheels, _ = _wheels_after_drops({ONSET: (4, 0.06), ONSET + 30: (4, 0.06)}, n=450)
    first = wheels.index("left")
    assert ONSET + 30 + 25 <= first <= ONSET + 30 + 28 and set(wheels[:first]) == {None}


def test_a_small_alarm_does_not_start_a_holdoff_that_masks_the_next_puncture() -> None:
    """Left 0.8 m before step 300 (declared), a 0.04 m right drop before step 600 (an alarm below
    ``min_drop``: the kind the physical plant's transients raise), right 0.8 m before step 700: the right
    puncture is booked and ``both`` declared within 3 + 25 settling steps + the 0.5 s wheel-change dwell.
    Only declared changes start the 2 s hold-off; the small alarm at 600 would otherwise mask 700."""
    wheels, _ = _wheels_after_drops({ONSET: (4, 0.8), 600: (3, 0.04), 700: (3, 0.8)})
    assert set(wheels[ONSET + 28:700]) == {"left"}
    assert "both" in wheels[700:790] and wheels[-1] == "both"
