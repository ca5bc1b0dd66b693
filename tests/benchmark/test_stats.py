"""The benchmark's statistics hold where the percentile bootstrap did not: exact McNemar p-values and an
interval that keeps its coverage with few discordant draws, Holm over the page's verdicts, medians with
order-statistic intervals, no effect size from a handful of pairs, and an exact power analysis.

Tolerances: exact binomial values are sums of a few dozen floating-point terms (scipy's ``binomtest``,
``binom``) or one incomplete-beta inversion (Clopper–Pearson): their relative round-off is far below
1e-9, which is the tolerance used; simulated quantities are not used at all (every check is an exact
enumeration)."""

from __future__ import annotations

import math

import pytest
from scipy.stats import binom

from ftc_mj.benchmark.report import answers, verdict, verdicts
from ftc_mj.benchmark.stats import (
    MIN_EFFECT_PAIRS,
    draws_for_power,
    holm,
    mcnemar_power,
    median_ci,
    order_statistic_ranks,
    paired,
    paired_rate_interval,
    sign_test,
)


def pairs(a: str, b: str, wins: int, losses: int, n: int = 200, err: float = 1.0) -> list[dict]:
    """``n`` draws where ``a`` alone succeeds on ``wins``, ``b`` alone on ``losses``, both on the rest; the same
    largest contouring error for both (no discordance there)."""
    out = []
    for i in range(n):
        sa, sb = (True, False) if i < wins else (False, True) if i < wins + losses else (True, True)
        out += [{"draw": i, "method": a, "success": sa, "contouring_max": err + 0.01 * i},
                {"draw": i, "method": b, "success": sb, "contouring_max": err + 0.01 * i}]
    return out


def test_exact_mcnemar_p_values_are_the_binomial_ones() -> None:
    """Two-sided exact binomial p of the discordant split: 4/0 → 2·2⁻⁴, 5/0 → 2·2⁻⁵, 12/0 → 2·2⁻¹²,
    9/1 → 2·(1 + 10)/2¹⁰; no discordant pair → 1."""
    assert sign_test(4, 0) == pytest.approx(0.125, rel=1e-9)
    assert sign_test(5, 0) == pytest.approx(0.0625, rel=1e-9)
    assert sign_test(12, 0) == pytest.approx(2.0**-11, rel=1e-9)
    assert sign_test(9, 1) == pytest.approx(22 / 1024, rel=1e-9)
    assert sign_test(0, 0) == 1.0


def test_four_of_two_hundred_is_not_shown_and_twelve_is_yes() -> None:
    """The issue's constructed pairs: 4 draws won / 0 lost of 200 (p = 0.125) is not shown, alone or after
    Holm; 12/0 (p = 0.00049) is yes, also after Holm over the page's two verdicts; its interval excludes 0,
    the 4/0 one does not."""
    four = paired(pairs("safe", "feedback-off", 4, 0), "success", "safe", "feedback-off")
    twelve = paired(pairs("safe", "feedback-off", 12, 0), "success", "safe", "feedback-off")
    assert (four.a_larger, four.b_larger, four.n) == (4, 0, 200) and four.estimate == pytest.approx(0.02)
    assert verdict(four, True) == "not shown" and four.lo < 0 < four.hi
    assert verdict(twelve, True) == "yes" and twelve.lo > 0
    assert "Success: **not shown** (safe − feedback-off +0.02" in "\n".join(
        answers(pairs("safe", "feedback-off", 4, 0), ["safe", "feedback-off"]))
    assert "Success: **yes** (safe − feedback-off +0.06" in "\n".join(
        answers(pairs("safe", "feedback-off", 12, 0), ["safe", "feedback-off"]))
    assert verdict(paired(pairs("safe", "feedback-off", 0, 12), "success", "safe", "feedback-off"), True) == "no"


def test_holm_changes_a_borderline_verdict() -> None:
    """9 won / 1 lost (p = 0.0215) is yes as a question of its own; on a page asking two such questions (four
    verdicts: success and contouring error each) Holm multiplies the smallest p by 4 → 0.086: not shown."""
    rows = pairs("safe", "feedback-off", 9, 1)
    alone = paired(rows, "success", "safe", "feedback-off")
    assert verdict(alone, True) == "yes"
    other = [r | {"method": {"safe": "paper", "feedback-off": "safe"}[r["method"]]} for r in rows]
    page = [r for r in other if r["method"] == "paper"] + rows
    found = verdicts(page, ["paper", "safe", "feedback-off"])
    assert [q[:2] for q in found] == [("paper", "safe"), ("safe", "feedback-off")]
    (ps, adj), (_pc, adj_c) = found[1][3]
    assert ps.p_value == pytest.approx(22 / 1024, rel=1e-9) and adj == pytest.approx(4 * 22 / 1024, rel=1e-9)
    assert adj_c == 1.0 and verdict(ps, True, adj) == "not shown"


def test_holm_by_hand() -> None:
    """Sorted p 0.01, 0.02, 0.04 of 3 (and one NaN, not a test): 3·0.01,
    max(2·0.02, 0.03), max(0.04, 0.04); 0.3, 0.9 of 2: 0.6, 0.9."""
    adj = holm([0.04, 0.01, math.nan, 0.02])
    assert adj[0] == pytest.approx(0.04) and adj[1] == pytest.approx(0.03) and adj[3] == pytest.approx(0.04)
    assert math.isnan(adj[2]) and holm([0.3, 0.9]) == [pytest.approx(0.6), pytest.approx(0.9)]


def test_the_paired_interval_keeps_its_coverage_with_few_discordant_pairs() -> None:
    """Exact coverage (enumerating D ~ Bin(n, ψ), W | D ~ Bin(D, θ)) of the interval of Δ = ψ(2θ − 1) is at
    least 95 % where discordant pairs are few (ψ 0.02–0.1 of 60 draws), where the conditional interval at
    the observed discordance alone falls short; with no discordant pair it is ±(1 − 0.0125^(1/n)), the
    Clopper–Pearson bound of ψ at 97.5 %."""
    lo, hi = paired_rate_interval(0, 0, 200)
    assert hi == pytest.approx(1 - 0.0125 ** (1 / 200), rel=1e-9) and lo == pytest.approx(-hi, rel=1e-9)
    n = 60
    for psi, theta in ((0.02, 1.0), (0.05, 0.9), (0.1, 0.5), (0.1, 1.0)):
        delta = psi * (2 * theta - 1)
        cover = 0.0
        for d in range(n + 1):
            for w in range(d + 1):
                lo, hi = paired_rate_interval(w, d - w, n)
                if lo - 1e-12 <= delta <= hi + 1e-12:
                    cover += binom.pmf(d, n, psi) * binom.pmf(w, d, theta)
        assert cover >= 0.95, (psi, theta, cover)


def test_medians_with_order_statistic_intervals() -> None:
    """The rank j of [x(j), x(n+1−j)]: the largest j with P(Bin(n, ½) ≤ j − 1) ≤ 0.025 — 20 values: j = 6
    (P(≤5) = 0.0207, P(≤6) = 0.0577); 6 values: j = 1 (2⁻⁶ = 0.016); 5 values: none (2⁻⁵ = 0.031)."""
    assert order_statistic_ranks(20) == 6 and order_statistic_ranks(6) == 1 and order_statistic_ranks(5) == 0
    assert binom.cdf(5, 20, 0.5) <= 0.025 < binom.cdf(6, 20, 0.5)
    e = median_ci([float(v) for v in range(1, 21)] + [None, math.inf])
    assert (e.mean, e.lo, e.hi, e.n) == (10.5, 6.0, 15.0, 20)
    assert math.isnan(median_ci([1.0, 2.0, 3.0, 4.0, 5.0]).lo)
    heavy = median_ci([0.1] * 15 + [165.0] * 5)  # the runs that end 165 m off do not move the median
    assert heavy.mean == pytest.approx(0.1) and heavy.hi == pytest.approx(0.1)


def test_no_effect_size_from_fewer_than_ten_discordant_pairs() -> None:
    """Two pairs gave r = +1.00; below MIN_EFFECT_PAIRS discordant pairs the effect size is NaN, from that
    many on it is the rank-biserial r (+1 when a wins every discordant pair)."""
    assert MIN_EFFECT_PAIRS == 10
    few = paired(pairs("a", "b", MIN_EFFECT_PAIRS - 1, 0), "success", "a", "b")
    enough = paired(pairs("a", "b", MIN_EFFECT_PAIRS, 0), "success", "a", "b")
    assert math.isnan(few.effect) and enough.effect == pytest.approx(1.0)


def test_exact_power_against_the_closed_form() -> None:
    """When every discordant draw favours a (difference = discordance = ψ) the test rejects exactly when
    D ≥ d*, d* the smallest d with 2·2⁻ᵈ ≤ α/k (6 at 0.05; 9 at 0.05/12), so the power is P(Bin(n, ψ) ≥ d*).
    Under no difference the power is the test's size, at most α/k. The issue's figure (+1 point at 1 %
    discordance ≈ 780 draws unadjusted) is reproduced by :func:`draws_for_power`."""
    assert mcnemar_power(780, 0.01, 0.01) == pytest.approx(binom.sf(5, 780, 0.01), rel=1e-9)
    assert mcnemar_power(1200, 0.01, 0.01, k=12) == pytest.approx(binom.sf(8, 1200, 0.01), rel=1e-9)
    assert 0 < mcnemar_power(200, 0.0, 0.2, k=12) <= 0.05 / 12 / 2 + 1e-12
    n = draws_for_power(0.01, 0.01)
    assert 700 <= n <= 850 and mcnemar_power(n, 0.01, 0.01) >= 0.8 > mcnemar_power(n - 1, 0.01, 0.01)
    assert mcnemar_power(200, 0.05, 0.1, k=12) < mcnemar_power(557, 0.05, 0.1, k=12)
    with pytest.raises(ValueError):
        mcnemar_power(200, 0.2, 0.1)
