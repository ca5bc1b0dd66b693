"""Claims R1–R3 on the reconfiguration-policy axis: verdicts follow the numbers, missing runs are not
evaluated."""

from __future__ import annotations

import copy

import numpy as np

from ftc_mj.config import load_config
from ftc_mj.paper.claims import checks as ck
from ftc_mj.paper.claims.policy import evaluate_policy_claims, plabel
from tests.paper.rows import judge, policy_rows


def _verdicts(rows: dict) -> dict[str, str]:
    return {cid: c.verdict for cid, c in judge(rows, every_family=True).items() if cid.startswith("R")}


def test_policy_claims_follow_the_numbers() -> None:
    rows = policy_rows()
    assert _verdicts(rows) == {"R1": ck.REPRODUCED, "R2": ck.REPRODUCED, "R3": ck.REPRODUCED}
    bad = copy.deepcopy(rows)
    bad[plabel("scenario2", "direct", "speed")]["cross_track_max_recovered"] = 120.0  # direct runs away
    assert _verdicts(bad)["R1"] == ck.PARTLY
    bad = copy.deepcopy(rows)
    bad[plabel("scenario3", "safe", "yaw")]["tipped"] = True  # safe tips where none did not
    assert _verdicts(bad)["R2"] == ck.PARTLY
    bad[plabel("scenario3", "none", "yaw")]["tipped"] = True  # ... unless none tipped as well
    assert _verdicts(bad)["R2"] == ck.REPRODUCED
    bad = copy.deepcopy(rows)
    bad[plabel("scenario2", "safe", "yaw")]["reconfig_handover_delay"] = 3.0  # too late
    assert _verdicts(bad)["R3"] == ck.PARTLY
    bad = copy.deepcopy(rows)
    bad[plabel("scenario4", "safe", "yaw")]["omega_at_limit_s"] = 1.0  # more saturation than none (+0.05 s)
    assert _verdicts(bad)["R2"] == ck.PARTLY


def test_policy_claims_without_the_axis_are_not_evaluated() -> None:
    assert set(_verdicts({}).values()) == {ck.NOT_EVALUATED}


def test_safe_without_hand_over_is_na_and_infeasible_reference_is_na() -> None:
    rows = policy_rows()
    no_hand = copy.deepcopy(rows)
    no_hand["s3-ukf-safe-speed-nmpc-rp"]["reconfig_handovers"] = 0
    r2 = next(c for c in evaluate_policy_claims(no_hand) if c.id == "R2")
    s3_speed = [ch for ch in r2.checks if ch.text.startswith("scenario 3, speed:")]
    assert len(s3_speed) == 4 and all(ch.outcome == ck.NA for ch in s3_speed)
    infeasible = copy.deepcopy(rows)
    infeasible["s4-ukf-safe-yaw-nmpc-rp"].update(reference_feasible_recovered=False,
                                                  reference_omega_required_recovered=98.0)
    r3 = next(c for c in evaluate_policy_claims(infeasible) if c.id == "R3")
    assert [ch.outcome for ch in r3.checks if ch.text.startswith("scenario 4")] == [ck.PASS, ck.NA]


def test_safe_without_hand_over_is_the_none_run() -> None:
    """R2's precondition: a safe run that never hands over is the none run (speed only: the split is not
    identified, so nothing is handed over). Kinematic plant, 12 s; every trace column but timings equal."""
    from ftc_mj.sim.run import execute

    ov = {"plant.kind": "kinematic", "duration": 12.0, "controller.rate_penalty": 1.0}
    none = execute(load_config("scenario2", {**ov, "reconfiguration.policy": "none"}))
    safe = execute(load_config("scenario2", {**ov, "reconfiguration.policy": "safe"}))
    assert safe.metrics["reconfig_handovers"] == 0
    for col in ("x", "y", "psi", "omega_R_cmd", "omega_L_cmd", "R_R_hat", "R_L_hat", "cross_track_error"):
        np.testing.assert_array_equal(safe.result.trace[col], none.result.trace[col], err_msg=col)
