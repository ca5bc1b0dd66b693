"""Posterior Cramér–Rao bound: the recursion against a Kalman filter and against a batch Fisher
information built from finite differences of the model."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from ftc_mj.config import RunConfig
from ftc_mj.estimation import Measurement
from ftc_mj.estimation.pcrb import data_model_bound, information_bound, pcrb_columns, trace_pcrb
from ftc_mj.model.kinematics import body_rates
from ftc_mj.wiring.estimation import setup_from_config


def test_linear_gaussian_bound_is_the_kalman_covariance() -> None:
    """For a linear-Gaussian model the PCRB equals the Kalman filter's posterior covariance (the KF is
    the MMSE estimator); filterpy's KalmanFilter is an independent implementation. Time-varying F and H,
    steps without a measurement and with two channels; agreement to round-off (1e-9 on O(1) entries)."""
    rng = np.random.default_rng(3)
    d, n = 4, 60
    P0 = np.diag([1.0, 0.5, 2.0, 0.3])
    Q = 0.01 * np.eye(d) + 0.002 * np.ones((d, d))
    F = np.array([np.eye(d) + 0.1 * rng.standard_normal((d, d)) for _ in range(n)])
    H, R = [], []
    for k in range(n):
        m = (0, 1, 2)[k % 3]
        H.append(rng.standard_normal((m, d)))
        R.append(np.diag(rng.uniform(0.1, 1.0, m)))
    B = information_bound(F, H, R, Q, P0)
    kf = KalmanFilter(dim_x=d, dim_z=1)
    kf.P = P0.copy()
    kf.Q = Q
    for k in range(n):
        kf.F = F[k]
        kf.predict()
        if H[k].shape[0]:
            kf.update(np.zeros(H[k].shape[0]), R=R[k], H=H[k])
        assert np.max(np.abs(B[k] - kf.P)) < 1e-9, k


def _synthetic_trace(n: int, cfg: RunConfig) -> dict[str, np.ndarray]:
    """True states of the kinematic model under varying wheel rates, with every sensor channel present
    (position fixes every 10th row) and a puncture half way."""
    setup = setup_from_config(cfg)
    model = setup.model
    t = np.arange(n) * setup.dt
    U = np.column_stack([5.0 + 2.0 * np.sin(3.0 * t), 4.5 + np.cos(5.0 * t)])
    X = np.zeros((n, 5))
    X[0] = [1.0, -2.0, 0.3, 2.0, 2.0]
    for k in range(1, n):
        X[k] = model.step(X[k - 1], U[k - 1])
        if k == n // 2:
            X[k, 4] = 1.2
    tr = {c: X[:, i] for i, c in enumerate(("x", "y", "psi", "R_R", "R_L"))}
    tr.update(omega_R=U[:, 0], omega_L=U[:, 1], v_meas=np.zeros(n), yaw_rate_meas=np.zeros(n))
    fix = np.where(np.arange(n) % 10 == 0, 0.0, np.nan)
    tr.update(x_meas=fix, y_meas=fix)
    return tr


def _fd_jacobian(fn, x: np.ndarray, h: float = 1e-6) -> np.ndarray:
    cols = []
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = h
        cols.append((fn(x + e) - fn(x - e)) / (2 * h))
    return np.stack(cols, axis=-1)


def _batch_bound(cfg: RunConfig, tr: dict[str, np.ndarray], last: int) -> np.ndarray:
    """Last 5x5 block of the inverse of the Fisher information of ``x_{-1} … x_last`` given ``z_0 … z_last``:
    ``J = Σ Aᵀ W A`` over the prior, process and measurement residuals (additive Gaussian noise), with the
    Jacobians ``A`` by central finite differences of the numpy model."""
    setup = setup_from_config(cfg)
    model = setup.model
    X = np.column_stack([tr[c] for c in ("x", "y", "psi", "R_R", "R_L")])
    U = np.column_stack([tr["omega_R"], tr["omega_L"]])
    N = 5 * (last + 2)
    J = np.zeros((N, N))

    def add(blocks: dict[int, np.ndarray], W: np.ndarray) -> None:
        for i, Ai in blocks.items():
            for j, Aj in blocks.items():
                J[5 * i:5 * i + 5, 5 * j:5 * j + 5] += Ai.T @ W @ Aj

    add({0: np.eye(5)}, np.linalg.inv(setup.P0))
    Qi = np.linalg.inv(setup.Q)
    for k in range(last + 1):
        x_lin, u_lin = X[max(k - 1, 0)], U[max(k - 1, 0)]  # the filters' convention: row 0 predicts from itself
        Fk = _fd_jacobian(lambda x, u=u_lin: model.step(x, u), x_lin)
        add({k: -Fk, k + 1: np.eye(5)}, Qi)  # residual x_k - f(x_{k-1})
        fix = bool(np.isfinite(tr["x_meas"][k]))

        def meas(x: np.ndarray, u: np.ndarray = U[k], fix: bool = fix) -> np.ndarray:
            V, yr = body_rates(x[3], x[4], u[0], u[1], model.b)
            return np.array([V, yr, x[0], x[1], x[2]] if fix else [V, yr])  # a fix: position and heading

        Hk = _fd_jacobian(meas, X[k])
        var = [setup.speed_sigma**2, setup.yaw_rate_sigma**2]
        if fix:
            var += [setup.position_sigma**2] * 2 + [setup.heading_sigma**2]
        add({k + 1: Hk}, np.diag(1.0 / np.asarray(var)))
    return np.linalg.inv(J)[-5:, -5:]


def test_robot_bound_matches_batch_fisher_information_by_finite_differences() -> None:
    """The recursion on the robot (AD Jacobians) equals the filtering marginal of the batch Fisher
    information of the whole trajectory (finite-difference Jacobians, independent of the AD ones), at a
    row with a pose fix (position and heading, σ 0.5 m and 0.5 rad), after a puncture and at the end. FD error
    ~h² ≈ 1e-12 on O(1) entries; the comparison allows 1e-6 relative."""
    cfg = RunConfig.model_validate({"sensors": {"yaw_rate_sigma": 0.05, "position_sigma": 0.5}})
    n = 25
    tr = _synthetic_trace(n, cfg)
    B = trace_pcrb(setup_from_config(cfg), tr)
    for k in (10, n // 2 + 1, n - 1):
        assert np.allclose(_batch_bound(cfg, tr, k), B[k], rtol=1e-6, atol=1e-12), k


def test_pcrb_columns_shrink_with_a_gyro_and_keep_the_split_unobserved_without() -> None:
    """Speed only: the split σ never falls below the prior's 0.5 m on a steady circle (nothing observes
    it; the random-walk Q makes it grow); with a gyro every direction is observed."""
    n = 400
    base = {"estimator": {"rate": 100.0}}
    for gyro, expect in ((None, "grows"), (0.01, "small")):
        cfg = RunConfig.model_validate({**base, "sensors": {"yaw_rate_sigma": gyro}})
        tr = _synthetic_trace(n, cfg)
        tr["omega_R"] = np.full(n, 5.1)
        tr["omega_L"] = np.full(n, 4.9)
        cols = pcrb_columns(setup_from_config(cfg), tr)
        split = cols["radius_split_pcrb_std"]
        if expect == "grows":
            assert split[-1] > 0.5 and split[-1] > split[0]
        else:
            assert split[-1] < 0.05 and cols["R_L_pcrb_std"][-1] < 0.05


def test_the_fixes_heading_observes_the_split_without_a_gyro() -> None:
    """Speed and pose fixes (every 10th row), no gyro, on the steady circle of the test above: an independent
    measurement can only add information, so the split σ with the fix's heading (σ 0.05 rad, which measures the
    yaw the split turns) lies below the one without it (position fixes of the same σ only, heading σ unset) at
    every row — strictly, since the heading row is not in the span of the others' — and by 29 % at the end
    (0.103 against 0.146 m; asserted: at least 20 %): the bound counts each measurement the filters fuse."""
    n = 400
    cfg = RunConfig.model_validate({"estimator": {"rate": 100.0}, "sensors": {
        "yaw_rate_sigma": None, "position_sigma": 0.05, "position_rate": 10.0, "heading_sigma": 0.05}})
    tr = _synthetic_trace(n, cfg)
    tr["omega_R"], tr["omega_L"] = np.full(n, 5.1), np.full(n, 4.9)
    setup = setup_from_config(cfg)
    with_heading = pcrb_columns(setup, tr)["radius_split_pcrb_std"]
    without = pcrb_columns(dataclasses.replace(setup, heading_sigma=None), tr)["radius_split_pcrb_std"]
    assert np.all(with_heading < without) and with_heading[-1] < 0.8 * without[-1]


def test_ukf_covariance_is_the_bound_of_its_own_model_on_the_kinematic_plant() -> None:
    """Speed + yaw rate measure the radii linearly (given the wheel rates) and the radii's dynamics are the
    identity, so the UKF is the Kalman filter of its radius sub-problem and its σ equals the PCRB of its
    model along the true trajectory — to round-off, before the puncture (the filter's Jacobian uses the
    rates of the previous row, the bound the current ones: equal while the commands are held)."""
    from ftc_mj.config import load_config
    from ftc_mj.sim.loop import simulate

    cfg = load_config("scenario2", {"plant.kind": "kinematic", "reconfiguration.policy": "none", "duration": 9.95,
                                    "sensors.yaw_rate_sigma": 0.01})
    tr = simulate(cfg).trace
    for w in ("R", "L"):
        assert abs(tr[f"R_{w}_std"][-1] / tr[f"R_{w}_pcrb_std"][-1] - 1.0) < 1e-9


def test_no_filter_beats_the_bound_of_the_model_that_made_its_data() -> None:
    """The data-model bound (:func:`data_model_bound`: radii constant, a jump of known time) bounds the mean
    squared error of *any* estimator averaged over that model's prior. Data drawn from it: kinematic
    model, speed + gyro, true radii ~ N(2, 0.5²) per wheel (the filters' ``P0``), constant, and for the
    second half of the seeds a left jump to 0.6× at step 150 (its own prior restart). For EKF, UKF and
    IMM-UKF, the mean squared radius error over 24 seeds × 300 steps over the mean bound must be ≥ 1
    within 3 standard errors (over seeds). The random-walk filters are far above it; this is the check
    that the bound is one."""
    from tests.estimation.filters import make_filter

    cfg = RunConfig.model_validate({"sensors": {"yaw_rate_sigma": 0.01}})
    setup = setup_from_config(cfg)
    m = setup.model
    n, seeds = 300, 24
    for kind in ("ekf", "ukf", "imm-ukf"):
        ratios = []
        for seed in range(seeds):
            rng = np.random.default_rng(seed)
            x = np.array([0.0, 0.0, 0.0, *rng.normal(2.0, 0.5, 2)])
            f = make_filter(kind, cfg)
            tr = {c: np.empty(n) for c in ("x", "y", "psi", "R_R", "R_L", "omega_R", "omega_L", "v_meas",
                                            "yaw_rate_meas", "R_L_hat", "R_R_hat")}
            for k in range(n):
                u = np.array([5.1 + 0.8 * np.sin(0.07 * k), 4.9 + 0.8 * np.cos(0.05 * k)])
                x = m.step(x, u)
                if seed >= seeds // 2 and k == 150:
                    x[4] *= 0.6
                v, w = body_rates(x[3], x[4], u[0], u[1], m.b)
                z = Measurement(speed=float(v) + 0.5 * rng.normal(), yaw_rate=float(w) + 0.01 * rng.normal())
                out = f.step(u, z)
                for i, c in enumerate(("x", "y", "psi", "R_R", "R_L")):
                    tr[c][k] = x[i]
                tr["omega_R"][k], tr["omega_L"][k] = u
                tr["v_meas"][k], tr["yaw_rate_meas"][k] = z.speed, z.yaw_rate
                tr["R_R_hat"][k], tr["R_L_hat"][k] = out.x[3], out.x[4]
            B = data_model_bound(setup, tr)
            err2 = (tr["R_R_hat"] - tr["R_R"]) ** 2 + (tr["R_L_hat"] - tr["R_L"]) ** 2
            ratios.append((err2.mean(), (B[:, 3, 3] + B[:, 4, 4]).mean()))
        r = np.array(ratios)
        per_seed = r[:, 0] / r[:, 1].mean()
        assert per_seed.mean() + 3 * per_seed.std(ddof=1) / np.sqrt(seeds) >= 1.0, kind


def test_a_singular_innovation_covariance_is_an_error_not_a_bound() -> None:
    """No prior uncertainty, no process and no measurement noise: ``S = H P Hᵀ + R = 0`` has no inverse, and
    the recursion says so instead of returning a bound of NaNs."""
    zero = np.zeros((5, 5))
    H = [np.eye(5)[:1]] * 3
    with pytest.raises(np.linalg.LinAlgError, match="singular"):
        information_bound(np.broadcast_to(np.eye(5), (3, 5, 5)), H, [np.zeros((1, 1))] * 3, zero, zero)
