"""EKF/UKF against filterpy 2.0.0 (to round-off), robustness to bad measurements, factory and API."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from filterpy.kalman import ExtendedKalmanFilter, JulierSigmaPoints, UnscentedKalmanFilter

from ftc_mj.config import RunConfig, run_context
from ftc_mj.estimation import EKF, IMM, UKF, FilterOutput, Measurement
from ftc_mj.estimation.setup import FilterSetup
from ftc_mj.model.kinematics import KinematicModel, casadi_to_numpy
from ftc_mj.registry import estimators
from ftc_mj.wiring.estimation import build_estimator
from tests.estimation.filters import excited_data, make_filter

N_STEPS = 400


def make_filterpy_ukf(setup: FilterSetup, dim_z: int) -> UnscentedKalmanFilter:
    m = setup.model

    def hx(x: np.ndarray, u: np.ndarray) -> np.ndarray:
        out = [float(m.speed(x, u))]
        if dim_z == 2:
            out.append(float(m.yaw_rate(x, u)))
        return np.array(out)

    f = UnscentedKalmanFilter(5, dim_z, setup.dt, hx=hx, fx=lambda x, dt, u: m.step(x, u, dt),
                              points=JulierSigmaPoints(5, kappa=0.001))
    f.x = setup.x0.copy()
    f.P = setup.P0.copy()
    f.Q = setup.Q.copy()
    R = [setup.speed_sigma**2] + ([setup.yaw_rate_sigma**2] if dim_z == 2 else [])
    f.R = np.diag(R)
    return f


@pytest.mark.parametrize("yaw", [None, 0.01])
def test_ukf_matches_filterpy(yaw: float | None) -> None:
    cfg = RunConfig.model_validate({"sensors": {"yaw_rate_sigma": yaw}})
    ours = make_filter("ukf", cfg)
    ref = make_filterpy_ukf(ours.setup, 1 if yaw is None else 2)
    u, zs, zy = excited_data(N_STEPS, yaw_sigma=yaw)
    worst_x = worst_p = worst_y = 0.0
    for k in range(N_STEPS):
        z = Measurement(float(zs[k]), float(zy[k]) if yaw else None)
        out = ours.step(u[k], z)
        ref.predict(u=u[k])
        ref.update(np.array([zs[k]] + ([zy[k]] if yaw else [])), u=u[k])
        worst_x = max(worst_x, float(np.abs(out.x - ref.x).max()))
        worst_p = max(worst_p, float(np.abs(out.P - ref.P).max()))
        worst_y = max(worst_y, float(np.abs(out.innovation - ref.y).max()), float(np.abs(out.S - ref.S).max()))
    print(f"UKF vs filterpy (yaw={yaw}): max |dx| {worst_x:.2e}, |dP| {worst_p:.2e}, |dy|,|dS| {worst_y:.2e}")
    assert worst_x < 1e-9 and worst_p < 1e-9 and worst_y < 1e-9
    assert ours.rejections == 0 and ours.resets == 0


class FilterpyEKF(ExtendedKalmanFilter):
    """filterpy's EKF with our Euler step and CasADi Jacobian (through CasADi's own Function call)."""

    def __init__(self, setup: FilterSetup, dim_z: int) -> None:
        super().__init__(dim_x=5, dim_z=dim_z)
        self.model = setup.model
        self.x = setup.x0.copy()
        self.P = setup.P0.copy()
        self.Q = setup.Q.copy()
        self.u = np.zeros(2)

    def predict_x(self, u: np.ndarray = 0) -> None:  # type: ignore[override]
        self.x = self.model.step(self.x, self.u)

    def step(self, u: np.ndarray, z: np.ndarray, R: np.ndarray) -> None:
        self.u = u
        self.F = self.model.step_jacobian(self.x, u)
        self.predict()
        nz = len(z)
        self.update(z, HJacobian=lambda x: self.model.measurement_jacobian(x, u)[:nz],
                    Hx=lambda x: np.array([float(self.model.speed(x, u)), float(self.model.yaw_rate(x, u))][:nz]),
                    R=R)


@pytest.mark.parametrize("yaw", [None, 0.01])
def test_ekf_matches_filterpy(yaw: float | None) -> None:
    cfg = RunConfig.model_validate({"sensors": {"yaw_rate_sigma": yaw}})
    ours = make_filter("ekf", cfg)
    ref = FilterpyEKF(ours.setup, 1 if yaw is None else 2)
    R = np.diag([0.25] + ([yaw**2] if yaw else []))
    u, zs, zy = excited_data(N_STEPS, yaw_sigma=yaw)
    worst = 0.0
    for k in range(N_STEPS):
        out = ours.step(u[k], Measurement(float(zs[k]), float(zy[k]) if yaw else None))
        ref.step(u[k], np.array([zs[k]] + ([zy[k]] if yaw else [])), R)
        worst = max(worst, float(np.abs(out.x - ref.x).max()), float(np.abs(out.P - ref.P).max()),
                    float(np.abs(out.innovation - ref.y).max()))
    print(f"EKF vs filterpy (yaw={yaw}): max abs difference {worst:.2e}")
    assert worst < 1e-9


def test_numpy_jacobians_are_casadi_ad() -> None:
    m = KinematicModel(b=1.3, dt=0.01)
    rng = np.random.default_rng(3)
    X = rng.normal(size=(6, 5)) + [0, 0, 0, 2, 2]
    U = rng.normal(size=(6, 2)) * 5
    F = casadi_to_numpy(m.casadi_step_jacobian())(X, U, 0.01)
    H = casadi_to_numpy(m.casadi_rates_jacobian())(X, U)
    for i in range(6):
        np.testing.assert_allclose(F[i], m.step_jacobian(X[i], U[i]), rtol=0, atol=1e-14)
        np.testing.assert_allclose(H[i], m.measurement_jacobian(X[i], U[i]), rtol=0, atol=1e-14)
    np.testing.assert_allclose(m.step_batch(X, U), m.step(X, U), rtol=0, atol=0)


@pytest.mark.parametrize("kind", ["ekf", "ukf", "imm-ekf", "imm-ukf"])
def test_bad_measurements_rejected_and_counted(kind: str) -> None:
    cfg = RunConfig.model_validate({"estimator": {"kind": kind}, "sensors": {"yaw_rate_sigma": 0.01,
                                                                             "position_sigma": 1.0}})
    f = build_estimator(cfg)
    assert f is not None
    u, zs, zy = excited_data(300, yaw_sigma=0.01)
    bad = {50: math.nan, 60: math.inf, 70: 1e6, 80: -math.inf}
    outs: list[FilterOutput] = []
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy warnings either
        for k in range(300):
            speed = bad.get(k, float(zs[k]))
            yaw = math.nan if k == 90 else float(zy[k])
            pos = np.array([math.nan, 0.0]) if k == 95 else None
            outs.append(f.step(u[k], Measurement(speed, yaw, pos)))
    flagged = [k for k, o in enumerate(outs) if o.rejected]
    assert flagged == [50, 60, 70, 80, 90, 95]
    assert f.rejections == 6 and f.resets == 0
    assert math.isnan(outs[50].speed_innovation)
    assert outs[70].nis > cfg.estimator.nis_gate
    for o in outs:
        assert np.all(np.isfinite(o.x)) and np.all(np.isfinite(o.P))
    # the filter carries on: radii still right at the end (R_L → 1 m by step 200)
    assert abs(outs[-1].x[3] - 2.0) < 0.2 and abs(outs[-1].x[4] - 1.0) < 0.2
    # non-finite wheel rates: the last good ones are used, nothing breaks
    o = f.step(np.array([math.nan, 1.0]), Measurement(float(zs[-1]), float(zy[-1])))
    assert np.all(np.isfinite(o.x))


@pytest.mark.parametrize("kind", ["ekf", "ukf"])
def test_divergence_resets(kind: str) -> None:
    cfg = RunConfig.model_validate({"estimator": {"divergence_dwell": 0.2}})
    f = make_filter(kind, cfg)
    u, zs, _ = excited_data(200)
    for k in range(50):
        f.step(u[k], Measurement(float(zs[k])))
    f.P = np.full((1, 5, 5), np.nan)  # corrupt the covariance: reset at the next step
    o = f.step(u[50], Measurement(float(zs[50])))
    assert o.reset and f.resets == 1 and np.all(np.isfinite(o.P))
    # persistent large speed errors (NIS between the divergence level and the gate) → reset
    f2 = make_filter(kind, cfg)
    resets = 0
    for k in range(100):
        o = f2.step(u[k], Measurement(float(zs[k]) + (40.0 * (-1) ** k if k >= 20 else 0.0)))
        resets += o.reset
    assert f2.resets >= 1 and resets == f2.resets
    assert np.all(np.isfinite(o.x))


def test_non_pd_covariance_is_repaired() -> None:
    f = make_filter("ukf", RunConfig())
    P = f.setup.P0.copy()
    P[3, 4] = P[4, 3] = 0.3  # |corr| > 1: indefinite
    f.P = P[None]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        o = f.step(np.array([5.0, 5.0]), Measurement(20.0))
    assert np.all(np.linalg.eigvalsh(o.P) > 0) and not o.reset


def test_factory_kinds() -> None:
    for kind, cls in (("ekf", EKF), ("ukf", UKF), ("imm-ekf", IMM), ("imm-ukf", IMM)):
        cfg = RunConfig.model_validate({"estimator": {"kind": kind}})
        assert isinstance(build_estimator(cfg), cls)
    assert build_estimator(RunConfig.model_validate({"estimator": {"kind": "none"}})) is None
    imm = build_estimator(RunConfig.model_validate({"estimator": {"kind": "imm-ekf", "imm_models": 5}}))
    assert isinstance(imm, IMM) and imm.member == "ekf" and len(imm.hypotheses) == 5


def test_initial_state_from_config() -> None:
    cfg = RunConfig.model_validate({"plant": {"initial_pose": [1.0, 2.0, 0.5]},
                                    "estimator": {"initial_radii": [1.8, 1.9]}})
    f = make_filter("ukf", cfg)
    np.testing.assert_array_equal(f.x, [1.0, 2.0, 0.5, 1.8, 1.9])
    np.testing.assert_allclose(np.diag(f.setup.Q), (np.array([5, 5, 0.1, 2, 2]) * 0.01) ** 2)
    np.testing.assert_allclose(np.diag(f.setup.P0), [0.25, 0.25, math.radians(1) ** 2, 0.25, 0.25])


@pytest.mark.parametrize("kind", ["ekf", "ukf", "imm-ekf", "imm-ukf"])
def test_position_fixes_bound_the_dead_reckoning(kind: str) -> None:
    """With speed only, x, y, psi are dead-reckoned and drift; 1 Hz position fixes (σ 1 m) bound them. The free
    radii's filters drift faster than their covariance says, so their χ² gate on the fixes rejects some (each
    streak ends after ``pose_gate_reacquire``, 2 s): ungated (``pose_gate = None``) they cut the error by > 5x,
    gated by > 3x."""
    m = KinematicModel(b=1.0, dt=0.01)
    rng = np.random.default_rng(5)
    errs = {}
    for pos_sigma, gate in ((None, None), (1.0, None), ("gated", 1e-4)):
        cfg = RunConfig.model_validate({"estimator": {"kind": kind, "initial_radii": [2.1, 1.9], "pose_gate": gate},
                                        "sensors": {"position_sigma": 1.0 if pos_sigma else None}})
        f = build_estimator(cfg)
        assert f is not None
        x = np.array([0.0, 0.0, 0.0, 2.0, 2.0])
        for k in range(2000):
            u = np.array([5.1 + 0.8 * np.sin(0.007 * k), 4.9])
            x = m.step(x, u)
            pos = x[:2] + rng.normal(size=2) if (pos_sigma and k % 100 == 0) else None
            o = f.step(u, Measurement(float(m.speed(x, u)) + 0.5 * rng.normal(), None, pos))
        errs[pos_sigma] = float(np.hypot(*(o.x[:2] - x[:2])))
    print(f"{kind}: final position error without fixes {errs[None]:.2f} m, with 1 Hz fixes {errs[1.0]:.2f} m, "
          f"gated {errs['gated']:.2f} m")
    if kind in ("ekf", "ukf"):
        # free radii (the paper's large Q): heading drifts fast, fixes cut the error by > 5x (gated: > 3x)
        assert errs[1.0] < 0.2 * errs[None] and errs[1.0] < 15.0
        assert errs["gated"] < errs[None] / 3.0
    else:
        # the hypothesis IMM holds the radii at their (true, nominal) values: little drift anyway
        assert errs[None] < 2.0 and errs[1.0] < 2.0 and errs["gated"] < 2.0


def test_builtin_factories_take_settings_and_context() -> None:
    """The registered estimators follow the (settings, context) contract; ``from_settings`` builds the
    same filter from plain tables (the ``[estimator]`` and ``[sensors]`` sections) as the run's factory."""
    cfg = RunConfig.model_validate({"sensors": {"yaw_rate_sigma": 0.01}, "estimator": {"kind": "imm-ukf"}})
    for kind in ("ekf", "ukf", "imm-ekf", "imm-ukf", "none"):
        assert not estimators.get(kind).legacy
    run = build_estimator(cfg)
    own = IMM.from_settings("ukf", {"imm_models": 4}, {"yaw_rate_sigma": 0.01}, wheel_radius=2.0, half_track=1.0)
    direct = estimators.create("imm-ukf", cfg.estimator, run_context(cfg))
    u, zs, zy = excited_data(20, yaw_sigma=0.01)
    for k in range(20):
        outs = [f.step(u[k], Measurement(float(zs[k]), float(zy[k]))) for f in (run, own, direct)]
        for o in outs[1:]:
            np.testing.assert_array_equal(o.x, outs[0].x)
            np.testing.assert_array_equal(o.mode_probs, outs[0].mode_probs)


def test_process_noise_is_a_diffusion_per_second() -> None:
    """``Q = diag(q_diffusion · dt)``: the variance the filter adds per second is the same at 50, 100 and
    400 Hz (to round-off, 1e-12 relative), and the default at 100 Hz is the paper's
    ``diag((q · dt)²)``, ``q = (5, 5, 0.1, 2, 2)``, bit for bit (today's runs unchanged)."""
    from ftc_mj.estimation.setup import setup_from_settings

    per_second = []
    for rate in (50.0, 100.0, 400.0):
        setup = setup_from_settings({"rate": rate})[1]
        per_second.append(np.diag(setup.Q) / setup.dt)
        if rate == 100.0:
            paper = np.diag(np.square(np.array([5.0, 5.0, 0.1, 2.0, 2.0]) * 0.01))
            assert np.array_equal(setup.Q, paper)
    np.testing.assert_allclose(per_second[0], per_second[1], rtol=1e-12)
    np.testing.assert_allclose(per_second[2], per_second[1], rtol=1e-12)
