"""Reconfiguration policies: what the controller's model is handed, and why.

The ``safe`` policy's rules are checked one by one against hand-made filter outputs and decisions;
the closed-loop behaviour (revert after an injected divergence) is in test_safe_in_the_loop.py.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from ftc_mj.config import load_config, run_context
from ftc_mj.context import RunContext
from ftc_mj.errors import BadInput
from ftc_mj.estimation.base import FilterOutput
from ftc_mj.estimation.decision import DecisionState
from ftc_mj.estimation.observability import radius_directions
from ftc_mj.reconfiguration import (
    DirectPolicy,
    ReconfigState,
    ReconfigurationPolicy,
    ReconfigurationSettings,
    SafePolicy,
    ScenarioWeighting,
)
from ftc_mj.wiring.reconfiguration import build_policy, build_scenario_weighting, resolved_reconfiguration

OMEGA = np.array([5.0, 5.0])
TRUTH = (2.0, 1.0)


def _out(rR: float, rL: float, sigma: float, nis: float = 1.0, corr: float = 0.0) -> FilterOutput:
    P = np.diag([0.1, 0.1, 0.01, sigma**2, sigma**2])
    P[3, 4] = P[4, 3] = corr * sigma**2
    return FilterOutput(x=np.array([0, 0, 0, rR, rL]), P=P, innovation=np.zeros(1), S=np.eye(1), nis=nis,
                        speed_innovation=0.0, speed_innovation_std=1.0)


def _dec(wheel: str | None) -> DecisionState:
    return DecisionState(detected=wheel is not None, time=None if wheel is None else 10.0, wheel=wheel,  # type: ignore[arg-type]
                         severity_R=0.0, severity_L=0.0)


def _fb(policy: str, **kw: object) -> ReconfigurationPolicy:
    oracle = {"oracle": True} if policy == "truth" else {}  # only an oracle run is told the true radii
    return build_policy(load_config("scenario2", {"reconfiguration.policy": policy, **oracle,
                                                    **{f"reconfiguration.{k}": v for k, v in kw.items()}}))


def _step(fb: ReconfigurationPolicy, t: float, out: FilterOutput, wheel: str | None, reset: bool = False) -> np.ndarray:
    fb.observe(out)
    return fb.radii(t, out, _dec(wheel), reset, OMEGA, TRUTH)


def test_feedback_alias_and_contradictions() -> None:
    assert load_config("scenario2").reconfiguration.policy == "safe"  # the default for new users
    assert load_config("scenario2", {"feedback": True}).reconfiguration.policy == "direct"
    assert load_config("scenario2", {"feedback": False}).reconfiguration.policy == "none"
    assert load_config("scenario2", {"feedback": True, "reconfiguration.policy": "safe"}).feedback
    with pytest.raises(BadInput, match=r"^feedback: false contradicts reconfiguration.policy"):
        load_config("scenario2", {"feedback": False, "reconfiguration.policy": "safe"})
    with pytest.raises(BadInput, match=r"^reconfiguration.policy: "):
        load_config("scenario2", {"reconfiguration.policy": "sometimes"})


def test_truth_policy_needs_the_oracle_flag() -> None:
    """The true radii reach a run only when it is declared an oracle; the flag stays out of a non-oracle
    run's identity (its run id is the one it had before the flag existed)."""
    with pytest.raises(BadInput, match=r"^oracle: reconfiguration.policy = 'truth'"):
        load_config("scenario2", {"reconfiguration.policy": "truth"})
    assert load_config("scenario2", {"reconfiguration.policy": "truth", "oracle": True}).oracle
    assert "oracle" not in load_config("scenario2").model_dump()
    assert load_config("scenario2", {"oracle": True}).model_dump()["oracle"] is True


def test_oracle_pose_is_an_oracle_setting() -> None:
    """``oracle_pose`` chooses an oracle's pose source only: without ``oracle = true`` a one-line error naming the
    field; at its default it stays out of the identity (the benchmark's oracle row keeps its run ids)."""
    with pytest.raises(BadInput, match=r"^oracle_pose: "):
        load_config("scenario2", {"oracle_pose": "sensors"})
    assert "oracle_pose" not in load_config("scenario2", {"oracle": True}).model_dump()
    assert load_config("scenario2", {"oracle": True, "oracle_pose": "sensors"}).model_dump()["oracle_pose"] == "sensors"


@pytest.mark.parametrize("source", ["truth", "sensors"])
def test_an_oracle_takes_its_pose_from_where_oracle_pose_says(source: str) -> None:
    """With the pose sensor feeding the controller (``sensors.pose_source = "sensor"``), an oracle's controller gets
    the true pose (``oracle_pose = "truth"``) or the filter's estimate, as a method's does (``"sensors"``); the
    two differ after the first fix (σ 0.05 m), so the test tells them apart."""
    from ftc_mj.sim.loop import ClosedLoop

    cfg = load_config("scenario1", {"duration": 0.2, "plant.kind": "kinematic", "controller.kind": "open-loop",
                                    "sensors.position_sigma": 0.05, "sensors.position_rate": 10.0,
                                    "sensors.pose_source": "sensor", "oracle": True, "oracle_pose": source})
    loop = ClosedLoop(cfg)
    sample = loop.measure(0)
    assert loop.out is not None and not np.array_equal(loop.out.x[:3], sample.reading.pose)
    expected = sample.reading.pose if source == "truth" else loop.out.x[:3]
    np.testing.assert_array_equal(loop.controller_pose(sample.reading), expected)


def test_none_direct_truth() -> None:
    o = _out(2.1, 1.0, 0.01)
    np.testing.assert_array_equal(_fb("none").radii(0.0, o, _dec("left"), False, OMEGA, TRUTH), [2.0, 2.0])
    np.testing.assert_array_equal(_fb("truth").radii(0.0, o, None, False, OMEGA, TRUTH), TRUTH)
    fb = _fb("direct")
    np.testing.assert_array_equal(fb.radii(0.0, o, None, False, OMEGA, TRUTH), [2.1, 1.0])
    floor = load_config("scenario2").estimator.min_radius
    np.testing.assert_array_equal(fb.radii(0.1, _out(2.1, -0.3, 0.5), None, False, OMEGA, TRUTH), [2.1, floor])
    # a non-finite estimate keeps the previous radii
    np.testing.assert_array_equal(fb.radii(0.2, _out(np.nan, 1.0, 0.5), None, False, OMEGA, TRUTH), [2.1, floor])


def test_safe_waits_for_an_isolated_and_identified_fault() -> None:
    fb = _fb("safe")
    # no declaration: nominal, whatever the estimate
    np.testing.assert_array_equal(_step(fb, 0.0, _out(2.0, 1.0, 0.01), None), [2.0, 2.0])
    assert fb.state == ReconfigState.NOMINAL
    # declared, wheel unknown: hold the radii in use
    np.testing.assert_array_equal(_step(fb, 0.1, _out(2.0, 1.0, 0.01), "unknown"), [2.0, 2.0])
    assert fb.state == ReconfigState.HOLD
    # isolated but uncertain: still held
    np.testing.assert_array_equal(_step(fb, 0.2, _out(2.0, 1.0, 0.5), "left"), [2.0, 2.0])
    # small marginal σ but strongly anti-correlated radii = a large σ along the unobservable split
    o = _out(2.0, 1.0, 0.09, corr=-0.95)
    assert radius_directions(o.P, OMEGA).split_std > 0.1 >= np.sqrt(o.P[4, 4])
    np.testing.assert_array_equal(_step(fb, 0.3, o, "left"), [2.0, 2.0])
    assert fb.state == ReconfigState.HOLD
    assert [e.text.split(":")[1].strip()[:9] for e in fb.events] == ["wheel not", "radii not"]


def test_safe_hands_over_only_the_isolated_wheel_clamped_and_rate_limited() -> None:
    fb = _fb("safe", max_rate=1.0)
    step = 1.0 / load_config("scenario2").controller.rate
    r = _step(fb, 0.0, _out(1.9, 1.0, 0.01), "left")  # right estimate 1.9: not isolated, stays nominal
    np.testing.assert_allclose(r, [2.0, 2.0 - step])
    assert fb.state == ReconfigState.HANDED and "hand-over (left)" in fb.events[-1].text
    for k in range(1, 40):
        r = _step(fb, 0.1 * k, _out(1.9, 1.0, 0.01), "left")
    np.testing.assert_allclose(r, [2.0, 1.0])
    # estimates beyond the physical bounds are clamped to [min_radius, nominal]
    fb = _fb("safe", max_rate=100.0)
    np.testing.assert_allclose(_step(fb, 0.0, _out(2.6, -0.4, 0.01), "both"), [2.0, 0.05])


def test_safe_reverts_to_last_trusted_on_divergence_and_to_nominal_when_withdrawn() -> None:
    fb = _fb("safe", max_rate=100.0, trust_lag=1.0)
    for k in range(30):  # 0 .. 2.9 s: handed over at 1.0 m
        _step(fb, 0.1 * k, _out(2.0, 1.0, 0.01), "left")
    for k in range(30, 40):  # 3.0 .. 3.9 s: the estimate drifts to 0.5 m (still "consistent")
        _step(fb, 0.1 * k, _out(2.0, 0.5, 0.01), "left")
    # the filter resets at 3.95 s: back to the radii trusted ≥ 1 s earlier (at 2.9 s: 1.0 m), not the
    # drifted ones it accepted just before the trouble showed
    r = _step(fb, 3.95, _out(2.0, 0.5, 0.01), "left", reset=True)
    assert fb.state == ReconfigState.REVERTED
    np.testing.assert_allclose(r, [2.0, 1.0])
    assert fb.events[-1].level == "error" and "filter reset" in fb.events[-1].text
    # inconsistent innovations (mean NIS per measurement over the window above the bound): revert too
    fb2 = _fb("safe", max_rate=100.0)
    for k in range(20):
        _step(fb2, 0.1 * k, _out(2.0, 1.0, 0.01), "left")
    for _ in range(100):
        fb2.observe(_out(2.0, 0.3, 0.01, nis=50.0))
    r = fb2.radii(3.0, _out(2.0, 0.3, 0.01, nis=50.0), _dec("left"), False, OMEGA, TRUTH)
    assert fb2.state == ReconfigState.REVERTED and "inconsistent innovations" in fb2.events[-1].text
    np.testing.assert_allclose(r, [2.0, 1.0])
    # the decision is withdrawn: back to nominal
    r = _step(fb2, 3.1, _out(2.0, 2.0, 0.01), None)
    np.testing.assert_allclose(r, [2.0, 2.0])
    assert "withdrawn" in fb2.events[-1].text


@given(p11=st.floats(1e-6, 1.0), p22=st.floats(1e-6, 1.0), rho=st.floats(-0.99, 0.99),
       wR=st.floats(-20, 20), wL=st.floats(-20, 20))
def test_radius_directions_split_is_what_the_speed_cannot_see(p11: float, p22: float, rho: float,
                                                                wR: float, wL: float) -> None:
    P = np.zeros((5, 5))
    P[3, 3], P[4, 4] = p11, p22
    P[3, 4] = P[4, 3] = rho * np.sqrt(p11 * p22)
    d = radius_directions(P, np.array([wR, wL]))
    H = np.array([wR, wL]) / 2.0  # ∂V/∂[R_R, R_L]
    assume(np.linalg.norm(H) > 1e-3)  # a (nearly) stopped robot uses the documented equal-rate convention
    assert abs(np.dot(d.d, H)) <= 1e-9 * max(1.0, np.linalg.norm(H))  # the split is unseen by the speed
    assert abs(np.dot(d.w, d.d)) < 1e-12 and abs(np.hypot(*d.w) - 1.0) < 1e-12
    # an orthonormal change of basis keeps the total variance
    assert d.sum_std**2 + d.split_std**2 == pytest.approx(p11 + p22, rel=1e-9)


def test_safe_lets_a_handed_over_radius_grow_only_slowly_but_falls_and_reverts_fast() -> None:
    """A puncture does not re-inflate: an isolated wheel's model radius climbs by at most
    ``max_growth_rate`` per second while it may fall at ``max_rate``; a wheel the decision stops
    isolating, and a withdrawn decision, return to nominal at the full rate."""
    rate = load_config("scenario2").controller.rate
    fb = _fb("safe", max_rate=10.0, max_growth_rate=0.5)
    np.testing.assert_allclose(_step(fb, 0.0, _out(2.0, 1.0, 0.01), "left"), [2.0, 1.0])  # falls 1 m at once
    r = _step(fb, 0.1, _out(2.0, 1.8, 0.01), "left")  # the estimate runs back up by 0.8 m
    np.testing.assert_allclose(r, [2.0, 1.0 + 0.5 / rate])
    assert fb.state == ReconfigState.HANDED
    np.testing.assert_allclose(_step(fb, 0.2, _out(2.0, 0.9, 0.01), "left"), [2.0, 0.9])  # and down again at once
    # the decision now isolates the right wheel only: the left returns to nominal at the full rate
    np.testing.assert_allclose(_step(fb, 0.3, _out(1.0, 0.9, 0.01), "right"), [1.0, 1.9])
    # withdrawn: nominal at the full rate
    np.testing.assert_allclose(_step(fb, 0.4, _out(1.0, 2.0, 0.01), None), [2.0, 2.0])


def test_safe_reverts_to_the_radius_in_use_not_to_a_target_the_growth_limit_held_back() -> None:
    """After a hand-over at 1.0 m the estimate climbs to 1.8 m; the growth limit (0.05 m/s) lets the
    model radius reach only 1.1 m by t = 2 s. A filter reset at t = 3 s reverts to the radius the
    controller was using ≥ ``trust_lag`` (1 s) earlier — 1.1 m — not to the 1.8 m estimate the limit
    refused."""
    rate = load_config("scenario2").controller.rate
    fb = _fb("safe", max_rate=10.0, max_growth_rate=0.05, trust_lag=1.0)
    np.testing.assert_allclose(_step(fb, 0.0, _out(2.0, 1.0, 0.01), "left"), [2.0, 1.0])
    in_use = {}
    for k in range(1, 30):
        in_use[k] = _step(fb, k / rate, _out(2.0, 1.8, 0.01), "left")[1]
    assert in_use[20] == pytest.approx(1.0 + 20 * 0.05 / rate)
    r = _step(fb, 3.0, _out(2.0, 1.8, 0.01), "left", reset=True)
    assert fb.state == ReconfigState.REVERTED
    np.testing.assert_allclose(r, [2.0, in_use[20]])


def test_safe_conditions_the_isolated_radius_on_the_healthy_one_being_nominal() -> None:
    # a common scale error (ρ = 0.99): right estimate 1.9 (nominal 2.0), left 0.95; conditioned on R_R = 2.0
    # the left radius is 0.95 + 0.99 (2.0 − 1.9) = 1.049, not the raw 0.95 paired with the nominal right
    fb = _fb("safe", max_rate=100.0, condition_on_healthy=True)
    np.testing.assert_allclose(_step(fb, 0.0, _out(1.9, 0.95, 0.01, corr=0.99), "left"), [2.0, 1.049])
    fb = _fb("safe", max_rate=100.0, condition_on_healthy=True)  # uncorrelated: the raw estimate
    np.testing.assert_allclose(_step(fb, 0.0, _out(1.9, 0.95, 0.01), "left"), [2.0, 0.95])
    fb = _fb("safe", max_rate=100.0, condition_on_healthy=True)  # both isolated: both raw estimates
    np.testing.assert_allclose(_step(fb, 0.0, _out(1.9, 0.95, 0.01, corr=0.99), "both"), [1.9, 0.95])
    fb = _fb("safe", max_rate=100.0)  # auto (default) with the scenario's nmpc: off, the raw estimate
    np.testing.assert_allclose(_step(fb, 0.0, _out(1.9, 0.95, 0.01, corr=0.99), "left"), [2.0, 0.95])


@pytest.mark.parametrize(("controller", "setting", "on"), [
    ("pf-nmpc", "auto", True), ("nmpc", "auto", False), ("robust-nmpc", "auto", False), ("lmpc", "auto", False),
    ("nmpc", True, True), ("pf-nmpc", False, False)])
def test_condition_on_healthy_auto_is_on_with_the_path_following_nmpc(controller: str, setting: object,
                                                                      on: bool) -> None:
    """``auto`` resolves for the run's controller (on where it takes radius intervals); an explicit flag wins;
    a policy built straight from the unresolved section takes ``auto`` as off."""
    cfg = load_config("scenario2", {"controller.kind": controller, "reconfiguration.policy": "safe",
                                    "reconfiguration.condition_on_healthy": setting})
    assert resolved_reconfiguration(cfg).condition_on_healthy is on
    assert build_policy(cfg).condition_on_healthy is on
    assert SafePolicy(cfg.reconfiguration, run_context(cfg)).condition_on_healthy is (setting is True)
    with pytest.raises(BadInput, match=r"condition_on_healthy"):
        load_config("scenario2", {"reconfiguration.condition_on_healthy": "yes"})


def _context(**kw: object) -> RunContext:
    base = dict(seed=0, duration=10.0, physics_dt=1e-3, estimator_dt=0.01, controller_dt=1 / 49,
                nominal_radii=(2.0, 2.0), half_track=1.0, omega_max=50.0, initial_pose=(0.0, 0.0, 0.0),
                controller_rate=49.0, min_radius=0.05)
    return RunContext(**{**base, **kw})  # type: ignore[arg-type]


def test_policies_from_their_settings_and_the_run_context() -> None:
    """No run config: the ``[reconfiguration]`` settings and a :class:`RunContext`. The rate limits divide by
    the controller rate as configured (49 Hz, whose 1 / (1 / 49) is not 49 to the last bit); the floor is the
    context's ``min_radius``; the built-in factory gives the same policy as ``build_policy``."""
    fb = SafePolicy(ReconfigurationSettings(max_rate=1.0, max_growth_rate=0.5), _context())
    assert fb.max_step == 1.0 / 49.0 and fb.max_grow == 0.5 / 49.0 and fb._nis.maxlen == 100
    np.testing.assert_array_equal(fb.nominal, [2.0, 2.0])
    direct = DirectPolicy(ReconfigurationSettings(), _context(nominal_radii=(1.5, 1.5), min_radius=0.2))
    np.testing.assert_array_equal(direct.radii(0.0, _out(2.1, -0.3, 0.5), None, False, OMEGA, TRUTH), [2.1, 0.2])
    cfg = load_config("scenario2", {"reconfiguration.max_rate": 1.0})
    built, own = build_policy(cfg), SafePolicy(cfg.reconfiguration, run_context(cfg))
    assert (built.max_step, built.max_grow, built.floor) == (own.max_step, own.max_grow, own.floor)


def test_a_policy_of_the_old_contract_fails_in_one_line() -> None:
    class Old(ReconfigurationPolicy):
        def __init__(self, cfg: object) -> None:
            super().__init__(cfg)

        def radii(self, *args: object) -> np.ndarray:
            return self.nominal

    with pytest.raises(TypeError, match=r"^Old: ReconfigurationPolicy\(cfg\) is the old contract; take "
                                        r"\(settings, context\)") as ei:
        Old(load_config("scenario2"))
    assert "\n" not in str(ei.value)


def test_scenario_weighting_only_for_a_filtered_robust_nmpc() -> None:
    robust = {"controller.kind": "robust-nmpc", "controller.robust.weighting": "posterior"}
    assert build_scenario_weighting(load_config("scenario2")) is None
    assert build_scenario_weighting(load_config("scenario2", {"controller.kind": "robust-nmpc"})) is None  # fixed
    cfg = load_config("scenario2", robust)
    w = build_scenario_weighting(cfg)
    assert isinstance(w, ScenarioWeighting)
    np.testing.assert_array_equal(w.fractions, np.asarray(cfg.controller.robust.scenarios, dtype=float))
    assert w.weights(None, np.array([2.0, 2.0])) is None
    p = w.weights(_out(2.0, 1.0, 0.01), np.array([2.0, 2.0]))
    assert p is not None and p.sum() == pytest.approx(1.0)


def test_a_step_without_measurements_is_no_evidence_for_the_safe_policy() -> None:
    """A sensor dropout's predict-only step (no channel: empty innovation, NIS NaN, not rejected) leaves the
    safe policy's mean NIS as it was; a rejected measurement still counts as inconsistent (NIS/dim 1000)."""
    fb = _fb("safe")
    fb.observe(_out(2.0, 1.0, 0.01, nis=1.0))
    empty = FilterOutput(x=np.array([0, 0, 0, 2.0, 1.0]), P=np.eye(5), innovation=np.zeros(0), S=np.zeros((0, 0)),
                         nis=np.nan, speed_innovation=np.nan, speed_innovation_std=np.nan)
    for _ in range(50):
        fb.observe(empty)
    assert fb.nis_ratio == 1.0  # type: ignore[attr-defined]
    fb.observe(FilterOutput(x=empty.x, P=empty.P, innovation=np.zeros(0), S=empty.S, nis=np.nan,
                            speed_innovation=np.nan, speed_innovation_std=np.nan, rejected=True))
    assert fb.nis_ratio == pytest.approx(1001.0 / 2)  # type: ignore[attr-defined]


@pytest.mark.parametrize(("band", "lo", "hi"), [(4.0, -0.01, 0.01), (0.0, -0.024, -0.008)])
def test_safe_tracks_a_noisy_estimate_without_a_ratchet(band: float, lo: float, hi: float) -> None:
    """An isolated radius estimate 1.0 m with white noise of σ 0.03 m (the 10 Hz pose fixes' jolts without a gyro;
    posterior σ 0.05 m): within the noise band a fall is followed at ``max_growth_rate`` like a rise, so the radius
    in use is a symmetric rate-limited tracker and settles at the estimate's median (within 1 cm; over 30 noise
    seeds −0.01 ± 0.17 cm). With no band (``noise_band = 0``) every dip is taken at ``max_rate`` and, unless the next
    sample undoes it (``_rebound``), recovered at ``max_growth_rate``: the radius in use settles below the estimate,
    a ratchet whose offset is a yaw-rate bias of the controller's model — −1.60 ± 0.16 cm over 30 noise seeds (the
    bounds are ±5 σ; 3–8 cm before the rebound)."""
    rate = load_config("scenario2").controller.rate
    fb = _fb("safe", max_rate=10.0, max_growth_rate=0.05, noise_band=band)
    np.testing.assert_allclose(_step(fb, 0.0, _out(2.0, 1.0, 0.05), "left"), [2.0, 1.0])  # a fall beyond the band
    rng = np.random.default_rng(0)
    used = [_step(fb, k / rate, _out(2.0, 1.0 + 0.03 * rng.standard_normal(), 0.05), "left")[1]
            for k in range(1, 600)]
    assert lo <= float(np.mean(used[100:])) - 1.0 <= hi


@pytest.mark.parametrize(("window", "lo", "hi"), [(2.0, -0.03, 0.03), (0.0, 0.05, 0.25)])
def test_safe_follows_an_estimate_that_keeps_falling(window: float, lo: float, hi: float) -> None:
    """A tyre deflating at 0.1 m/s (a puncture ramp) seen through an estimate with white noise of σ 0.03 m at the
    controller's samples (posterior σ 0.05 m: a noise band of 0.2 m). The least-squares line over 2 s falls at
    0.1 ± 0.012 m/s (σ of its slope for that noise), beyond ``max_growth_rate`` (0.05 m/s) by 4 σ: the fall is
    followed at ``max_rate`` and, once the window is full, the radius in use is within the noise's σ of the true
    radius on average from 3 s on (measured 1.4 cm below: it takes the dips at once). Without the trend
    (``trend_window = 0``) it falls at 0.05 m/s inside the band and lags by 0.05 m/s × the time until a dip
    leaves the band (measured 6.6 cm)."""
    rate = load_config("scenario2").controller.rate
    fb = _fb("safe", max_rate=10.0, max_growth_rate=0.05, trend_window=window)
    rng = np.random.default_rng(1)
    true = [1.5 - 0.1 * k / rate for k in range(int(8 * rate))]
    used = [_step(fb, k / rate, _out(2.0, r + 0.03 * rng.standard_normal(), 0.05), "left")[1]
            for k, r in enumerate(true)]
    lag = np.asarray(used[int(3 * rate):]) - np.asarray(true[int(3 * rate):])
    assert lo <= float(np.mean(lag)) <= hi


def test_an_estimate_converging_after_a_step_is_no_trend() -> None:
    """A 0.5 m step of the left radius whose estimate converges with a 0.4 s time constant (falls at up to 1.25 m/s),
    with white noise of σ 0.03 m: the fall is faster than ``trend_max_rate`` (0.3 m/s) and then levels off, so the
    radius in use is exactly what it is without the trend (``trend_window = 0``) — the noise band governs, as it
    does a step's. With no ceiling on the trend the convergence is followed at ``max_rate`` and the sequences
    differ."""
    rate = load_config("scenario2").controller.rate
    rng = np.random.default_rng(2)
    est = [1.0 + 0.5 * np.exp(-max(k / rate - 3.0, 0.0) / 0.4) + 0.03 * rng.standard_normal()
           for k in range(int(10 * rate))]

    def used(**kw: float) -> list[float]:
        fb = _fb("safe", max_rate=10.0, max_growth_rate=0.05, **kw)
        return [float(_step(fb, k / rate, _out(2.0, r, 0.05), "left")[1]) for k, r in enumerate(est)]

    assert used(trend_window=2.0) == used(trend_window=0.0)
    assert used(trend_window=2.0, trend_max_rate=100.0) != used(trend_window=0.0)


def test_one_sample_dip_beyond_the_noise_band_is_undone_at_once() -> None:
    """An estimate that overshoots for one controller sample as it converges after a step (scenario 3 with the
    gyro, dev seed 0: 1.13, 0.95, 1.01 m for a 1.00 m tyre) is followed down at once, and when the next sample's
    estimate lies above the radius in use the fall is undone at ``max_rate`` as far as that estimate, never above
    the radius before the fall; a fall the next sample confirms stays, and a rise after it is growth-limited."""
    slow = 0.05 / load_config("scenario2").controller.rate  # max_growth_rate per sample (m): 0.005 m at 10 Hz
    fb = _fb("safe", max_rate=10.0, max_growth_rate=0.05)  # σ 0.02 m: a noise band of 0.08 m
    np.testing.assert_allclose(_step(fb, 0.0, _out(2.0, 1.13, 0.02), "left"), [2.0, 1.13])  # the first hand-over
    np.testing.assert_allclose(_step(fb, 0.1, _out(2.0, 0.95, 0.02), "left"), [2.0, 0.95])  # the dip, at once
    np.testing.assert_allclose(_step(fb, 0.2, _out(2.0, 1.01, 0.02), "left"), [2.0, 1.01])  # undone to the estimate
    np.testing.assert_allclose(_step(fb, 0.3, _out(2.0, 1.2, 0.02), "left"), [2.0, 1.01 + slow])  # a rise: slowly
    np.testing.assert_allclose(_step(fb, 0.4, _out(2.0, 0.8, 0.02), "left"), [2.0, 0.8])  # a fall, at once
    np.testing.assert_allclose(_step(fb, 0.5, _out(2.0, 0.79, 0.02), "left"), [2.0, 0.8 - slow])  # confirmed
    np.testing.assert_allclose(_step(fb, 0.6, _out(2.0, 1.5, 0.02), "left"), [2.0, 0.8])  # no rebound after it
    # the first hand-over (a fall from nominal) is the declaration's evidence: never undone this way
    fb = _fb("safe", max_rate=10.0, max_growth_rate=0.05)
    _step(fb, 0.0, _out(2.0, 1.0, 0.02), "left")
    np.testing.assert_allclose(_step(fb, 0.1, _out(2.0, 1.5, 0.02), "left"), [2.0, 1.0 + slow])


def test_safe_hands_a_fall_beyond_the_noise_band_over_at_once() -> None:
    """A fall of the estimate by more than ``noise_band`` σ (4 × 0.05 m) is a new fault size, not noise: it is
    handed over at ``max_rate``; one within the band follows at ``max_growth_rate``."""
    rate = load_config("scenario2").controller.rate
    fb = _fb("safe", max_rate=10.0, max_growth_rate=0.05)
    _step(fb, 0.0, _out(2.0, 1.0, 0.05), "left")
    np.testing.assert_allclose(_step(fb, 0.1, _out(2.0, 0.85, 0.05), "left"), [2.0, 1.0 - 0.05 / rate])
    np.testing.assert_allclose(_step(fb, 0.2, _out(2.0, 0.6, 0.05), "left"), [2.0, 0.6])
