"""Filter consistency statistics (Bar-Shalom, Li, Kirubarajan, *Estimation with Applications*, §5.4).

Arrays in, arrays out; nothing here knows about runs, traces or configs.

A filter is *consistent* when its errors are zero-mean with the covariance it reports. Then

* the normalised estimation error squared ``ε = eᵀ P⁻¹ e`` of an ``n``-dimensional state error
  ``e`` with covariance ``P`` is χ²-distributed with ``n`` degrees of freedom (mean ``n``);
* the normalised innovation squared ``yᵀ S⁻¹ y`` of an ``m``-channel innovation ``y`` with
  innovation covariance ``S`` is χ² with ``m`` degrees of freedom, and the innovations of a
  consistent filter are white (independent from step to step).

The full covariance matters: with speed-only sensing the two radius errors are strongly
correlated (the sum is observed, the split is not) and ``(e_R/σ_R)² + (e_L/σ_L)²`` differs from
``eᵀ P⁻¹ e`` by orders of magnitude.

Averages. ``n`` independent χ²_dof samples sum to a χ² with ``n·dof`` degrees of freedom, so the
average lies, with probability ``1 - alpha``, in ``[χ²_{n·dof}(alpha/2), χ²_{n·dof}(1 - alpha/2)] / n``
(:func:`anees_bounds`). Two ways of averaging a set of runs are offered:

* :func:`anees_per_step` — Bar-Shalom's Monte-Carlo test: at each time step, the average over the
  runs (independent by construction), ``n`` = number of runs;
* :func:`anees` and :func:`anis` — one average over all runs *and* time steps (or over one run's
  steps, pooled over runs afterwards by :func:`combine`). Successive NEES
  values are correlated (a radius error persists), so the steps are not independent samples: the
  number of samples is the effective ``n_eff = n_steps / τ``, with ``τ`` the integrated
  autocorrelation time of the statistic (:func:`autocorrelation_time`, pooled over the runs), and
  the bounds are those of a χ² with ``n_eff · dof`` degrees of freedom (the Welch–Satterthwaite
  approximation: a χ² with the sum's mean and variance). Innovations of a consistent filter are
  white, so for the NIS ``τ`` ≈ 1 and the time-pooled test is exact.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..lazy import lazy_module

scipy = lazy_module("scipy")  # imported on first use (ftc_mj.lazy)

SOKAL_WINDOW = 5.0
"""Autocorrelation window: the smallest lag ``M`` with ``M ≥ 5 τ(M)`` (Sokal's automatic window)."""


def nees(e: np.ndarray, P: np.ndarray) -> np.ndarray:
    """Normalised estimation error squared ``eᵀ P⁻¹ e`` of a batch.

    Parameters
    ----------
    e : array (..., n)
        Estimation errors (estimate minus truth), any units consistent with ``P``.
    P : array (..., n, n)
        Covariances the filter reported for those errors (symmetrised here).

    Returns
    -------
    array (...)
        ε per batch element (dimensionless; χ²_n for a consistent filter). NaN where ``e`` or ``P``
        is not finite or ``P`` is not positive definite.
    """
    e = np.asarray(e, dtype=float)
    P = np.asarray(P, dtype=float)
    out = np.full(e.shape[:-1], np.nan)
    ok = np.all(np.isfinite(e), axis=-1) & np.all(np.isfinite(P), axis=(-2, -1))
    if not np.any(ok):
        return out
    Ps = 0.5 * (P[ok] + np.swapaxes(P[ok], -1, -2))
    lam, V = np.linalg.eigh(Ps)  # never raises for a symmetric matrix, unlike a batched Cholesky
    proj = np.einsum("...ij,...i->...j", V, e[ok])
    with np.errstate(divide="ignore", invalid="ignore"):
        val = np.sum(proj**2 / lam, axis=-1)
    val[~np.all(lam > 0.0, axis=-1)] = np.nan
    out[ok] = val
    return out


def nis(y: np.ndarray, S: np.ndarray) -> np.ndarray:
    """Normalised innovation squared ``yᵀ S⁻¹ y``: :func:`nees` of innovations ``y`` (..., m) with
    innovation covariances ``S`` (..., m, m); χ²_m for a consistent filter."""
    return nees(y, S)


def chi2_average_bounds(dof: float | np.ndarray, alpha: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """Two-sided ``1 - alpha`` bounds of ``X / dof`` for ``X ~ χ²_dof`` (``dof`` may be non-integer).

    Returns ``(lo, hi)``; NaN where ``dof ≤ 0``.
    """
    d = np.asarray(dof, dtype=float)
    half = np.maximum(d, 1e-300) / 2.0
    with np.errstate(invalid="ignore", divide="ignore"):
        # the χ² quantile, 2 P⁻¹(dof/2, q) (bitwise scipy.stats.chi2.ppf, without importing scipy.stats)
        lo = np.where(d > 0, 2.0 * scipy.special.gammaincinv(half, alpha / 2.0) / d, np.nan)
        hi = np.where(d > 0, 2.0 * scipy.special.gammaincinv(half, 1.0 - alpha / 2.0) / d, np.nan)
    return lo, hi


def anees_bounds(n_runs: float | np.ndarray, dof: float, alpha: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """Two-sided ``1 - alpha`` bounds for the average of ``n_runs`` independent χ²_dof samples.

    ``n·ε̄ ~ χ²_{n·dof}``, so ``ε̄ ∈ [χ²_{n·dof}(alpha/2), χ²_{n·dof}(1 - alpha/2)] / n`` (Bar-Shalom
    §5.4.2). E.g. 50 runs, 2 dof, alpha 0.05: [1.48, 2.59]. ``n_runs`` may be an effective
    (non-integer) number of samples.
    """
    lo, hi = chi2_average_bounds(np.asarray(n_runs, dtype=float) * dof, alpha)
    return dof * lo, dof * hi


def autocorrelation_time(x: np.ndarray) -> float:
    """Integrated autocorrelation time ``τ = 1 + 2 Σ_{k=1}^{M} ρ(k)`` of a statistic over time.

    Parameters
    ----------
    x : array (n_steps,) or (n_runs, n_steps)
        The statistic per step; rows are independent runs of one process, NaN = missing step.

    Returns
    -------
    float
        ``τ ≥ 1`` (steps): the average of ``n`` steps has the variance of ``n / τ`` independent ones.
        The autocorrelation ``ρ`` is pooled over the runs about the overall mean; ``M`` is Sokal's
        window (:data:`SOKAL_WINDOW`), capped at the run length. ``τ`` is never below 1 (a negatively
        correlated sequence is not credited with more samples than it has); 1 for a constant
        statistic; NaN with fewer than two values.
    """
    a = np.atleast_2d(np.asarray(x, dtype=float))
    mask = np.isfinite(a)
    if mask.sum() < 2:
        return float("nan")
    if np.ptp(a[mask]) == 0.0:
        return 1.0  # a constant statistic: nothing correlates (and round-off must not pretend it does)
    z = np.where(mask, a - a[mask].mean(), 0.0)
    m = mask.astype(float)
    K = a.shape[1]
    nfft = 1 << int(math.ceil(math.log2(2 * K)))
    cz = np.fft.irfft(np.abs(np.fft.rfft(z, nfft, axis=1)) ** 2, nfft, axis=1)[:, :K].sum(axis=0)
    cm = np.fft.irfft(np.abs(np.fft.rfft(m, nfft, axis=1)) ** 2, nfft, axis=1)[:, :K].sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        acov = np.where(cm > 0.5, cz / np.maximum(cm, 1.0), 0.0)
    rho = acov / acov[0]
    tau_m = 1.0 + 2.0 * np.cumsum(rho[1:])
    lags = np.arange(1, K)
    ok = lags >= SOKAL_WINDOW * tau_m
    tau = float(tau_m[np.argmax(ok)] if ok.any() else tau_m[-1]) if K > 1 else 1.0
    return max(tau, 1.0)


@dataclass(frozen=True)
class ChiSquareTest:
    """An average of χ² statistics with its two-sided χ² acceptance interval."""

    value: float
    """The average (ANEES: mean ε, expected ``dof``; ANIS per dimension: expected 1)."""
    lo: float
    hi: float
    """Bounds containing the average with probability ``1 - alpha`` for a consistent filter."""
    n_eff: float
    """Effective number of independent samples behind the average (samples / τ)."""
    samples: int
    """Finite samples averaged."""
    tau: float
    """Integrated autocorrelation time (steps) used for ``n_eff``."""
    dof: float
    """Degrees of freedom of one sample (mean over samples for the NIS of varying dimension)."""

    @property
    def inside(self) -> bool:
        """The average lies inside its bounds (False when there is nothing to test)."""
        return bool(self.lo <= self.value <= self.hi)

    def as_dict(self) -> dict[str, float]:
        """Plain values (for ``metrics.json``)."""
        return {"lo": self.lo, "hi": self.hi, "n_eff": self.n_eff, "samples": float(self.samples),
                "tau": self.tau, "dof": self.dof}


_EMPTY = ChiSquareTest(float("nan"), float("nan"), float("nan"), 0.0, 0, float("nan"), float("nan"))


def _pooled(stat: np.ndarray, dof: np.ndarray, alpha: float, per_dof: bool) -> ChiSquareTest:
    """Σ stat / Σ dof over finite samples, with bounds for ``Σ dof / τ`` effective degrees of freedom;
    ``τ`` from the standardised statistic ``(stat - dof) / sqrt(2 dof)``."""
    ok = np.isfinite(stat) & np.isfinite(dof) & (dof > 0)
    n = int(ok.sum())
    if n == 0:
        return _EMPTY
    total_dof = float(dof[ok].sum())
    value = float(stat[ok].sum()) / total_dof
    zs = np.where(ok, (stat - dof) / np.sqrt(2.0 * np.where(ok, dof, 1.0)), np.nan)
    tau = autocorrelation_time(zs)
    lo, hi = chi2_average_bounds(total_dof / tau, alpha)
    mean_dof = total_dof / n
    scale = 1.0 if per_dof else mean_dof
    return ChiSquareTest(value * scale, float(lo) * scale, float(hi) * scale, n / tau, n, tau, mean_dof)


def anees(eps: np.ndarray, dof: int, alpha: float = 0.05) -> ChiSquareTest:
    """Average NEES over all runs and time steps, with χ² bounds for the effective sample count.

    Parameters
    ----------
    eps : array (n_steps,) or (n_runs, n_steps)
        NEES per step (:func:`nees`); NaN = no estimate.
    dof : int
        State dimension ``n`` of the errors.
    alpha : float
        Two-sided significance level of the bounds.

    Returns
    -------
    ChiSquareTest
        ``value`` = mean ε (expected ``dof``); ``n_eff = samples / τ`` with ``τ`` of
        :func:`autocorrelation_time` pooled over the runs; bounds :func:`anees_bounds` at ``n_eff``.
    """
    e = np.atleast_2d(np.asarray(eps, dtype=float))
    return _pooled(e, np.full(e.shape, float(dof)), alpha, per_dof=False)


def anis(nis_values: np.ndarray, dims: np.ndarray, alpha: float = 0.05) -> ChiSquareTest:
    """Average NIS *per measurement dimension* over all runs and steps, with χ² bounds.

    Parameters
    ----------
    nis_values : array (n_steps,) or (n_runs, n_steps)
        NIS per step (:func:`nis`); NaN = no update.
    dims : array like ``nis_values``
        Measurement channels used at each step (1 with the speed alone, 2 with a gyro, +2 on a
        position fix); 0 = no update.
    alpha : float
        Two-sided significance level.

    Returns
    -------
    ChiSquareTest
        ``value`` = Σ NIS / Σ dims (expected 1). The sum of independent χ²_{m_k} is χ²_{Σ m_k}, so the
        bounds are those of χ²_{Σm/τ}/(Σm/τ) with ``τ`` (≈ 1 for white innovations) of the
        standardised NIS.
    """
    s = np.atleast_2d(np.asarray(nis_values, dtype=float))
    d = np.broadcast_to(np.atleast_2d(np.asarray(dims, dtype=float)), s.shape)
    return _pooled(s, d, alpha, per_dof=True)


def combine(tests: Sequence[ChiSquareTest], alpha: float = 0.05, *, per_dof: bool = False) -> ChiSquareTest:
    """Pool the averages of independent runs into one, with χ² bounds for their summed samples.

    Parameters
    ----------
    tests : sequence of ChiSquareTest
        One per run (from :func:`anees`, or :func:`anis` with ``per_dof``); empty ones are skipped.
    alpha : float
        Two-sided significance level of the pooled bounds.
    per_dof : bool
        The values are averages per degree of freedom (:func:`anis`), else plain means (:func:`anees`).

    Returns
    -------
    ChiSquareTest
        The average over all samples of all runs (weights ``samples · dof``); independent runs add
        their effective samples, so the bounds are those of χ² with ``Σ n_eff · dof`` degrees of freedom.
    """
    ts = [x for x in tests if x.samples > 0 and math.isfinite(x.value) and math.isfinite(x.n_eff)]
    if not ts:
        return _EMPTY
    samples = sum(x.samples for x in ts)
    total_dof = sum(x.samples * x.dof for x in ts)
    total = sum(x.value * x.samples * (x.dof if per_dof else 1.0) for x in ts)
    n_eff = sum(x.n_eff for x in ts)
    lo, hi = chi2_average_bounds(sum(x.n_eff * x.dof for x in ts), alpha)
    mean_dof = total_dof / samples
    scale = 1.0 if per_dof else mean_dof
    value = total / total_dof if per_dof else total / samples
    return ChiSquareTest(value, float(lo) * scale, float(hi) * scale, n_eff, samples, samples / n_eff, mean_dof)


def anees_per_step(eps: np.ndarray, dof: int, alpha: float = 0.05) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bar-Shalom's Monte-Carlo ANEES at each time step: the average over independent runs.

    Parameters
    ----------
    eps : array (n_runs, n_steps)
        NEES per run and step; NaN = missing.
    dof : int
        State dimension.
    alpha : float
        Two-sided significance level.

    Returns
    -------
    value, lo, hi : arrays (n_steps,)
        Mean over the runs with a finite value at that step and its :func:`anees_bounds` for that
        number of runs (NaN where no run has a value). About ``alpha`` of the steps of a consistent
        filter fall outside (the steps are not independent of each other).
    """
    e = np.atleast_2d(np.asarray(eps, dtype=float))
    n = np.sum(np.isfinite(e), axis=0)
    with np.errstate(invalid="ignore"):
        value = np.where(n > 0, np.nansum(e, axis=0) / np.maximum(n, 1), np.nan)
    lo, hi = anees_bounds(n, dof, alpha)
    return value, lo, hi
