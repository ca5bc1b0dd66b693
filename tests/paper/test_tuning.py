"""Data-tuned parameters: the selection rules on synthetic study results, the defaults, the studies'
development seeds."""

from __future__ import annotations

from typing import Any

import polars as pl

from ftc_mj.paper.seeds import DEV_SEEDS
from ftc_mj.paper.tuning import STUDY_DIR, TUNED, select_dwell, select_growth


def _dwell_rows(false_alarm_dwells: dict[float, int]) -> pl.DataFrame:
    """10 seeds × 3 faults × 3 set-ups per dwell; ``false_alarm_dwells[d]`` runs of dwell d false-alarm."""
    rows: list[dict[str, Any]] = []
    for d in (0.1, 0.2, 0.3, 0.5):
        n_fa = false_alarm_dwells.get(d, 0)
        for i in range(90):
            fault, setup = ("s1", "s2", "s3")[i % 3], ("ukf", "imm-ukf", "ukf-safe-yaw")[(i // 3) % 3]
            rows.append({"dwell": d, "fault": fault, "setup": setup, "seed": i // 9, "status": "ok",
                         "false_alarm": i < n_fa, "missed_detection": False if fault != "s1" else None,
                         "detection_delay": None if fault == "s1" else 0.4 + d,
                         "cross_track_max_recovered": 0.3 + d})
    return pl.DataFrame(rows)


def test_dwell_rule_picks_the_smallest_dwell_without_false_alarms() -> None:
    sel = select_dwell(_dwell_rows({0.1: 5, 0.2: 1}))
    assert sel.value == 0.3 and sel.why == "no false alarm or isolation"
    assert [r["false alarms"] for r in sel.table] == ["5/90", "1/90", "0/90", "0/90"]
    # a failed run counts as a false alarm
    df = _dwell_rows({0.1: 5}).with_columns(
        pl.when((pl.col("dwell") == 0.2) & (pl.col("seed") == 0) & (pl.col("fault") == "s2"))
        .then(pl.lit("failed")).otherwise(pl.col("status")).alias("status"))
    assert select_dwell(df).value == 0.3
    # no dwell without one: the fewest, the smaller on ties
    sel = select_dwell(_dwell_rows({0.1: 3, 0.2: 2, 0.3: 2, 0.5: 4}))
    assert sel.value == 0.2 and "no dwell without false alarms" in sel.why
    # a wrong-wheel declaration after the onset disqualifies a dwell like a false alarm
    wrong = (pl.col("dwell") == 0.2) & (pl.col("seed") == 4) & (pl.col("fault") == "s2")
    df = _dwell_rows({0.1: 5}).with_columns(pl.when(wrong).then(1).otherwise(0).alias("false_isolations"))
    assert select_dwell(df).value == 0.3


def _growth_rows(worse: dict[str, int], cte: dict[str, float]) -> pl.DataFrame:
    rows: list[dict[str, Any]] = []
    for fault in ("s2", "s3", "s4"):
        for seed in range(10):
            base = {"fault": fault, "seed": seed, "status": "ok", "omega_at_limit_s": 0.0,
                    "liftoff_time_post_transient_s": 1.0, "tipped": False}
            rows.append({**base, "setting": "none", "cross_track_max_recovered": 9.0})
            for g, c in cte.items():
                lift = 1.0 + (0.5 if fault == "s3" and seed < worse.get(g, 0) else 0.0)  # 0.5 s > POLICY_TOL
                rows.append({**base, "setting": g, "cross_track_max_recovered": c,
                             "liftoff_time_post_transient_s": lift})
    return pl.DataFrame(rows)


def test_growth_rule_keeps_r2_on_every_run_then_tracks_best() -> None:
    cte = {"0": 0.9, "0.02": 0.5, "0.05": 0.4, "0.2": 0.3, "5": 0.2}
    sel = select_growth(_growth_rows({"0.2": 1, "5": 4}, cte))
    assert sel.value == 0.05  # 0.2 and 5 track better but lift a wheel longer than none in some run
    assert [r["runs worse than none (R2)"] for r in sel.table] == ["0/30", "0/30", "0/30", "1/30", "4/30"]
    # ties in tracking: the larger limit
    sel = select_growth(_growth_rows({}, {"0.02": 0.4, "0.05": 0.4}))
    assert sel.value == 0.05
    # none admissible: the fewest violations
    sel = select_growth(_growth_rows({"0.02": 3, "0.05": 1}, {"0.02": 0.4, "0.05": 0.5}))
    assert sel.value == 0.05 and "none admissible" in sel.why
    # tipping where none did not violates
    df = _growth_rows({}, {"0.05": 0.4, "5": 0.2}).with_columns(
        pl.when((pl.col("setting") == "5") & (pl.col("seed") == 2)).then(True).otherwise(pl.col("tipped"))
        .alias("tipped"))
    assert select_growth(df).value == 0.05


def test_tuned_defaults_are_the_config_values() -> None:
    assert {t.key: t.default() for t in TUNED} == {"estimator.decision.dwell": 0.5,
                                                  "reconfiguration.max_growth_rate": 0.05}


def test_tuning_studies_run_on_the_development_seeds() -> None:
    import tomllib

    for t in TUNED:
        data = tomllib.loads((STUDY_DIR / f"{t.study}.toml").read_text())
        assert tuple(data["seeds"]) == DEV_SEEDS
