"""The ftc-v2 report's tables: every fault of a draw counts in its class, the tiers, the trackable draws the oracle
fails and the fraction of the oracle with an interval that covers."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.benchmark.ceiling import (
    classes_of_draws,
    every_class_table,
    oracle_failures,
    oracle_fraction,
    tiers,
)
from ftc_mj.benchmark.draws import draw


def _rows(success: dict[str, list[bool]], labels: list[str]) -> list[dict]:
    return [{"method": m, "draw": k, "success": ok, "label": labels[k]} for m, oks in success.items()
            for k, ok in enumerate(oks)]


def test_a_draw_counts_in_every_class_of_its_faults():
    d = next(draw("dev", i, "ftc-v2") for i in range(400) if len(draw("dev", i, "ftc-v2").faults) == 2)
    classes = classes_of_draws([d])
    first, second = (f.fault_class for f in d.faults)
    rows = [{"method": "m", "draw": d.index, "success": False}]
    text = "\n".join(every_class_table(rows, ["m"], [first, second], classes))
    assert f"| {first} |" in text and f"| {second} |" in text  # both rows hold the draw
    assert text.count("(n=1)") == (2 if first != second else 1)


def test_tiers_split_the_draws():
    draws = [draw("dev", i, "ftc-v2") for i in range(30)]
    rows = [{"method": "m", "draw": d.index, "label": "trackable" if i % 3 else "stop-only"}
            for i, d in enumerate(draws)]
    t = tiers(draws, rows)
    every = {d.index for d in draws}
    assert t["with a gyro"] | t["without a gyro"] == every and not t["with a gyro"] & t["without a gyro"]
    assert t["no fault"] | t["one fault"] | t["two faults"] == every
    assert len(t["stop-only"]) == 10 and len(t["trackable"]) == 20


def test_oracle_failures_and_fraction():
    labels = ["trackable"] * 40 + ["stop-only"] * 10
    oracle = [k != 3 for k in range(50)]  # fails trackable draw 3 only (and no stop-only draw counts)
    method = [k % 2 == 0 for k in range(50)]
    rows = _rows({"oracle": oracle, "m": method}, labels)
    assert oracle_failures(rows) == [3]
    f, lo, hi, n = oracle_fraction(rows, "m")
    assert n == 40 and f == pytest.approx(20 / 39)
    assert lo < f < hi
    assert np.isnan(oracle_fraction(_rows({"oracle": [False] * 50, "m": method}, labels), "m")[0])


def test_fraction_interval_covers_at_least_95_percent():
    """Simulated paired draws (method succeeds only where the oracle does: the most dependent pairing): the
    interval's coverage of p_m / p_o is at least 95 % (not anti-conservative)."""
    rng = np.random.default_rng(7)
    p_o, p_m_given_o, n, trials = 0.9, 0.6, 60, 400
    truth = p_m_given_o
    hits = 0
    for _ in range(trials):
        o = rng.random(n) < p_o
        m = o & (rng.random(n) < p_m_given_o)
        _f, lo, hi, _n = oracle_fraction(_rows({"oracle": list(o), "m": list(m)}, ["trackable"] * n), "m")
        hits += lo <= truth <= hi
    assert hits / trials >= 0.95
