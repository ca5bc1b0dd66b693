"""95 % intervals of the study statistics: a mean (Student t), a proportion (Wilson score interval,
:func:`scipy.stats.binomtest`), and for the error bars and bands of the figures a percentile bootstrap
of the mean (:func:`scipy.stats.bootstrap`), which stays inside the range of the data and so never
below zero for a non-negative quantity.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

BOOTSTRAP_RESAMPLES = 999
"""Resamples of a figure's bootstrap interval (a drawing aid: the tables give the Student-t interval)."""


def fmt_g(x: float) -> str:
    """Three significant digits, exponent notation outside ``[1e-3, 1e5)``."""
    if x == 0 or not math.isfinite(x):
        return f"{x:g}"
    return f"{x:.3g}" if 1e-3 <= abs(x) < 1e5 else f"{x:.2e}"


@dataclass(frozen=True)
class Estimate:
    """Mean (or proportion) and its 95 % interval ``[lo, hi]`` over ``n`` runs, in the metric's unit."""

    mean: float
    lo: float
    hi: float
    n: int

    @property
    def half(self) -> float:
        """Half-width of the interval (the metric's unit)."""
        return (self.hi - self.lo) / 2.0

    def fmt(self, unit: str = "", pct: bool = False) -> str:
        """``mean ± half unit``, or ``p % [lo, hi]`` for a proportion; ``—`` without data."""
        if self.n == 0 or not math.isfinite(self.mean):
            return "—"
        if pct:
            return f"{100 * self.mean:.0f} % [{100 * self.lo:.0f}, {100 * self.hi:.0f}]"
        u = f" {unit}" if unit and unit not in ("fraction", "per run") else ""
        if not math.isfinite(self.half):
            return f"{fmt_g(self.mean)}{u}"
        return f"{fmt_g(self.mean)} ± {fmt_g(self.half)}{u}"


NO_DATA = Estimate(float("nan"), float("nan"), float("nan"), 0)


def t_crit(n: int) -> float:
    """Two-sided 95 % Student-t critical value for ``n`` samples (n - 1 dof); NaN below 2 samples."""
    if n < 2:
        return float("nan")
    from scipy.stats import t

    return float(t.ppf(0.975, n - 1))


def _finite(values: Sequence[Any] | np.ndarray) -> np.ndarray:
    a = np.asarray([v for v in values if v is not None], dtype=float)
    return a[np.isfinite(a)]


def mean_ci(values: Sequence[float] | np.ndarray) -> Estimate:
    """Mean with a Student-t 95 % interval (None and non-finite values dropped)."""
    a = _finite(values)
    n = int(a.size)
    if n == 0:
        return NO_DATA
    m = float(a.mean())
    if n < 2:
        return Estimate(m, float("nan"), float("nan"), 1)
    h = t_crit(n) * float(a.std(ddof=1)) / math.sqrt(n)
    return Estimate(m, m - h, m + h, n)


def rate_ci(values: Sequence[Any] | np.ndarray) -> Estimate:
    """Proportion of true values with the Wilson 95 % score interval (None and NaN values dropped)."""
    from scipy.stats import binomtest

    a = [bool(v) for v in values if v is not None and not (isinstance(v, float) and math.isnan(v))]
    n = len(a)
    if n == 0:
        return NO_DATA
    k = sum(a)
    ci = binomtest(k, n).proportion_ci(method="wilson")
    return Estimate(k / n, float(ci.low), float(ci.high), n)


def bootstrap_mean_ci(values: Sequence[float] | np.ndarray, seed: int = 0) -> Estimate:
    """Mean with a percentile-bootstrap 95 % interval (None and non-finite values dropped): inside the
    range of the data, so never below zero for a non-negative quantity; NaN bounds below 2 values."""
    from scipy.stats import bootstrap

    a = _finite(values)
    n = int(a.size)
    if n == 0:
        return NO_DATA
    m = float(a.mean())
    if n < 2 or np.all(a == a[0]):
        return Estimate(m, m if n > 1 else float("nan"), m if n > 1 else float("nan"), n)
    r = bootstrap((a,), np.mean, confidence_level=0.95, method="percentile", n_resamples=BOOTSTRAP_RESAMPLES,
                  random_state=np.random.default_rng(seed))
    return Estimate(m, float(r.confidence_interval.low), float(r.confidence_interval.high), n)


def ts_mean(a: np.ndarray) -> np.ndarray:
    """Per-sample mean across runs (rows) of a NaN-padded (runs, samples) array."""
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN sample has no mean
        return np.nanmean(np.where(np.isfinite(a), a, np.nan), axis=0) if a.size else np.zeros(0)


def ts_bootstrap_band(a: np.ndarray, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-sample mean across runs (rows) and its percentile-bootstrap 95 % band ``(mean, lo, hi)``,
    resampling whole runs; NaN where fewer than two runs have the sample."""
    from scipy.stats import bootstrap

    m = ts_mean(a)
    if a.shape[0] < 2:
        nan = np.full(m.shape, np.nan)
        return m, nan, nan
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        r = bootstrap((np.where(np.isfinite(a), a, np.nan),), np.nanmean, axis=0, vectorized=True,
                      method="percentile", n_resamples=BOOTSTRAP_RESAMPLES, random_state=np.random.default_rng(seed))
    few = np.sum(np.isfinite(a), axis=0) < 2
    lo = np.where(few, np.nan, r.confidence_interval.low)
    hi = np.where(few, np.nan, r.confidence_interval.high)
    return m, lo, hi


def log_scale_interval(e: Estimate) -> tuple[float, float]:
    """The 95 % interval of a positive mean on the log scale (delta method: ``log m ± h/m``, ``h`` the
    Student-t half-width), back-transformed: ``(m·exp(-h/m), m·exp(h/m))``, positive whenever ``m`` is;
    NaN without an interval or for a mean that is not positive."""
    if not (e.mean > 0 and math.isfinite(e.half)):
        return float("nan"), float("nan")
    r = math.exp(e.half / e.mean)
    return e.mean / r, e.mean * r
