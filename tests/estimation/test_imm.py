"""IMM: against filterpy's IMMEstimator, a hand-computed 2-model cycle, the collapse of the literal
(paper) bank, and the hypothesis banks on the paper's fault scenarios (kinematic data, gyro)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from filterpy.kalman import IMMEstimator, JulierSigmaPoints, UnscentedKalmanFilter

from ftc_mj.config import RunConfig
from ftc_mj.estimation import IMM, Hypothesis, Measurement
from ftc_mj.estimation.imm import BANK_4, transition_matrix
from ftc_mj.model.kinematics import KinematicModel, inverse_rates
from ftc_mj.wiring.decision import build_fault_decision
from ftc_mj.wiring.estimation import setup_from_config
from tests.estimation.filters import make_filter
from tests.support.numpy_filters import assemble

DT = 0.01


def excited(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    m = KinematicModel(b=1.0, dt=DT)
    t = np.arange(n) * DT
    u = np.stack([5.1 + 0.8 * np.sin(0.7 * t), 4.9 + 0.8 * np.cos(0.5 * t)], axis=1)
    x = np.array([0.0, 0.0, 0.0, 2.0, 2.0])
    z = np.empty(n)
    for k in range(n):
        x = m.step(x, u[k])
        x[4] = 1.5 if k > 100 else 2.0
        z[k] = float(m.speed(x, u[k])) + 0.5 * rng.normal()
    return u, z


def test_imm_matches_filterpy_immestimator() -> None:
    """Where filterpy applies: UKF members with identical structure (the paper variant), inputs via a
    closure, speed only. Mode probabilities, member and combined estimates agree to round-off."""
    cfg = RunConfig()
    setup = setup_from_config(cfg)
    m = setup.model
    inputs = np.zeros(2)
    filters = []
    for h in BANK_4:
        f = UnscentedKalmanFilter(5, 1, DT, hx=lambda x: np.atleast_1d(m.speed(x, inputs)),
                                  fx=lambda x, dt: m.step(x, inputs, dt), points=JulierSigmaPoints(5, kappa=0.001))
        f.x = setup.x0.copy()
        f.x[3:5] = (h.frac_R * 2.0, h.frac_L * 2.0)
        f.P = setup.P0.copy()
        f.Q = setup.Q.copy()
        f.R = np.eye(1) * 0.25
        filters.append(f)
    Pi = transition_matrix(4, 0.97)
    ref = IMMEstimator(filters, np.full(4, 0.25), Pi)
    ours = make_filter("imm-ukf", cfg, variant="paper")
    u, z = excited(300)
    worst = {"mu": 0.0, "x": 0.0, "P": 0.0, "members": 0.0}
    for k in range(300):
        out = ours.step(u[k], Measurement(float(z[k])))
        inputs[:] = u[k]
        ref.predict()
        ref.update(np.array([z[k]]))
        worst["mu"] = max(worst["mu"], float(np.abs(out.mode_probs - ref.mu).max()))
        worst["x"] = max(worst["x"], float(np.abs(out.x - ref.x).max()))
        worst["P"] = max(worst["P"], float(np.abs(out.P - ref.P).max()))
        worst["members"] = max(worst["members"], max(float(np.abs(out.model_x[i] - f.x).max())
                                                     for i, f in enumerate(filters)))
    print("IMM vs filterpy IMMEstimator, max abs differences:", {k: f"{v:.1e}" for k, v in worst.items()})
    assert all(v < 1e-9 for v in worst.values())


def test_two_model_hand_computed_cycle() -> None:
    """Mixing, mode-probability update and combination for 2 models, computed by hand."""
    cfg = RunConfig()
    bank = (Hypothesis("a", 1.0, 1.0, False), Hypothesis("b", 1.0, 0.5, False))
    Pi = np.array([[0.9, 0.1], [0.2, 0.8]])
    imm = make_filter("imm-ukf", cfg, hypotheses=bank, transition=Pi, variant="paper")
    imm.mu = np.array([0.8, 0.2])
    X = np.array([[0.0, 0.0, 0.0, 2.0, 2.0], [1.0, 0.0, 0.0, 2.0, 1.0]])
    P = np.array([np.eye(5) * 0.1, np.eye(5) * 0.2])
    imm.X, imm.P = X.copy(), P.copy()
    ref = make_filter("imm-ukf", cfg, reference=True, hypotheses=bank, transition=Pi, variant="paper")
    ref.mu = imm.mu
    # step 1: c̄ = [0.8·0.9 + 0.2·0.2, 0.8·0.1 + 0.2·0.8] = [0.76, 0.24]
    cbar, omega = ref.mixing_probabilities()
    np.testing.assert_allclose(cbar, [0.76, 0.24], atol=1e-15)
    np.testing.assert_allclose(omega, [[0.72 / 0.76, 0.08 / 0.24], [0.04 / 0.76, 0.16 / 0.24]], atol=1e-15)
    # step 2: mixed means and covariances
    X0, P0 = ref.mix(X, P, omega)
    w00, w10 = 0.72 / 0.76, 0.04 / 0.76  # μ_{0|0}, μ_{1|0}
    np.testing.assert_allclose(X0[0], [w10, 0, 0, 2.0, w00 * 2 + w10 * 1], atol=1e-14)
    np.testing.assert_allclose(X0[1], [2 / 3, 0, 0, 2.0, 1 / 3 * 2 + 2 / 3 * 1], atol=1e-14)
    # x-x entry of model 0: Σ μ_{i|0} (P_i + (x_i - x⁰)²)
    e = w00 * (0.1 + w10**2) + w10 * (0.2 + (1 - w10) ** 2)
    assert math.isclose(P0[0, 0, 0], e, rel_tol=1e-13)
    # cross term x-R_L of model 0: Σ μ_{i|0} (x_i - x⁰)(R_L,i - R_L⁰)
    rl0 = w00 * 2 + w10
    e_xr = w00 * (0 - w10) * (2 - rl0) + w10 * (1 - w10) * (1 - rl0)
    assert math.isclose(P0[0, 0, 4], e_xr, rel_tol=1e-12)
    # steps 3-5 through a full step, checked against the member filters run by hand
    u = np.array([5.0, 5.0])
    z = 14.0
    out = imm.step(u, Measurement(z))
    core = ref.core
    Xp, Pp = core.predict(X0, P0, u)
    # the measurement update of each member and its Gaussian likelihood N(z; ẑ_j, S_j)
    res = core.update(Xp, Pp, u, assemble(imm.setup, Measurement(z)))
    lik = np.exp(-0.5 * res.y[:, 0] ** 2 / res.S[:, 0, 0]) / np.sqrt(2 * np.pi * res.S[:, 0, 0])
    mu = lik * cbar / np.sum(lik * cbar)
    np.testing.assert_allclose(out.mode_probs, mu, rtol=1e-12)
    x_comb = mu[0] * res.X[0] + mu[1] * res.X[1]
    np.testing.assert_allclose(out.x, x_comb, rtol=1e-12, atol=1e-15)  # y is a round-off zero
    d = res.X - x_comb
    P_comb = sum(mu[j] * (res.P[j] + np.outer(d[j], d[j])) for j in range(2))
    np.testing.assert_allclose(out.P, P_comb, rtol=1e-10, atol=1e-15)


@pytest.mark.parametrize("models", [4, 5])
def test_paper_variant_collapses_hypothesis_does_not(models: int) -> None:
    u, z = excited(1000)
    spreads = {}
    for variant in ("paper", "hypothesis"):
        cfg = RunConfig.model_validate({"estimator": {"kind": "imm-ukf", "imm_models": models,
                                                        "imm_variant": variant}})
        imm = make_filter("imm-ukf", cfg)
        for k in range(1000):
            out = imm.step(u[k], Measurement(float(z[k])))
        spread = float(np.ptp(out.model_x[:, 3:5], axis=0).max())
        spreads[variant] = (spread, out.mode_probs)
        print(f"{models} models, {variant}: radius spread across models after 1000 steps {spread:.2e}, "
              f"mode probs {np.round(out.mode_probs, 4)}")
    spread, mu = spreads["paper"]
    assert spread < 1e-6
    np.testing.assert_allclose(mu, 1.0 / models, atol=1e-6)
    spread, mu = spreads["hypothesis"]
    assert spread > 0.5
    assert np.ptp(mu) > 0.5


def circle_run(imm: IMM, left: list, right: list, n: int, seed: int = 2) -> tuple[np.ndarray, list]:
    """Circle at 10 m/s, 0.2 rad/s; piecewise-linear radius schedules like the scenarios; gyro on."""
    m = KinematicModel(b=1.0, dt=DT)
    rng = np.random.default_rng(seed)
    x = np.array([0.0, 0.0, 0.0, 2.0, 2.0])
    outs = []
    t = np.arange(1, n + 1) * DT
    for k in range(n):
        tk = k * DT
        x[3] = np.interp(tk, *zip(*right, strict=True)) if right else 2.0
        x[4] = np.interp(tk, *zip(*left, strict=True)) if left else 2.0
        u = np.array(inverse_rates(10.0, 0.2, x[3], x[4], 1.0))
        x = m.step(x, u)
        z = Measurement(float(m.speed(x, u)) + 0.5 * rng.normal(), float(m.yaw_rate(x, u)) + 0.01 * rng.normal())
        outs.append(imm.step(u, z))
    return t, outs


def test_scenario3_both_wheels() -> None:
    cfg = RunConfig.model_validate({"sensors": {"yaw_rate_sigma": 0.01}})
    imm = make_filter("imm-ukf", cfg)
    t, outs = circle_run(imm, left=[(5.0, 2.0), (5.0, 1.0)], right=[(10.0, 2.0), (10.0, 1.0)], n=1400)
    mu = np.array([o.mode_probs for o in outs])
    assert np.all(mu[(t > 6.0) & (t < 10.0), 2] > 0.9)
    assert np.all(mu[t > 11.0, 3] > 0.9)
    dec = build_fault_decision(cfg)
    final = [dec.update(float(tk), o) for tk, o in zip(t, outs, strict=True)][-1]
    print("scenario 3 events:", dec.events)
    assert [e[1] for e in dec.events] == ["declare left", "change both"]
    assert final.wheel == "both" and 5.0 < final.time < 6.0


def test_scenario4_ramp_needs_fifth_model() -> None:
    cfg = RunConfig.model_validate({"sensors": {"yaw_rate_sigma": 0.01},
                                    "estimator": {"kind": "imm-ukf", "imm_models": 5}})
    imm = make_filter("imm-ukf", cfg)
    ramp = [(10.0, 2.0), (29.0, 0.1)]
    t, outs = circle_run(imm, left=ramp, right=[], n=2500)
    mu = np.array([o.mode_probs for o in outs])
    x = np.array([o.x for o in outs])
    true_RL = np.interp(t - DT, *zip(*ramp, strict=True))
    err5 = np.abs(x[:, 4] - true_RL)[(t > 12.0)]
    ramp_share = mu[(t > 12.0) & (t < 25.0), 4].mean()
    print(f"5 models, ramp: mean P(ramp) over 12-25 s {ramp_share:.3f}, max |R_L error| after 12 s "
          f"{err5.max():.3f} m, mean {err5.mean():.4f} m")
    pre = (t > 1.0) & (t < 10.0)
    print(f"5 models, before the ramp: mean P(no fault) {mu[pre, 0].mean():.3f}, mean P(ramp) {mu[pre, 4].mean():.3f}")
    # a ramp that has not started and no fault explain a constant radius alike: they share probability
    assert np.all(mu[pre, 0] + mu[pre, 4] > 0.9)
    assert ramp_share > 0.8
    assert err5.mean() < 0.05
    dec = build_fault_decision(cfg)
    final = [dec.update(float(tk), o) for tk, o in zip(t, outs, strict=True)][-1]
    print("scenario 4 (5 models) events:", dec.events)
    assert final.wheel == "left" and 10.0 < final.time < 12.0
    assert [e[1] for e in dec.events] == ["declare left"]
    # the 4-model bank has no hypothesis for it: its combined estimate is worse
    imm4 = make_filter("imm-ukf", RunConfig.model_validate({"sensors": {"yaw_rate_sigma": 0.01}}))
    t, outs4 = circle_run(imm4, left=ramp, right=[], n=2500)
    err4 = np.abs(np.array([o.x[4] for o in outs4]) - true_RL)[t > 12.0]
    print(f"4 models, ramp: mean |R_L error| after 12 s {err4.mean():.3f} m")
    assert err4.mean() > 3 * err5.mean()
