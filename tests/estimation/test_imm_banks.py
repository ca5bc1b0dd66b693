"""Configured IMM banks (``estimator.imm_bank``): validation, and closed-loop runs whose bank is not the
paper's — 30 % punctures in 4 members in another order, and 3 members — decided correctly."""

from __future__ import annotations

import pytest

import ftc_mj
from ftc_mj.errors import BadInput

BANK4 = [{"name": "left 30 %", "frac_L": 0.7}, {"name": "no fault"},
         {"name": "both 30 %", "frac_R": 0.7, "frac_L": 0.7}, {"name": "right 30 %", "frac_R": 0.7}]
BANK3 = [{"name": "no fault"}, {"name": "right 30 %", "frac_R": 0.7}, {"name": "left 30 %", "frac_L": 0.7}]
RUN = {"duration": 6.0, "plant.kind": "kinematic", "sensors.yaw_rate_sigma": 0.01, "estimator.kind": "imm-ukf",
       "reconfiguration.policy": "none", "faults.left": [[2.0, 2.0], [2.0, 1.4]]}
"""A 30 % left puncture (2 m → 1.4 m) at 2 s, seen for 4 s with a gyro, on the kinematic plant."""


def test_bank_config_is_validated() -> None:
    IMM = {"estimator.kind": "imm-ukf"}  # the bank's settings are an IMM kind's
    with pytest.raises(BadInput, match=r"^estimator.imm_models: give either imm_models"):
        ftc_mj.load_config("scenario2", {**IMM, "estimator.imm_models": 5, "estimator.imm_bank": BANK3})
    with pytest.raises(BadInput, match=r"^estimator.imm_bank: hypothesis names must differ"):
        ftc_mj.load_config("scenario2", {**IMM, "estimator.imm_bank": [{"name": "a"}, {"name": "a"}]})
    with pytest.raises(BadInput, match=r"^estimator.imm_bank\[1\].frac_L: must be a finite number in \(0, 1\]"):
        ftc_mj.load_config("scenario2", {**IMM, "estimator.imm_bank": [{"name": "a"}, {"name": "b", "frac_L": 1.5}]})
    with pytest.raises(BadInput, match=r"^estimator.imm_bank: List should have at least 2 items"):
        ftc_mj.load_config("scenario2", {**IMM, "estimator.imm_bank": [{"name": "a"}]})


@pytest.mark.parametrize(("bank", "tag"), [(BANK4, "imm-ukf4c"), (BANK3, "imm-ukf3c")])
def test_a_bank_other_than_the_papers_isolates_the_left_puncture(bank: list[dict], tag: str) -> None:
    run = ftc_mj.run("scenario2", overrides={**RUN, "estimator.imm_bank": bank})
    m = run.metrics
    assert m["status"] == "ok" and tag in run.run_id and m["imm_models"] == len(bank)
    assert m["isolated_wheel"] == "left" and m["false_alarm"] is False, m
    # the member hypothesising the true radius pins it at 1.4 m within hypothesis_sigma (0.05 m)
    assert abs(m["radius_final_error_L"]) < 0.05, m["radius_final_error_L"]
    # the declaration follows the onset by the dwell plus the time the bank needs (< 1 s)
    dwell = run.config.estimator.decision.dwell
    assert dwell <= m["detection_delay"] < dwell + 1.0, (m["detection_delay"], dwell)
    assert [c for c in run.trace.columns if c.startswith("mode_prob_")] == [f"mode_prob_{j + 1}"
                                                                            for j in range(len(bank))]
