"""Claims R1–R3 on the reconfiguration-policy axis: verdicts follow the numbers, missing runs are not
evaluated."""

from __future__ import annotations

import copy

from ftc_mj.report import claims as cl
from ftc_mj.report.matrix import policy_runs
from ftc_mj.report.policy_claims import evaluate_policy_claims, plabel


def _rows() -> dict[str, dict]:
    """A world where direct and safe both help and safe hands over 0.5 s after the fault."""
    rows = {}
    for e in policy_runs():
        ct = {"none": 2.0, "direct": 0.3, "safe": 0.4}[e.policy]
        rows[e.label] = {"status": "ok", "cross_track_max_recovered": ct, "cross_track_final": -ct / 2,
                         "omega_at_limit_s": 0.0, "liftoff_time_post_transient_s": 0.0, "tipped": False,
                         "reconfig_handover_delay": 0.5 if e.policy == "safe" else None,
                         "reconfig_first_handover_time": 12.2 if e.policy == "safe" else None,
                         "detection_time": 11.7, "reconfig_handovers": 1 if e.policy == "safe" else 0,
                         "reconfig_reverts": 0, "reconfig_holds": 0}
    return rows


def _verdicts(rows: dict) -> dict[str, str]:
    return {c.id: c.verdict for c in evaluate_policy_claims(rows)}


def test_policy_claims_follow_the_numbers() -> None:
    rows = _rows()
    assert _verdicts(rows) == {"R1": cl.REPRODUCED, "R2": cl.REPRODUCED, "R3": cl.REPRODUCED}
    bad = copy.deepcopy(rows)
    bad[plabel("scenario2", "direct", "speed")]["cross_track_max_recovered"] = 120.0  # direct runs away
    assert _verdicts(bad)["R1"] == cl.PARTLY
    bad = copy.deepcopy(rows)
    bad[plabel("scenario3", "safe", "yaw")]["tipped"] = True  # safe tips where none did not
    assert _verdicts(bad)["R2"] == cl.PARTLY
    bad[plabel("scenario3", "none", "yaw")]["tipped"] = True  # ... unless none tipped as well
    assert _verdicts(bad)["R2"] == cl.REPRODUCED
    bad = copy.deepcopy(rows)
    bad[plabel("scenario2", "safe", "yaw")]["reconfig_handover_delay"] = 3.0  # too late
    assert _verdicts(bad)["R3"] == cl.PARTLY
    bad = copy.deepcopy(rows)
    bad[plabel("scenario4", "safe", "yaw")]["omega_at_limit_s"] = 1.0  # more saturation than none (+0.05 s)
    assert _verdicts(bad)["R2"] == cl.PARTLY


def test_policy_claims_without_the_axis_are_not_evaluated() -> None:
    assert set(_verdicts({}).values()) == {cl.NOT_EVALUATED}


def test_pathfollow_claim_checks_the_thresholds() -> None:
    """P1 on synthetic rows: a pf-nmpc that meets every threshold passes, one that lifts a wheel for 0.3 s in
    scenario 3 fails that check only; the path-following axis has its 11 runs with unique labels."""
    from ftc_mj.report.matrix import pathfollow_runs
    from ftc_mj.report.pathfollow_claims import _label, evaluate_pathfollow_claims

    runs = pathfollow_runs()
    assert len(runs) == 11 and len({e.label for e in runs}) == 11
    good = {"status": "ok", "contouring_max_recovered": 0.3, "liftoff_time_post_transient_s": 0.1, "tipped": False,
            "cross_track_max_settled": 0.4, "speed_ratio_final": 1.02, "speed_mean_final": 10.02}
    rows = {e.label: dict(good) for e in runs}
    rows[_label("scenario1", "pf-nmpc", "safe", "speed+yaw")]["cross_track_max_settled"] = 0.05
    for sc in ("scenario2", "scenario3", "scenario4"):
        rows[_label(sc, "nmpc", "safe", "speed+yaw")] = dict(good, liftoff_time_post_transient_s=3.0)
    (claim,) = evaluate_pathfollow_claims(rows)
    assert claim.verdict == "reproduced" and all(c.passed for c in claim.checks)
    rows[_label("scenario3", "pf-nmpc", "safe", "speed+yaw")]["liftoff_time_post_transient_s"] = 0.3
    (claim,) = evaluate_pathfollow_claims(rows)
    assert [c.passed for c in claim.checks].count(False) == 1 and not claim.checks[1].passed
    assert any("3 s" in n for n in claim.notes)
