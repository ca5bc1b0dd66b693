"""``ftc-mj study tune_dwell --report`` / ``tune_growth --report``: the data-tuned parameters from the tuning
studies' output folders, the text the tuning-table script it replaced (deleted) printed (its lines on these
synthetic results kept below), also from the folder ``ftc-mj paper --tune`` writes."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import polars as pl
import pytest
from typer.testing import CliRunner

from ftc_mj.cli import app
from ftc_mj.config import RunConfig
from ftc_mj.paper.tuning import DWELL_RULE, GROWTH_RULE, TUNED, run_tuning
from ftc_mj.reports.doc_tables import doc_table_studies, doc_tables
from ftc_mj.study import worker
from tests.paper.test_tuning import _dwell_rows, _growth_rows
from tests.support.fake_runs import FakeOutcome, FakeResult

runner = CliRunner()


def _folders(root: Path) -> tuple[Path, Path]:
    """``tune-dwell`` (dwell 0.1 and 0.2 with false alarms, the 9 seed-2 runs of dwell 0.5 failed) and
    ``tune-growth`` (limits 0.2 and 5 worse than none in 1 and 4 runs) output folders."""
    dwell, growth = root / "tune-dwell", root / "tune-growth"
    dwell.mkdir(parents=True)
    growth.mkdir(parents=True)
    failed = (pl.col("dwell") == 0.5) & (pl.col("seed") == 2)
    _dwell_rows({0.1: 5, 0.2: 1}).with_columns(
        pl.when(failed).then(pl.lit("failed")).otherwise(pl.col("status")).alias("status")
    ).write_parquet(dwell / "results.parquet")
    _growth_rows({"0.2": 1, "5": 4}, {"0": 0.9, "0.02": 0.5, "0.05": 0.4, "0.2": 0.3, "5": 0.2}).write_parquet(
        growth / "results.parquet")
    return dwell, growth


def test_reports_print_the_lines_of_the_retired_script(tmp_path: Path) -> None:
    dwell, growth = _folders(tmp_path)
    assert {"tune-dwell", "tune-growth"} <= set(doc_table_studies())
    text = doc_tables("tune-dwell", dwell)
    assert text.startswith("\n`estimator.decision.dwell` (360 runs, 9 not ok, seeds [0, 1, 2, 3, 4, 5, 6, 7, 8, 9]): "
                           "chosen 0.3, configured 0.5 (no false alarm or isolation).\n\nRule: " + DWELL_RULE + ".\n\n")
    lines = text.splitlines()
    assert lines[5] == ("| dwell [s] | runs | false alarms | runs with false isolations | false alarm or isolation "
                        "[95 % CI] | detection delay [s] | missed detections | safe: max \\|cte\\| from onset + 5 s "
                        "[m] |")
    assert lines[7] == "| 0.1 | 90 | 5/90 | 0/90 | 6 % [2, 12] | 0.5 ± 0 | 0 % [0, 6] | 0.4 ± 0 |"
    assert lines[10] == "| 0.5 | 90 | 9/90 | 0/90 | 10 % [5, 18] | 0.9 ± 0 | 0 % [0, 7] | 0.8 ± 1.11e-16 |"
    assert lines[11:] == [""] and text.endswith(" |\n\n")  # print() of a table that ends in a newline
    text = doc_tables("tune-growth", growth)
    lines = text.splitlines()
    assert lines[1] == ("`reconfiguration.max_growth_rate` (180 runs, 0 not ok, seeds [0, 1, 2, 3, 4, 5, 6, 7, 8, 9]): "
                        "chosen 0.05, configured 0.05 (admissible (never worse than none)).")
    assert lines[3] == f"Rule: {GROWTH_RULE}."
    assert lines[7:] == ["| 0 | 30 | 0/30 | 0.9 ± 1.11e-16 | 1 ± 0 |", "| 0.02 | 30 | 0/30 | 0.5 ± 0 | 1 ± 0 |",
                         "| 0.05 | 30 | 0/30 | 0.4 ± 5.55e-17 | 1 ± 0 |",
                         "| 0.2 | 30 | 1/30 | 0.3 ± 0 | 1.02 ± 0.0341 |",
                         "| 5 | 30 | 4/30 | 0.2 ± 2.78e-17 | 1.07 ± 0.0646 |", ""]
    (tmp_path / "empty").mkdir()
    assert doc_tables("tune-growth", tmp_path / "empty") == \
        f"\n`reconfiguration.max_growth_rate`: no results at {tmp_path / 'empty'}\n"


def _fake_dwell_run(cfg: RunConfig, out_root: Path | None, rrd: bool) -> FakeOutcome:
    """A ``tune_dwell`` run: dwells below 0.3 s false-alarm in the fault-free scenario."""
    dwell = cfg.estimator.decision.dwell
    fault_free = not cfg.faults.left
    metrics: dict[str, Any] = {"status": "ok", "false_alarm": fault_free and dwell < 0.3, "false_isolations": 0,
                               "missed_detection": None if fault_free else False,
                               "detection_delay": None if fault_free else 0.4 + dwell,
                               "cross_track_max_recovered": 0.3 + dwell}
    return FakeOutcome(metrics, FakeResult({"t": [0.0, 0.01]}))


def test_cli_report_reads_the_folder_paper_tune_writes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(worker, "_default_run_fn", _fake_dwell_run)
    (outcome,) = run_tuning(tmp_path, n_seeds=1, duration=None, workers=1, which=TUNED[:1])
    assert outcome.folder.parent == tmp_path / "tuning" / "tune_dwell"
    res = runner.invoke(app, ["study", "tune_dwell", "--report", "--out", str(outcome.folder)])
    assert res.exit_code == 0, res.output
    assert res.output.startswith(f"\n`estimator.decision.dwell` ({outcome.runs} runs, 0 not ok, seeds [0]): chosen "
                                 f"{outcome.selection.value}, configured 0.5 (no false alarm or isolation).\n")
    assert outcome.selection.value == 0.3
    assert (outcome.folder / "doc_tables.md").read_text() == res.output
