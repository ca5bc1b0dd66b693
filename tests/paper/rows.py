"""Fake summary rows for the claim and verdict tests: a world that tells the paper's story, the
policy axis where direct and safe both help, and a helper that judges rows like the quick look."""

from __future__ import annotations

from typing import Any

from ftc_mj.paper.claims import evaluate_all
from ftc_mj.paper.claims.paper import evaluate_claims
from ftc_mj.paper.matrix import full_matrix, policy_runs
from ftc_mj.paper.verdicts import Claim, combine

Rows = dict[str, dict[str, Any]]


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


def _paper_row(label: str) -> dict[str, Any]:
    p = _parse(label)
    sc, est, fb, ctrl, models = p["sc"], p["est"], p["fb"], p["ctrl"], p["models"]
    imm = est.startswith("imm")
    r: dict[str, Any] = {
        "label": label, "status": "ok", "detection_delay": 0.3, "detection_time": 10.3, "false_alarm": False,
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
        r.update(omega_at_limit_fraction_after_fault=0.7, cross_track_max_after_fault=12.0,
                 time_on_path_after_fault=5.0)
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
    return r


def paper_like_rows() -> Rows:
    """Rows of every matrix entry that tell the paper's story (including its scenario 3 UKF anomaly)."""
    return {e.label: _paper_row(e.label) for e in full_matrix()}


def policy_rows() -> Rows:
    """The policy axis in a world where direct and safe both help and safe hands over 0.5 s after the fault."""
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


def judge(rows: Rows, every_family: bool = False) -> dict[str, Claim]:
    """The claims judged on ``rows`` as the single-seed quick look does, by id (the paper's 1–12, or
    every family)."""
    evidence = evaluate_all(rows) if every_family else evaluate_claims(rows)
    return {c.id: c for c in combine({0: evidence}, single_seed=True)}
