"""The benchmark's statistics: per-method aggregates with 95 % intervals (Wilson for rates, percentile
bootstrap for continuous scores; :mod:`ftc_mj.study.stats`) and paired comparisons of two methods on the
same draws — the paired bootstrap of the mean difference and the Wilcoxon signed-rank test with the
matched-pairs rank-biserial correlation as its effect size."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..study.stats import Estimate, bootstrap_mean_ci, rate_ci

RATES = {"success": "success", "tipped": "tipped over", "false_alarm": "false alarm"}
"""Rate scores (True/False per run) → their name in the tables."""
CONTINUOUS = {"contouring_max": "m", "contouring_rms": "m", "detection_delay": "s", "reconfig_delay": "s"}
"""Continuous scores → unit."""


def aggregate(rows: list[dict[str, Any]]) -> dict[str, Estimate]:
    """Every rate (Wilson) and continuous score (bootstrap of the mean) over ``rows``, plus the isolation
    rates over the runs with a fault and an estimator: ``isolation_correct`` and ``isolation_wrong``."""
    out = {k: rate_ci([r.get(k) for r in rows]) for k in RATES}
    out.update({k: bootstrap_mean_ci([r.get(k) for r in rows]) for k in CONTINUOUS})
    iso = [r.get("isolation") for r in rows if r.get("isolation") not in (None, "n/a")]
    out["isolation_correct"] = rate_ci([v == "correct" for v in iso])
    out["isolation_wrong"] = rate_ci([v == "wrong" for v in iso])
    return out


@dataclass(frozen=True)
class Paired:
    """Method ``a`` against ``b`` on the draws both have a value for: the mean difference ``a − b`` with its
    paired-bootstrap 95 % interval, the Wilcoxon signed-rank p-value and the rank-biserial correlation
    (−1: ``b`` larger on every pair … +1: ``a`` larger on every pair), and the pairs where ``a`` is larger /
    smaller."""

    score: str
    a: str
    b: str
    diff: Estimate
    p_value: float
    effect: float
    a_larger: int
    b_larger: int


def rank_biserial(d: np.ndarray) -> float:
    """Matched-pairs rank-biserial correlation of differences ``d`` (zeros dropped): ``(R⁺ − R⁻) / (R⁺ + R⁻)``
    of the signed ranks of ``|d|``; NaN without a non-zero difference."""
    from scipy.stats import rankdata

    d = d[d != 0]
    if d.size == 0:
        return math.nan
    r = rankdata(np.abs(d))
    return float((r[d > 0].sum() - r[d < 0].sum()) / r.sum())


def paired(rows: list[dict[str, Any]], score: str, a: str, b: str) -> Paired:
    """:class:`Paired` of ``score`` between methods ``a`` and ``b`` (rows keyed by ``method`` and ``draw``;
    booleans count as 0/1)."""
    from scipy.stats import wilcoxon

    val = {(r["method"], r["draw"]): r.get(score) for r in rows}
    draws = sorted({d for (m, d) in val if m == a} & {d for (m, d) in val if m == b})
    pairs = [(val[(a, d)], val[(b, d)]) for d in draws]
    x = np.array([[float(u), float(v)] for u, v in pairs if u is not None and v is not None
                  and math.isfinite(float(u)) and math.isfinite(float(v))]).reshape(-1, 2)
    d = x[:, 0] - x[:, 1]
    p = math.nan
    if np.count_nonzero(d) >= 1:
        p = float(wilcoxon(d, zero_method="wilcox").pvalue) if np.count_nonzero(d) >= 2 else 1.0
    return Paired(score, a, b, bootstrap_mean_ci(d), p, rank_biserial(d), int(np.sum(d > 0)), int(np.sum(d < 0)))
