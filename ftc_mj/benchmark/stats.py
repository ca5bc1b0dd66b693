"""The benchmark's statistics: per-method aggregates and paired comparisons of two methods on the same
draws, chosen so that a verdict holds with few discordant pairs and over many questions.

- **Rates** (success, tipped, false alarm): proportion with the Wilson 95 % interval
  (:func:`ftc_mj.study.stats.rate_ci`).
- **Continuous scores** (largest contouring error, delays): the *median* with the distribution-free
  order-statistic 95 % interval (:func:`median_ci`) — a mean of the largest contouring error is
  dominated by the few runs that end 100 m or more off the path — plus tail fractions (:data:`TAILS`:
  share of runs whose largest contouring error exceeds 0.5 m, the success bound, and 10 m).
- **Paired success** (0/1 on the same draws): the exact McNemar test — the two-sided binomial test of the
  discordant pairs' split at 1/2 (:func:`sign_test`) — and the interval of the paired difference
  :func:`paired_rate_interval` (why that one: its docstring).
- **Paired continuous scores**: the median of the paired differences with its order-statistic interval and
  the exact sign test, the test that interval inverts (the same binomial arithmetic as McNemar's).
- **Effect size**: the matched-pairs rank-biserial correlation, only from :data:`MIN_EFFECT_PAIRS`
  discordant pairs on (from two pairs it is ±1 whatever the methods are).
- **Many questions**: yes/no verdicts after Holm's step-down correction over every verdict the page gives
  (:func:`holm`); each question's achieved power (:func:`mcnemar_power`) is printed beside it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..study.stats import Estimate, rate_ci

ALPHA = 0.05
"""Family-wise error rate of a page's verdicts (Holm) and the level of every interval (95 %)."""
MIN_EFFECT_PAIRS = 10
"""Fewest discordant pairs (non-zero differences) an effect size is computed from."""
POWER_DIFFERENCE = 0.05
"""The paired success difference (5 points) a leaderboard's draw count is powered for."""
POWER_TARGET = 0.8
"""The power a version's draw count is chosen for (:func:`draws_for_power`)."""
RATES = {"success": "success", "tipped": "tipped over", "false_alarm": "false alarm"}
"""Rate scores (True/False per run) → their name in the tables."""
CONTINUOUS = {"contouring_max": "m", "contouring_rms": "m", "detection_delay": "s", "reconfig_delay": "s"}
"""Continuous scores → unit."""
TAILS = {"contouring_max": (0.5, 10.0)}
"""Tail fractions reported per continuous score: the share of runs above each threshold (the score's unit;
0.5 m is the success bound)."""


# ---------------------------------------------------------------------------- exact binomial pieces
def sign_test(wins: int, losses: int) -> float:
    """Two-sided exact p of ``wins`` against ``losses`` discordant pairs under a 1/2 split (the exact McNemar
    test for 0/1 pairs; the sign test for signed differences): ``min(1, 2·P(X ≥ max))``, X ~ Bin(wins +
    losses, 1/2); 1 without a discordant pair."""
    from scipy.stats import binomtest

    n = wins + losses
    return 1.0 if n == 0 else float(binomtest(wins, n, 0.5).pvalue)


def clopper_pearson(k: int, n: int, level: float) -> tuple[float, float]:
    """The exact (Clopper–Pearson) interval of a binomial proportion, ``k`` of ``n``, at ``level`` (its
    coverage is at least ``level`` for every true proportion); ``(0, 1)`` for ``n = 0``."""
    from scipy.stats import beta

    if n == 0:
        return 0.0, 1.0
    a = 1.0 - level
    lo = 0.0 if k == 0 else float(beta.ppf(a / 2, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1 - a / 2, k + 1, n - k))
    return lo, hi


def paired_rate_interval(wins: int, losses: int, n: int, level: float = 1 - ALPHA) -> tuple[float, float]:
    """An interval of the paired difference of two success rates, ``Δ = P(a only) − P(b only) = ψ(2θ − 1)``
    (``ψ`` the discordance probability, ``θ`` the share of discordant pairs ``a`` wins), from ``wins`` and
    ``losses`` discordant pairs of ``n``.

    Why this one: the exact conditional interval (Clopper–Pearson for θ, scaled by the *observed*
    discordance) treats ψ as known and is too narrow exactly where it matters, with few discordant pairs;
    Newcombe's hybrid score interval is close to nominal but not guaranteed. Here both unknowns get a
    Clopper–Pearson interval at ``1 − (1 − level)/2`` each — θ given the discordant count (exact conditional
    coverage, hence unconditional too), ψ from all ``n`` — and Δ ranges over the box they span. By the union
    bound the coverage is at least ``level`` for every (ψ, θ): never anti-conservative, at the price of some
    width. With no discordant pair it is ``±`` the upper bound of ψ (0 of 200: ±0.0217), not a point."""
    half = 1.0 - (1.0 - level) / 2
    t_lo, t_hi = clopper_pearson(wins, wins + losses, half)
    p_lo, p_hi = clopper_pearson(wins + losses, n, half)
    ends = [psi * (2 * t - 1) for psi in (p_lo, p_hi) for t in (t_lo, t_hi)]
    return min(ends), max(ends)


def order_statistic_ranks(n: int, level: float = 1 - ALPHA) -> int:
    """The rank ``j`` (1-based) of the order-statistic interval ``[x(j), x(n+1−j)]`` of the median of ``n``
    values: the largest ``j`` with ``P(Bin(n, 1/2) ≤ j − 1) ≤ (1 − level)/2``, so the coverage is at least
    ``level`` for any continuous distribution; 0 when ``n`` is too small for an interval (below 6 at 95 %)."""
    from scipy.stats import binom

    j = 0
    while j + 1 <= n // 2 and binom.cdf(j, n, 0.5) <= (1 - level) / 2 * (1 + 1e-12):
        j += 1
    return j


def median_ci(values: Sequence[Any] | np.ndarray, level: float = 1 - ALPHA) -> Estimate:
    """Median (as ``Estimate.mean``) with the distribution-free order-statistic interval
    (:func:`order_statistic_ranks`); None and non-finite values dropped; NaN bounds below 6 values."""
    a = np.sort(np.asarray([float(v) for v in values if v is not None], dtype=float))
    a = a[np.isfinite(a)]
    n = int(a.size)
    if n == 0:
        return Estimate(math.nan, math.nan, math.nan, 0)
    j = order_statistic_ranks(n, level)
    lo, hi = (float(a[j - 1]), float(a[n - j])) if j else (math.nan, math.nan)
    return Estimate(float(np.median(a)), lo, hi, n)


def holm(p_values: Sequence[float]) -> list[float]:
    """Holm's step-down adjusted p-values (family-wise error ≤ α over the family for any dependence): the
    ``i``-th smallest of ``m`` is multiplied by ``m − i`` (i from 0), made non-decreasing, capped at 1. NaN
    entries (no test) stay NaN and are not counted in ``m``."""
    idx = [i for i, p in enumerate(p_values) if math.isfinite(p)]
    order = sorted(idx, key=lambda i: p_values[i])
    m = len(order)
    out = [math.nan] * len(p_values)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p_values[i]))
        out[i] = running
    return out


# ---------------------------------------------------------------------------- power
def mcnemar_power(n: int, difference: float, discordance: float, alpha: float = ALPHA, k: int = 1) -> float:
    """Exact power of the two-sided exact McNemar test at level ``alpha / k`` (the first step of Holm over
    ``k`` questions, a lower bound of Holm's power) to find ``a`` better on ``n`` paired draws when
    ``P(a only) − P(b only) = difference`` and ``P(a only) + P(b only) = discordance``.

    By summation: the discordant count D ~ Bin(n, ψ); given D = d, a's wins W ~ Bin(d, θ), θ = (ψ + δ)/(2ψ);
    the power is Σ_d P(D = d) · P(W ≥ w*(d)), w*(d) the smallest win count above d/2 the test rejects at.
    :class:`ValueError` unless ``0 ≤ difference ≤ discordance ≤ 1``."""
    from scipy.stats import binom

    if not (0.0 <= difference <= discordance <= 1.0) or discordance == 0.0:
        raise ValueError(f"power: need 0 <= difference <= discordance <= 1, 0 < discordance; got {difference}, "
                         f"{discordance}")
    level = alpha / k
    theta = (discordance + difference) / (2 * discordance)
    d = np.arange(1, n + 1)
    w = np.maximum(binom.isf(level / 2, d, 0.5) + 1, d // 2 + 1)  # smallest rejecting win count, up to round-off
    for step in (-1, 1):  # settle the round-off of isf: w rejects and w - 1 does not (or w > d: none does)
        w = np.where((step < 0) & (w - 1 > d // 2) & (2 * binom.sf(w - 2, d, 0.5) <= level * (1 + 1e-12)), w - 1, w)
        w = np.where((step > 0) & (w <= d) & (2 * binom.sf(w - 1, d, 0.5) > level * (1 + 1e-12)), w + 1, w)
    return float(np.sum(binom.pmf(d, n, discordance) * binom.sf(w - 1, d, theta)))


def draws_for_power(difference: float, discordance: float, k: int = 1, target: float = POWER_TARGET,
                    alpha: float = ALPHA, max_draws: int = 20_000) -> int:
    """The fewest paired draws whose :func:`mcnemar_power` reaches ``target``, by bisection on ``n`` (the
    exact test's power is a slight sawtooth in n; bisection finds a crossing, within a few draws of the
    first); ``max_draws`` if even that many do not reach it."""
    lo, hi = 1, max_draws
    if mcnemar_power(hi, difference, discordance, alpha, k) < target:
        return max_draws
    while lo < hi:
        mid = (lo + hi) // 2
        if mcnemar_power(mid, difference, discordance, alpha, k) >= target:
            hi = mid
        else:
            lo = mid + 1
    return lo


def achieved_power(n: int, wins: int, losses: int, k: int, difference: float = POWER_DIFFERENCE) -> float:
    """A question's power to find a ``difference`` (5 points) on its ``n`` draws at the discordance it showed
    (``(wins + losses)/n``, at least ``difference``: a difference needs that many discordant draws), after
    Holm over ``k`` verdicts; NaN without draws."""
    if n == 0:
        return math.nan
    return mcnemar_power(n, difference, min(1.0, max((wins + losses) / n, difference)), ALPHA, k)


# ---------------------------------------------------------------------------- aggregates and pairs
def aggregate(rows: list[dict[str, Any]]) -> dict[str, Estimate]:
    """Every rate (Wilson), every continuous score (median, order-statistic interval) and its tail fractions
    (``<score>>`` + threshold, Wilson) over ``rows``, plus the isolation rates over the runs with a fault and
    an estimator: ``isolation_correct`` and ``isolation_wrong``."""
    out = {k: rate_ci([r.get(k) for r in rows]) for k in RATES}
    out.update({k: median_ci([r.get(k) for r in rows]) for k in CONTINUOUS})
    for k, thresholds in TAILS.items():
        vals = [r.get(k) for r in rows if r.get(k) is not None and math.isfinite(float(r[k]))]
        out.update({f"{k}>{t:g}": rate_ci([float(v) > t for v in vals]) for t in thresholds})
    iso = [r.get("isolation") for r in rows if r.get("isolation") not in (None, "n/a")]
    out["isolation_correct"] = rate_ci([v == "correct" for v in iso])
    out["isolation_wrong"] = rate_ci([v == "wrong" for v in iso])
    return out


@dataclass(frozen=True)
class Paired:
    """Method ``a`` against ``b`` on the draws both have a value for: ``n`` pairs, the pairs where ``a`` is
    larger / smaller, the estimate of ``a − b`` (0/1 scores: the difference of the rates; continuous: the
    median of the paired differences) with its 95 % interval (:func:`paired_rate_interval`; the
    order-statistic interval), the exact two-sided p (McNemar; sign test), the rank-biserial correlation
    (NaN below :data:`MIN_EFFECT_PAIRS` discordant pairs) and, for 0/1 scores, the share of discordant
    pairs."""

    score: str
    a: str
    b: str
    n: int
    a_larger: int
    b_larger: int
    estimate: float
    lo: float
    hi: float
    p_value: float
    effect: float
    binary: bool

    @property
    def discordant(self) -> int:
        """Pairs with a non-zero difference."""
        return self.a_larger + self.b_larger


def rank_biserial(d: np.ndarray) -> float:
    """Matched-pairs rank-biserial correlation of differences ``d`` (zeros dropped): ``(R⁺ − R⁻) / (R⁺ + R⁻)``
    of the signed ranks of ``|d|``; NaN below :data:`MIN_EFFECT_PAIRS` non-zero differences."""
    from scipy.stats import rankdata

    d = d[d != 0]
    if d.size < MIN_EFFECT_PAIRS:
        return math.nan
    r = rankdata(np.abs(d))
    return float((r[d > 0].sum() - r[d < 0].sum()) / r.sum())


def paired_values(rows: list[dict[str, Any]], score: str, a: str, b: str) -> np.ndarray:
    """``(pairs, 2)`` finite values of ``score`` of ``a`` and ``b`` on the draws both have (booleans as 0/1;
    rows keyed by ``method`` and ``draw``)."""
    val = {(r["method"], r["draw"]): r.get(score) for r in rows}
    draws = sorted({d for (m, d) in val if m == a} & {d for (m, d) in val if m == b})
    pairs = [(val[(a, d)], val[(b, d)]) for d in draws]
    return np.array([[float(u), float(v)] for u, v in pairs if u is not None and v is not None
                     and math.isfinite(float(u)) and math.isfinite(float(v))]).reshape(-1, 2)


def paired(rows: list[dict[str, Any]], score: str, a: str, b: str) -> Paired:
    """:class:`Paired` of ``score`` between methods ``a`` and ``b``; a score whose values are all 0/1 is
    treated as a rate (McNemar), any other as continuous (sign test, median)."""
    x = paired_values(rows, score, a, b)
    d = x[:, 0] - x[:, 1]
    n, wins, losses = int(d.size), int(np.sum(d > 0)), int(np.sum(d < 0))
    binary = bool(np.all(np.isin(x, (0.0, 1.0))))
    if binary:
        est = (wins - losses) / n if n else math.nan
        lo, hi = paired_rate_interval(wins, losses, n) if n else (math.nan, math.nan)
    else:
        m = median_ci(d)
        est, lo, hi = m.mean, m.lo, m.hi
    p = sign_test(wins, losses) if n else math.nan
    return Paired(score, a, b, n, wins, losses, est, lo, hi, p, rank_biserial(d), binary)
