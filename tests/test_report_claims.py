"""The paper matrix and the claim-verdict logic of ``ftc-mj paper``, on synthetic summary rows."""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
import pytest

from ftc_mj.report import claims as cl
from ftc_mj.report.derived import command_switching, innovation_peak_z, mode_delays, settle_delay
from ftc_mj.report.matrix import full_matrix, paper_matrix, pathfollow_runs, select
from ftc_mj.report.render import render_claims
from ftc_mj.report.summary import read_summary_csv, write_summary_csv


# ---------------------------------------------------------------------------------------- matrix
def test_matrix_has_the_papers_38_runs() -> None:
    m = paper_matrix()
    assert len(m) == 38
    labels = [e.label for e in m]
    assert len(set(labels)) == 38
    combos = {(e.scenario, e.estimator, e.imm_models, e.feedback, e.controller) for e in m}
    assert len(combos) == 38
    # 32 = 4 scenarios x 4 filters x fb off/on, NMPC, 4-model IMMs
    for sc in ("scenario1", "scenario2", "scenario3", "scenario4"):
        for est in ("ekf", "ukf", "imm-ekf", "imm-ukf"):
            for fb in (False, True):
                models = 4 if est.startswith("imm") else None
                assert (sc, est, models, fb, "nmpc") in combos
    # 4 = scenario 4, 5-model IMMs, fb off/on
    for est in ("imm-ekf", "imm-ukf"):
        for fb in (False, True):
            assert ("scenario4", est, 5, fb, "nmpc") in combos
    # 2 = LMPC with UKF and feedback, scenarios 2 and 4
    lmpc = [e for e in m if e.controller == "lmpc"]
    assert {(e.scenario, e.estimator, e.feedback) for e in lmpc} == {("scenario2", "ukf", True),
                                                                      ("scenario4", "ukf", True)}
    assert all(not e.extra for e in m)
    assert all(e.imm_variant in (None, "hypothesis") for e in m)


def test_extras_are_the_literal_imm_variant() -> None:
    full = full_matrix(extras=True)
    extras = [e for e in full if e.extra]
    literal = [e for e in extras if e.estimator.startswith("imm")]
    assert len(literal) == 2
    assert all(e.imm_variant == "paper" and e.overrides["estimator.imm_variant"] == "paper" for e in literal)
    assert len(full_matrix(extras=False)) == 38
    # the reconfiguration-policy axis: scenarios 2-4 x {none, direct, safe} x {speed, speed+yaw}, UKF, NMPC
    pf = {e.label for e in pathfollow_runs()}
    policy = [e for e in extras if not e.estimator.startswith("imm") and e.label not in pf]
    assert len(policy) == 18 and len({e.label for e in policy}) == 18
    assert {(e.scenario, e.policy, e.sensing) for e in policy} == {
        (f"scenario{n}", p, s) for n in (2, 3, 4) for p in ("none", "direct", "safe") for s in ("speed", "speed+yaw")}
    assert all(e.estimator == "ukf" and e.controller == "nmpc" and e.rate_penalty > 0 for e in policy)


def test_select_by_glob() -> None:
    m = full_matrix()
    assert [e.label for e in select(m, ["s4-imm-ukf5-*"])] == ["s4-imm-ukf5-nofb-nmpc", "s4-imm-ukf5-fb-nmpc"]
    assert len(select(m, ["s1-*", "s2-*"])) == 8 + 9 + 2 + 6 + 2 + 3  # + the path-following axis' s1 and s2 runs
    assert [e.label for e in select(m, ["s2-ukf-safe-speed-nmpc-rp", "s2-ukf-safe-yaw-nmpc-rp"])] == [
        "s2-ukf-safe-speed-nmpc-rp", "s2-ukf-safe-yaw-nmpc-rp"]
    assert [e.label for e in select(m, ["s2-ukf-safe-*-pf-nmpc-rp"])] == ["s2-ukf-safe-yaw-pf-nmpc-rp",
                                                                          "s2-ukf-safe-speed-pf-nmpc-rp"]
    assert select(m, None) == m
    assert select(m, ["nothing"]) == []


# ---------------------------------------------------------------------------------------- derived metrics
def test_settle_delay() -> None:
    t = np.arange(0, 20, 0.01)
    err = np.where(t < 12.0, 1.0, 0.01)
    assert settle_delay(t, err, 10.0) == pytest.approx(2.0, abs=0.011)
    assert settle_delay(t, np.ones_like(t), 10.0) is None
    # a transient dip below the tolerance that does not hold does not count
    err2 = np.where((t > 11) & (t < 11.2), 0.0, err)
    assert settle_delay(t, err2, 10.0) == pytest.approx(2.0, abs=0.011)


def test_innovation_peak_z_separates_a_step_from_noise() -> None:
    rng = np.random.default_rng(0)
    t = np.arange(0, 20, 0.01)
    inn = rng.normal(0, 0.5, t.size)
    sd = np.full(t.size, 0.5)
    z_noise = innovation_peak_z(t, inn, sd, 10.0)
    inn_fault = inn + np.where((t >= 10) & (t < 10.5), 2.5, 0.0)
    z_fault = innovation_peak_z(t, inn_fault, sd, 10.0)
    assert z_noise is not None and z_fault is not None
    assert z_noise < cl.PEAK_Z < z_fault


def test_mode_delays() -> None:
    t = np.arange(0, 20, 0.01)
    p = np.zeros((t.size, 4))
    p[:, 0] = 1.0
    late = t >= 10.3
    p[late, 0], p[late, 2] = 0.0, 1.0
    delays, frac = mode_delays(t, p, [(0.0, 1), (10.0, 3)])
    assert delays[0] == pytest.approx(0.0)
    assert delays[1] == pytest.approx(0.3, abs=0.011)
    assert frac == pytest.approx(1 - 0.3 / 20, abs=0.002)


def test_command_switching_counts_bang_bang() -> None:
    t = np.arange(0, 10, 0.01)
    wmax = 17.45
    square = np.where((np.arange(t.size) // 50) % 2 == 0, wmax, -wmax)  # switches every 0.5 s
    rev, sw = command_switching(t, square, wmax)
    assert sw == pytest.approx(2.0, rel=0.05)
    assert rev == pytest.approx(2.0, rel=0.15)  # n steps give n - 1 reversals
    smooth = np.full(t.size, 5.0)
    assert command_switching(t, smooth, wmax) == (0.0, 0.0)


# ---------------------------------------------------------------------------------------- claims
def _parse(label: str) -> dict[str, Any]:
    parts = label.split("-")
    sc = int(parts[0][1:])
    variant = "paper" if label.endswith("-paper") else "hypothesis"
    if variant == "paper":
        parts = parts[:-1]
    ctrl, fb = parts[-1], parts[-2] == "fb"
    est = "-".join(parts[1:-2])
    models = 5 if est.endswith("5") else 4
    return {"sc": sc, "est": est.rstrip("5"), "fb": fb, "ctrl": ctrl, "models": models, "variant": variant}


def paper_like_rows() -> dict[str, dict[str, Any]]:
    """Rows that tell the paper's story (including its scenario 3 UKF anomaly)."""
    rows: dict[str, dict[str, Any]] = {}
    for e in full_matrix():
        p = _parse(e.label)
        sc, est, fb, ctrl, models = p["sc"], p["est"], p["fb"], p["ctrl"], p["models"]
        imm = est.startswith("imm")
        r: dict[str, Any] = {
            "label": e.label, "status": "ok", "detection_delay": 0.3, "detection_time": 10.3, "false_alarm": False,
            "innovation_peak_z_1": 12.0, "innovation_peak_z_2": 11.0, "radius_rmse_R": 0.04, "radius_rmse_L": 0.05,
            "innovation_in_2sigma": 0.955, "cross_track_max_settled": 0.4, "mode_delay_0": 0.05,
            "mode_delay_1": 0.2, "mode_delay_2": 0.3, "radius_rmse_L_after_fault": 0.08,
            "radius_final_error_L": 0.02, "innovation_in_2sigma_after_fault": 0.95, "filter_resets": 0,
            "radius_rmse_L_after_fault_in_domain": 0.05,
            "cross_track_max_after_fault": 1.0 if fb else 9.0, "time_on_path_after_fault": 30.0,
            "innovation_std_median_after_fault": 0.5, "cmd_reversals_per_s": 2.0,
            "omega_at_limit_fraction_after_fault": 0.1, "command_total_variation_per_s": 5.0,
            "settle_delay_L": (0.5 if imm else 3.0) * (1.0 if fb else 2.0),
            "settle_delay_R": (0.5 if imm else 3.0) * (1.0 if fb else 2.0),
            "radius_rmse_L_early": 0.1 if imm else 0.3, "radius_rmse_mean": {"ekf": 0.15, "ukf": 0.1}.get(est, 0.05),
            "time_off_path": None if fb else 12.0,
        }
        if sc == 4:
            r["omega_at_limit_fraction_after_fault"] = 0.7
            r["cross_track_max_after_fault"] = 12.0
            r["time_on_path_after_fault"] = 5.0
            if imm and models == 4:
                r["radius_rmse_L_after_fault"], r["radius_final_error_L"] = 0.8, 0.9
            if est == "ekf":
                r["radius_rmse_L_after_fault"] = 0.25 if not fb else 0.9
                r["innovation_in_2sigma_after_fault"] = 0.95 if not fb else 0.6
            if est == "ukf":
                r["time_on_path_after_fault"] = 15.0
                r["radius_rmse_L_early"] = 0.3
            if ctrl == "lmpc":
                r["cross_track_max_after_fault"] = 30.0
        if sc == 2 and ctrl == "lmpc":
            r.update(cross_track_max_after_fault=20.0, innovation_std_median_after_fault=1.0,
                     command_total_variation_per_s=20.0)
        if sc == 3 and est == "ukf" and fb:  # the paper's anomaly
            r.update(time_off_path=12.0, cross_track_max_after_fault=6.0)
        rows[e.label] = r
    return rows


def _by_id(rows: dict[str, dict[str, Any]]) -> dict[str, cl.Claim]:
    return {c.id: c for c in cl.evaluate_claims(rows)}


def test_paper_story_reproduces_every_claim_but_its_own_contradiction() -> None:
    claims = _by_id(paper_like_rows())
    assert len(claims) >= 10
    for cid, c in claims.items():
        if cid == "2":
            # the paper's own scenario 3 UKF anomaly contradicts "feedback keeps it on the path"
            assert c.verdict == cl.PARTLY
            assert c.n_evaluated == 8 and c.n_passed == 7
        else:
            assert c.verdict == cl.REPRODUCED, (cid, [(k.text, k.detail) for k in c.checks if not k.passed])


def test_verdicts_flip_with_the_numbers() -> None:
    rows = paper_like_rows()
    # a physical plant where feedback does not help: both on and off the path
    bad = copy.deepcopy(rows)
    for lb, r in bad.items():
        if lb.startswith(("s2-", "s3-")):
            r["cross_track_max_after_fault"] = 30.0
    assert _by_id(bad)["2"].verdict == cl.NOT_REPRODUCED
    # no filter detects scenario 2: the declarations fail, the innovation peaks still pass
    bad = copy.deepcopy(rows)
    for lb, r in bad.items():
        if lb.startswith("s2-"):
            r["detection_delay"] = None
    assert _by_id(bad)["1"].verdict == cl.PARTLY
    # ... and without a peak in the innovations at the fault nothing of claim 1 holds
    for lb, r in bad.items():
        if lb.startswith("s2-"):
            r["innovation_peak_z_1"] = cl.PEAK_Z - 3.0
    assert _by_id(bad)["1"].verdict == cl.NOT_REPRODUCED
    # one filter detects late -> partly
    bad = copy.deepcopy(rows)
    bad["s2-ekf-fb-nmpc"]["detection_delay"] = cl.DETECT_MAX_DELAY + 1.0
    assert _by_id(bad)["1"].verdict == cl.PARTLY
    # a false alarm is not a detection
    bad = copy.deepcopy(rows)
    bad["s2-ekf-fb-nmpc"]["false_alarm"] = True
    assert _by_id(bad)["1"].verdict == cl.PARTLY
    # the 5-model IMMs fail too
    bad = copy.deepcopy(rows)
    for lb in ("s4-imm-ekf5-nofb-nmpc", "s4-imm-ekf5-fb-nmpc", "s4-imm-ukf5-nofb-nmpc", "s4-imm-ukf5-fb-nmpc"):
        bad[lb]["radius_rmse_L_after_fault"] = 0.9
    assert _by_id(bad)["4"].verdict == cl.PARTLY
    # the EKF does not break down with feedback, and its no-feedback run does
    bad = copy.deepcopy(rows)
    bad["s4-ekf-fb-nmpc"].update(innovation_in_2sigma_after_fault=0.97, radius_rmse_L_after_fault=0.1)
    bad["s4-ekf-nofb-nmpc"].update(filter_resets=3)
    bad["s4-ukf-fb-nmpc"].update(innovation_in_2sigma_after_fault=0.5)
    bad["s4-ukf-nofb-nmpc"].update(innovation_in_2sigma_after_fault=0.5)
    assert _by_id(bad)["5"].verdict == cl.NOT_REPRODUCED
    # LMPC tracks as well as the NMPC and with the same switching
    bad = copy.deepcopy(rows)
    bad["s2-ukf-fb-lmpc"].update(cross_track_max_after_fault=1.0, command_total_variation_per_s=5.0)
    c7, c8 = _by_id(bad)["7"], _by_id(bad)["8"]
    assert c7.verdict == cl.PARTLY and c8.verdict == cl.PARTLY
    # the UKF settles first (IMMs never)
    bad = copy.deepcopy(rows)
    for lb in ("s2-imm-ekf-nofb-nmpc", "s2-imm-ekf-fb-nmpc", "s2-imm-ukf-nofb-nmpc", "s2-imm-ukf-fb-nmpc"):
        bad[lb]["settle_delay_L"] = None
    for lb in ("s4-imm-ekf5-nofb-nmpc", "s4-imm-ekf5-fb-nmpc", "s4-imm-ukf5-nofb-nmpc", "s4-imm-ukf5-fb-nmpc"):
        bad[lb]["radius_rmse_L_early"] = 1.0
    assert _by_id(bad)["9"].verdict == cl.NOT_REPRODUCED


def test_missing_runs_are_not_evaluated() -> None:
    claims = cl.evaluate_claims({})
    assert all(c.verdict == cl.NOT_EVALUATED for c in claims)
    rows = {k: v for k, v in paper_like_rows().items() if k.startswith("s1-")}
    by = _by_id(rows)
    assert by["3"].verdict == cl.REPRODUCED
    assert by["4"].verdict == cl.NOT_EVALUATED


def test_failed_run_values_missing_do_not_pass() -> None:
    rows = paper_like_rows()
    rows["s2-ukf-fb-nmpc"] = {"label": "s2-ukf-fb-nmpc", "status": "failed", "error": "boom"}
    c1 = _by_id(rows)["1"]
    assert c1.verdict == cl.PARTLY  # a failed run that declared nothing has not detected the fault


def test_verdict_of() -> None:
    assert cl.verdict_of([True, True, None]) == cl.REPRODUCED
    assert cl.verdict_of([False, None]) == cl.NOT_REPRODUCED
    assert cl.verdict_of([True, False]) == cl.PARTLY
    assert cl.verdict_of([None]) == cl.NOT_EVALUATED


def test_render_claims_states_thresholds_and_verdicts(tmp_path: Any) -> None:
    rows = paper_like_rows()
    md = render_claims(cl.evaluate_claims(rows), rows, {"wall_time_s": 12.3, "jobs": 2})
    assert "## Thresholds" in md
    for name in cl.THRESHOLDS:
        assert name in md
    assert "reproduced" in md and "partly" in md
    assert "`paper`" in md and "hypothesis" in md
    # summary.csv round trip
    path = tmp_path / "summary.csv"
    write_summary_csv(path, list(rows.values()))
    back = read_summary_csv(path)
    assert len(back) == len(rows)
    assert back[0]["label"] == next(iter(rows))
    assert isinstance(back[0]["radius_rmse_L"], float)
    assert back[0]["false_alarm"] is False
    # verdicts from the CSV equal those from the in-memory rows
    by_csv = {r["label"]: r for r in back}
    assert [c.verdict for c in cl.evaluate_claims(by_csv)] == [c.verdict for c in cl.evaluate_claims(rows)]
