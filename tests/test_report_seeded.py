"""Verdicts over seeds: the outcome rules of a check, the Wilson verdict rule, the aggregation over
seeds, the comparison with a baseline, the seed sets and the generated matrix study."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ftc_mj.config import load_config, validate_config
from ftc_mj.errors import BadInput
from ftc_mj.report import checks as ck
from ftc_mj.report import claims as cl
from ftc_mj.report.compare import claims_document, compare, load_baseline
from ftc_mj.report.matrix import full_matrix
from ftc_mj.report.matrix_study import AXIS, load_matrix_study
from ftc_mj.report.policy_claims import evaluate_policy_claims
from ftc_mj.report.seeded import FAILS, HOLDS, UNDECIDED, CheckStats, combine, summarise, verdict_over_seeds
from ftc_mj.report.seeds import DEV_SEEDS, HELD_OUT_START, seed_set
from tests.test_report_claims import paper_like_rows
from tests.test_report_policy_claims import _rows as policy_rows


# ---------------------------------------------------------------------------------------- outcome rules
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


def test_single_seed_verdict_ignores_na() -> None:
    assert ck.verdict_of([ck.PASS, ck.NA, ck.NOT_RUN]) == ck.REPRODUCED
    assert ck.verdict_of([ck.NA]) == ck.NOT_EVALUATED


def test_failed_run_fails_every_check_that_reads_it() -> None:
    rows = paper_like_rows()
    rows["s4-ukf-fb-nmpc"] = {"label": "s4-ukf-fb-nmpc", "status": "failed", "error": "TypeError: shape"}
    for c in cl.evaluate_claims(rows):
        for ch in c.checks:
            if "s4-ukf-fb-nmpc" in ch.runs:
                assert ch.outcome == ck.FAIL, (c.id, ch.text)


# ---------------------------------------------------------------------------------------- preconditions of the claims
def _check(claims: list[ck.Claim], cid: str, text_part: str) -> ck.Check:
    c = next(c for c in claims if c.id == cid)
    return next(ch for ch in c.checks if text_part in ch.text)


def test_claim_1_checks_the_innovation_peak() -> None:
    rows = paper_like_rows()
    rows["s2-ukf-nofb-nmpc"]["innovation_peak_z_1"] = cl.PEAK_Z - 0.5
    ch = _check(cl.evaluate_claims(rows), "1", "UKF fb off: innovation peak")
    assert ch.outcome == ck.FAIL


def test_comparisons_identical_by_construction_are_na() -> None:
    claims = cl.evaluate_claims(paper_like_rows())
    for part in ("fb off: UKF R_L error below the EKF's", "fb off: the UKF keeps the robot on the path the longest",
                 "fb off: the UKF is the only one"):
        assert _check(claims, "6", part).outcome == ck.NA
    assert _check(claims, "10", "fb off: UKF better than EKF").outcome == ck.NA
    assert _check(claims, "6", "fb on: UKF R_L error below the EKF's").outcome in (ck.PASS, ck.FAIL)


def test_in_domain_selection_is_na_below_its_stated_share() -> None:
    rows = paper_like_rows()
    rows["s4-imm-ukf5-fb-nmpc"]["out_of_domain_fraction_after_fault"] = 1.0 - cl.MIN_IN_DOMAIN / 2
    ch = _check(cl.evaluate_claims(rows), "4", "IMM-UKF-5 fb on succeeds while")
    assert ch.outcome == ck.NA and "in the domain" in ch.na
    rows["s4-imm-ukf5-fb-nmpc"]["out_of_domain_fraction_after_fault"] = 0.5
    ch = _check(cl.evaluate_claims(rows), "4", "IMM-UKF-5 fb on succeeds while")
    assert ch.outcome == ck.PASS and "excluded share 0.5" in ch.detail


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


def test_check_texts_do_not_depend_on_the_numbers() -> None:
    """Seeds are matched check by check: the same checks, in the same order, whatever the rows."""
    a = paper_like_rows()
    b = {lb: {"status": "ok"} for lb in a}
    for rows in (b, {}):
        for x, y in zip(cl.evaluate_claims(a) + evaluate_policy_claims(a),
                        cl.evaluate_claims(rows) + evaluate_policy_claims(rows), strict=True):
            assert [ch.text for ch in x.checks] == [ch.text for ch in y.checks]


# ---------------------------------------------------------------------------------------- the rule over seeds
def _stats(n_pass: int, n_fail: int, n_na: int = 0) -> CheckStats:
    st = CheckStats("t")
    outs = [ck.PASS] * n_pass + [ck.FAIL] * n_fail + [ck.NA] * n_na
    st.outcomes = dict(enumerate(outs))
    return st


def test_wilson_rule_holds_fails_and_undecided() -> None:
    # Wilson 95 %: 9/10 → [0.60, 0.98] holds; 8/10 → [0.49, 0.94] undecided; 1/10 → [0.02, 0.40] fails
    assert _stats(9, 1).result == HOLDS
    assert _stats(8, 2).result == UNDECIDED
    assert _stats(1, 9).result == FAILS
    assert _stats(2, 8).result == UNDECIDED
    iv = _stats(9, 1).interval
    assert iv.lo == pytest.approx(0.596, abs=1e-3) and iv.hi == pytest.approx(0.982, abs=1e-3)
    # n/a seeds are not passes: 3 passes and 7 n/a is 3/3, undecided, not 10/10
    st = _stats(3, 0, 7)
    assert (st.passed, st.applicable, st.count(ck.NA)) == (3, 3, 7) and st.result == UNDECIDED
    assert _stats(0, 0, 10).result == ck.NA


def test_claim_verdict_over_seeds() -> None:
    assert verdict_over_seeds([HOLDS, HOLDS, ck.NA]) == ck.REPRODUCED
    assert verdict_over_seeds([FAILS, ck.NA]) == ck.NOT_REPRODUCED
    assert verdict_over_seeds([UNDECIDED, UNDECIDED]) == "undecided"
    assert verdict_over_seeds([HOLDS, UNDECIDED]) == ck.PARTLY
    assert verdict_over_seeds([HOLDS, FAILS]) == ck.PARTLY
    assert verdict_over_seeds([ck.NA, ck.NOT_RUN]) == ck.NOT_EVALUATED


def _per_seed(n: int, bad_seeds: set[int]) -> dict[int, list[ck.Claim]]:
    out = {}
    for s in range(n):
        rows = paper_like_rows()
        if s in bad_seeds:  # the EKF with feedback does not declare the fault in these seeds
            rows["s2-ekf-fb-nmpc"]["detection_delay"] = None
        out[s] = cl.evaluate_claims(rows)
    return out


def test_combine_counts_every_check_over_the_seeds() -> None:
    claims = combine(_per_seed(10, {3}))
    c1 = claims[0]
    st = next(ch for ch in c1.checks if ch.text.startswith("EKF fb on declares"))
    assert (st.passed, st.applicable, st.failing_seeds()) == (9, 10, [3])
    assert st.result == HOLDS and c1.verdict == ck.REPRODUCED
    claims = combine(_per_seed(10, {1, 3, 5}))  # 7/10: undecided → claim 1 is only partly reproduced
    assert claims[0].verdict == ck.PARTLY
    assert claims[0].table()[0]["run"] == "s2-ekf-nofb-nmpc"


def test_combine_refuses_seeds_with_other_checks() -> None:
    per = _per_seed(2, set())
    per[1][0].checks.pop()
    with pytest.raises(ValueError, match="other checks"):
        combine(per)


def test_summarise_cells_over_seeds() -> None:
    assert summarise([1.0, 3.0, 2.0]) == "2 [1, 3]"
    assert summarise([True, False, True]) == "2/3"
    assert summarise(["left", "left"]) == "left" and summarise(["left", "right"]) == "mixed"
    assert summarise([None, 2.0, 4.0]) == "3 [2, 4] (n=2)"
    assert summarise([None, None]) is None


# ---------------------------------------------------------------------------------------- comparison
def test_compare_with_a_single_seed_baseline() -> None:
    single = cl.evaluate_claims(paper_like_rows())
    base = json.loads(json.dumps(claims_document(single, [0], "single-seed")))
    seeded = combine(_per_seed(10, {1, 3, 5}))
    cur = json.loads(json.dumps(claims_document(seeded, range(10), "seeded")))
    lines = compare(cur, base)
    assert any("verdict reproduced → partly" in ln for ln in lines)
    changed = [ln for ln in lines if "EKF fb on declares" in ln]
    assert len(changed) == 1 and "pass → undecided (7/10" in changed[0]
    # a pass that holds over seeds is no change
    assert not any("UKF fb on declares" in ln for ln in lines)
    assert compare(base, base) == []


def test_baseline_from_a_rendered_claims_md(tmp_path: Path) -> None:
    from ftc_mj.report.render import render_claims

    rows = paper_like_rows()
    rows["s2-ekf-fb-nmpc"]["detection_delay"] = None  # claim 1 partly, the others reproduced
    claims = cl.evaluate_claims(rows)
    md = tmp_path / "claims.md"
    md.write_text(render_claims(claims, rows, {}))
    base = load_baseline(md)
    assert {c["id"]: c["verdict"] for c in base["claims"]} == {c.id: c.verdict for c in claims}
    assert base["claims"][0]["verdict"] == ck.PARTLY


def test_baseline_from_an_old_paper_run_json(tmp_path: Path) -> None:
    (tmp_path / "paper_run.json").write_text(json.dumps({"verdicts": {"1": "reproduced", "2": "partly"}}))
    base = load_baseline(tmp_path)
    seeded = combine(_per_seed(3, set()))
    lines = compare(json.loads(json.dumps(claims_document(seeded, range(3), "seeded"))), base)
    assert any(ln.startswith("- claim 1") and "reproduced → undecided" in ln for ln in lines)
    with pytest.raises(BadInput, match="--baseline"):
        load_baseline(tmp_path / "nothing")


# ---------------------------------------------------------------------------------------- seeds and the study
def test_seed_sets() -> None:
    assert seed_set("dev", 3) == (0, 1, 2) and len(seed_set("dev", 10)) == 10
    assert seed_set("held-out", 2) == (HELD_OUT_START, HELD_OUT_START + 1)
    assert not set(seed_set("held-out", 50)) & set(DEV_SEEDS)
    for bad in (("dev", 11), ("held-out", 0), ("other", 1)):
        with pytest.raises(BadInput):
            seed_set(*bad)


def test_no_study_file_uses_the_held_out_seeds() -> None:
    from ftc_mj.resources import resource_path
    from ftc_mj.study.spec import load_study

    for f in sorted(resource_path("studies").glob("*.toml")):
        assert max(r.seed for r in load_study(f).runs) < HELD_OUT_START, f.name


def test_tuning_studies_run_on_the_development_seeds() -> None:
    import tomllib

    from ftc_mj.report.tuning import STUDY_DIR, TUNED

    for t in TUNED:
        data = tomllib.loads((STUDY_DIR / f"{t.study}.toml").read_text())
        assert tuple(data["seeds"]) == DEV_SEEDS


def test_matrix_study_configs_equal_the_matrix_entries(tmp_path: Path) -> None:
    entries = full_matrix()
    plan = load_matrix_study(entries, [5, 1001], 12.0, tmp_path, write=False)
    assert not any(tmp_path.iterdir())  # write=False: nothing on disk
    assert len(plan.runs) == 2 * len(entries)
    by_label = {e.label: e for e in entries}
    for r in plan.runs:
        e = by_label[r.labels[AXIS]]
        want = load_config(e.scenario, dict(e.overrides, seed=r.seed, duration=12.0))
        assert validate_config(r.config).model_dump() == want.model_dump(), e.label


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
