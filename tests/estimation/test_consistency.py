"""Consistency statistics (NEES, NIS, χ² bounds, effective sample counts) and the Monte-Carlo test of
the EKF and UKF on in-model data: inside the χ² bounds when tuned right, outside when R or Q is wrong."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from ftc_mj.config import RunConfig
from ftc_mj.estimation import Measurement
from ftc_mj.estimation.consistency import (
    anees,
    anees_bounds,
    anees_per_step,
    anis,
    autocorrelation_time,
    chi2_average_bounds,
    combine,
    nees,
    nis,
)
from ftc_mj.wiring.estimation import build_estimator, setup_from_config


# ---------------------------------------------------------------------------- the maths
def test_chi2_average_bounds_are_scipy_chi2_quantiles_bitwise() -> None:
    """The bounds use the regularised incomplete gamma inverse directly (no scipy.stats import at run
    time): bitwise the reference ``scipy.stats.chi2.ppf`` over integer and fractional dof, NaN for dof ≤ 0."""
    dof = np.concatenate([np.arange(1.0, 400.0), np.geomspace(1e-3, 1e6, 500), [0.0, -1.0]])
    for alpha in (0.05, 0.01, 0.3):
        lo, hi = chi2_average_bounds(dof, alpha)
        ok = dof > 0
        np.testing.assert_array_equal(lo[ok], chi2.ppf(alpha / 2, dof[ok]) / dof[ok])
        np.testing.assert_array_equal(hi[ok], chi2.ppf(1 - alpha / 2, dof[ok]) / dof[ok])
        assert np.isnan(lo[~ok]).all() and np.isnan(hi[~ok]).all()


def test_nees_is_the_full_quadratic_form_for_a_correlated_covariance() -> None:
    """Speed-only radius covariance: tight along the sum, loose along the split (correlation -0.9998)."""
    w = np.array([1.0, 1.0]) / np.sqrt(2.0)
    d = np.array([1.0, -1.0]) / np.sqrt(2.0)
    P = 0.01**2 * np.outer(w, w) + 0.5**2 * np.outer(d, d)  # σ 0.01 m on the sum, 0.5 m on the split
    e = np.array([0.05, 0.05])  # a 0.07 m error of the sum: 7 σ along w
    expected = float(e @ np.linalg.solve(P, e))
    assert expected == pytest.approx(50.0, rel=1e-9)  # (0.0707/0.01)² by hand
    assert float(nees(e, P)) == pytest.approx(expected, rel=1e-9)
    diagonal = float(np.sum(e**2 / np.diag(P)))
    assert diagonal < expected / 100  # the diagonal formula is wrong by orders of magnitude here
    # a batch, with a non-finite error and an indefinite covariance: NaN, not a number
    E = np.array([e, [np.nan, 0.0], e])
    Ps = np.array([P, P, [[1.0, 2.0], [2.0, 1.0]]])
    out = nees(E, Ps)
    assert out[0] == pytest.approx(expected, rel=1e-9) and np.isnan(out[1]) and np.isnan(out[2])
    # 5x5 with a random SPD matrix
    rng = np.random.default_rng(0)
    A = rng.normal(size=(7, 5, 5))
    P5 = A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(5)
    e5 = rng.normal(size=(7, 5))
    np.testing.assert_allclose(nis(e5, P5), [v @ np.linalg.solve(M, v) for v, M in zip(e5, P5, strict=True)],
                               rtol=1e-10)


def test_anees_bounds_are_the_chi2_quantiles() -> None:
    lo, hi = anees_bounds(50, 2)
    assert (float(lo), float(hi)) == pytest.approx((1.4844, 2.5912), abs=1e-4)  # Bar-Shalom Table, 100 dof / 50
    lo, hi = anees_bounds(1, 1)
    assert (float(lo), float(hi)) == pytest.approx((chi2.ppf(0.025, 1), chi2.ppf(0.975, 1)), rel=1e-12)
    lo, hi = anees_bounds(np.array([10, 1000]), 5, alpha=0.01)
    np.testing.assert_allclose(lo, chi2.ppf(0.005, [50, 5000]) / [10, 1000], rtol=1e-12)
    np.testing.assert_allclose(hi, chi2.ppf(0.995, [50, 5000]) / [10, 1000], rtol=1e-12)


def _ar1_chi2(rng: np.random.Generator, runs: int, steps: int, phi: float, dof: int = 2) -> np.ndarray:
    """χ²_dof samples whose Gaussian components are AR(1) with coefficient ``phi``: the squared process
    has autocorrelation φ^{2k}, so τ = (1 + φ²) / (1 - φ²)."""
    w = rng.normal(size=(runs, steps, dof))
    e = np.empty_like(w)
    e[:, 0] = w[:, 0]
    for k in range(1, steps):
        e[:, k] = phi * e[:, k - 1] + np.sqrt(1.0 - phi**2) * w[:, k]
    return np.sum(e**2, axis=-1)


def test_autocorrelation_time_of_known_processes() -> None:
    rng = np.random.default_rng(2)
    # 50 000 samples: the estimate's standard error is about τ·sqrt(2(2M+1)/N) (Sokal), M ≈ 5τ
    white = rng.chisquare(2, size=(50, 1000))
    assert 1.0 <= autocorrelation_time(white) < 1.07  # se 0.02 at M ≈ 5: 3.5 σ
    phi = 0.9
    tau = autocorrelation_time(_ar1_chi2(rng, 50, 1000, phi))
    expected = (1 + phi**2) / (1 - phi**2)  # 9.53
    assert tau == pytest.approx(expected, rel=0.2)  # se ≈ 6 % at M ≈ 48: 3 σ
    # missing steps are skipped, not counted as zeros
    x = _ar1_chi2(rng, 50, 1000, phi)
    x[:, ::7] = np.nan
    assert autocorrelation_time(x) == pytest.approx(expected, rel=0.2)


@pytest.mark.parametrize("phi", [0.0, 0.8])
def test_pooled_bounds_cover_95_percent(phi: float) -> None:
    """The time-pooled ANEES with n_eff = samples/τ contains the true mean in about 95 % of trials,
    for white and for correlated (τ = 4.6) statistics: 300 trials, binomial σ 0.0126, band ±4σ."""
    rng = np.random.default_rng(3)
    trials = 300
    data = _ar1_chi2(rng, trials * 4, 500, phi).reshape(trials, 4, 500)
    inside = sum(anees(x, 2).inside for x in data)
    assert 0.90 <= inside / trials <= 0.99


def test_anis_is_per_measurement_dimension() -> None:
    """Steps with a position fix have 3 channels, the others 1: Σ NIS / Σ m estimates 1."""
    rng = np.random.default_rng(4)
    dims = np.where(np.arange(2000) % 100 == 0, 3, 1)
    vals = rng.chisquare(dims, size=(20, 2000))
    res = anis(vals, dims)
    assert res.inside and res.value == pytest.approx(1.0, abs=0.02)
    assert res.samples == 40000 and res.dof == pytest.approx(1.02)
    assert not anis(1.1 * vals, dims).inside  # 10 % too large: 10 σ off with 40 800 dof
    # per-step ANEES over runs
    v, lo, hi = anees_per_step(rng.chisquare(2, size=(50, 10)), 2)
    assert v.shape == lo.shape == hi.shape == (10,)
    np.testing.assert_allclose(lo, anees_bounds(50, 2)[0])


# ---------------------------------------------------------------------------- Monte Carlo
SEEDS = 50
STEPS = 1000  # 10 s at 100 Hz
YAW_SIGMA = 0.01
TRUTH = RunConfig.model_validate({"sensors": {"yaw_rate_sigma": YAW_SIGMA}})


@pytest.fixture(scope="module")
def in_model_data() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Data from the filters' own kinematic model (Euler step at 100 Hz), ``SEEDS`` runs of 10 s:
    x₀ ~ N(x̂₀, P₀), x_{k+1} = f(x_k, u_k) + N(0, Q), speed and yaw rate + N(0, R) with the default
    (paper) P₀, Q and R, and excited wheel rates. Returns u (n, 2), truth (seeds, n, 5), z (seeds, n, 2)."""
    setup = setup_from_config(TRUTH)
    m = setup.model
    rng = np.random.default_rng(2024)
    t = np.arange(STEPS) * setup.dt
    u = np.stack([5.1 + 0.8 * np.sin(0.7 * t), 4.9 + 0.8 * np.cos(0.5 * t)], axis=1)
    x = setup.x0 + rng.normal(size=(SEEDS, 5)) @ np.linalg.cholesky(setup.P0).T
    q = np.sqrt(np.diag(setup.Q))
    X = np.empty((SEEDS, STEPS, 5))
    Z = np.empty((SEEDS, STEPS, 2))
    for k in range(STEPS):
        x = m.step(x, u[k]) + q * rng.normal(size=(SEEDS, 5))
        X[:, k] = x
        Z[:, k, 0] = m.speed(x, u[k]) + setup.speed_sigma * rng.normal(size=SEEDS)
        Z[:, k, 1] = m.yaw_rate(x, u[k]) + YAW_SIGMA * rng.normal(size=SEEDS)
    return u, X, Z


def run_filters(kind: str, overrides: dict, data: tuple[np.ndarray, np.ndarray, np.ndarray]) -> dict[str, np.ndarray]:
    """Full-state NEES, radius NEES, NIS and channel counts (seeds, steps) of the filter ``kind``
    configured with ``overrides`` on top of the data's true sensor set."""
    u, X, Z = data
    cfg = RunConfig.model_validate({"estimator": {"kind": kind, **overrides.get("estimator", {})},
                                    "sensors": {"yaw_rate_sigma": YAW_SIGMA, **overrides.get("sensors", {})}})
    out = {k: np.empty((SEEDS, STEPS)) for k in ("nees", "radius_nees", "nis", "dims")}
    for s in range(SEEDS):
        f = build_estimator(cfg)
        xs = np.empty((STEPS, 5))
        Ps = np.empty((STEPS, 5, 5))
        for k in range(STEPS):
            o = f.step(u[k], Measurement(float(Z[s, k, 0]), float(Z[s, k, 1])))
            xs[k], Ps[k] = o.x, o.P
            out["nis"][s, k], out["dims"][s, k] = o.nis, o.innovation.size
        e = xs - X[s]
        out["nees"][s] = nees(e, Ps)
        out["radius_nees"][s] = nees(e[:, 3:], Ps[:, 3:, 3:])
    return out


def _fmt(name: str, r) -> str:
    return f"{name} {r.value:.4g} [{r.lo:.4g}, {r.hi:.4g}] (n_eff {r.n_eff:.0f}, τ {r.tau:.2f})"


R_SCALE = {"R x1.5": 1.5, "R x0.67": 0.67}
MISTUNED = {
    **{name: {"sensors": {"speed_sigma": 0.5 * np.sqrt(s), "yaw_rate_sigma": YAW_SIGMA * np.sqrt(s)}}
       for name, s in R_SCALE.items()},
    "Q x0.25": {"estimator": {"q_diffusion": (0.0625, 0.0625, 2.5e-5, 0.01, 0.01)}},  # every process-noise σ halved
}


@pytest.mark.parametrize("kind", ["ekf", "ukf"])
def test_correct_filter_is_consistent(kind: str, in_model_data) -> None:
    """50 seeds × 10 s, speed + gyro, in-model data: the ANIS (per dimension, 100 000 channel samples),
    the radius ANEES (2 dof) and the full-state ANEES (5 dof) pooled over runs and time, and the
    per-step ANEES at t = 10 s over the 50 runs, all inside their two-sided 95 % χ² bounds."""
    res = run_filters(kind, {}, in_model_data)
    a = anis(res["nis"], res["dims"])
    r = anees(res["radius_nees"], 2)
    f = anees(res["nees"], 5)
    v, lo, hi = anees_per_step(res["nees"], 5)
    print(f"{kind} correct: {_fmt('ANIS', a)}; {_fmt('radius ANEES', r)}; {_fmt('ANEES', f)}; "
          f"ANEES at 10 s {v[-1]:.3g} [{lo[-1]:.3g}, {hi[-1]:.3g}]; steps outside: {np.mean((v < lo) | (v > hi)):.3f}")
    assert a.samples == SEEDS * STEPS and a.dof == 2.0
    assert a.inside and r.inside and f.inside
    assert lo[-1] <= v[-1] <= hi[-1]


@pytest.mark.parametrize("kind", ["ekf", "ukf"])
@pytest.mark.parametrize("case", list(MISTUNED))
def test_mistuned_filter_is_not_consistent(kind: str, case: str, in_model_data) -> None:
    """The same data through the same filter with R ×1.5 or ×0.67, or Q ×0.25: the ANIS and the radius
    ANEES leave their 95 % χ² bounds (and the full-state ANEES with the wrong Q)."""
    res = run_filters(kind, MISTUNED[case], in_model_data)
    a = anis(res["nis"], res["dims"])
    r = anees(res["radius_nees"], 2)
    f = anees(res["nees"], 5)
    print(f"{kind} {case}: {_fmt('ANIS', a)}; {_fmt('radius ANEES', r)}; {_fmt('ANEES', f)}")
    assert not a.inside and not r.inside
    if case.startswith("Q"):
        assert not f.inside


def test_combining_runs_equals_pooling_them() -> None:
    """Pooling runs one by one (:func:`combine` of per-run tests) gives the all-runs average, the summed
    effective samples, and bounds no wider than for the runs' own number of samples."""
    rng = np.random.default_rng(5)
    x = _ar1_chi2(rng, 8, 400, 0.5)
    per_run = [anees(row, 2) for row in x]
    c = combine(per_run)
    assert c.value == pytest.approx(x.mean(), rel=1e-12) and c.samples == 3200
    assert c.n_eff == pytest.approx(sum(r.n_eff for r in per_run))
    lo, hi = anees_bounds(c.n_eff, 2)
    assert (c.lo, c.hi) == pytest.approx((float(lo), float(hi)), rel=1e-12)
    dims = np.where(np.arange(400) % 50 == 0, 3, 1)
    v = rng.chisquare(dims, size=(8, 400))
    cn = combine([anis(row, dims) for row in v], per_dof=True)
    assert cn.value == pytest.approx(v.sum() / (8 * dims.sum()), rel=1e-12)
    assert cn.inside and combine([]).samples == 0
