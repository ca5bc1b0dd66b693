"""The outcome rules of a check (a failed run fails, a missing run is not run, an unmet precondition
is n/a), on every claim family, and the independence of check texts from the numbers."""

from __future__ import annotations

from typing import Any

from ftc_mj.paper.claims import checks as ck
from ftc_mj.paper.claims import evaluate_all
from tests.paper.rows import paper_like_rows, policy_rows


def _rows(**status: str) -> dict[str, dict[str, Any]]:
    return {lb: {"status": s, "x": 1.0} for lb, s in status.items()}


def test_a_failed_run_fails_its_check_even_when_the_test_passed() -> None:
    rows = _rows(a="ok", b="failed")
    rows["b"]["error"] = "TypeError: boom"
    ch = ck.settle(ck.Check("t", True, "", ("a", "b")), rows)
    assert ch.outcome == ck.FAIL and "TypeError: boom" in ch.detail


def test_missing_runs_are_not_run_and_unmet_preconditions_are_na() -> None:
    rows = _rows(a="ok")
    assert ck.settle(ck.Check("t", True, "", ("a", "z")), rows).outcome == ck.NOT_RUN
    assert ck.settle(ck.Check("t", True, "", ("a",), na="identical by construction"), rows).outcome == ck.NA
    ch = ck.settle(ck.Check("t", None, "", ("a",)), rows)
    assert ch.outcome == ck.NA and ch.na == "a value it needs is missing"
    rows["a"]["onsets_after_end"] = 1  # a fault scheduled after the end of the run is neither passed nor failed
    assert ck.settle(ck.Check("t", False, "", ("a",)), rows).outcome == ck.NA
    # "missing" rows of --report-only are not run, not failed
    assert ck.settle(ck.Check("t", True, "", ("m",)), _rows(m="missing")).outcome == ck.NOT_RUN


def test_failed_run_fails_every_check_that_reads_it() -> None:
    rows = {**paper_like_rows(), **policy_rows()}
    for bad in ("s4-ukf-fb-nmpc", "s3-ukf-safe-yaw-nmpc-rp"):
        rows[bad] = {"label": bad, "status": "failed", "error": "TypeError: shape"}
    n = 0
    for c in evaluate_all(rows):
        for ch in c.checks:
            if {"s4-ukf-fb-nmpc", "s3-ukf-safe-yaw-nmpc-rp"} & set(ch.runs):
                assert ch.outcome == ck.FAIL, (c.id, ch.text)
                n += 1
    assert n > 10


def test_check_texts_do_not_depend_on_the_numbers() -> None:
    """Seeds are matched check by check: the same checks, in the same order, whatever the rows."""
    a = {**paper_like_rows(), **policy_rows()}
    b = {lb: {"status": "ok"} for lb in a}
    for rows in (b, {}):
        for x, y in zip(evaluate_all(a), evaluate_all(rows), strict=True):
            assert [ch.text for ch in x.checks] == [ch.text for ch in y.checks]
