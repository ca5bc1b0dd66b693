"""Claim P1 (path following) on synthetic rows: the thresholds decide, the axis has its 11 runs."""

from __future__ import annotations

from ftc_mj.paper.claims.pathfollow import _label
from ftc_mj.paper.matrix import pathfollow_runs
from tests.paper.rows import judge


def test_pathfollow_claim_checks_the_thresholds() -> None:
    """P1 on synthetic rows: a pf-nmpc that meets every threshold passes, one that lifts a wheel for 0.3 s in
    scenario 3 fails that check only; the path-following axis has its 11 runs with unique labels."""
    runs = pathfollow_runs()
    assert len(runs) == 11 and len({e.label for e in runs}) == 11
    good = {"status": "ok", "contouring_max_recovered": 0.3, "liftoff_time_post_transient_s": 0.1, "tipped": False,
            "cross_track_max_settled": 0.4, "speed_ratio_final": 1.02, "speed_mean_final": 10.02}
    rows = {e.label: dict(good) for e in runs}
    rows[_label("scenario1", "pf-nmpc", "safe", "speed+yaw")]["cross_track_max_settled"] = 0.05
    for sc in ("scenario2", "scenario3", "scenario4"):
        rows[_label(sc, "nmpc", "safe", "speed+yaw")] = dict(good, liftoff_time_post_transient_s=3.0)
    claim = judge(rows, every_family=True)["P1"]
    assert claim.verdict == "reproduced" and all(c.passed for c in claim.checks)
    rows[_label("scenario3", "pf-nmpc", "safe", "speed+yaw")]["liftoff_time_post_transient_s"] = 0.3
    claim = judge(rows, every_family=True)["P1"]
    assert [c.passed for c in claim.checks].count(False) == 1 and not claim.checks[1].passed
    assert any("3 s" in n for n in claim.notes[0])
