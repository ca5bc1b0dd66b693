"""Every key metrics.json can hold has a unit and a one-line meaning (``ftc-mj metrics``,
``metrics.schema.json`` beside each run's metrics.json); a new metric without one fails here."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import polars as pl
import pytest
from typer.testing import CliRunner

from ftc_mj.cli import app
from ftc_mj.metrics.schema import METRICS, RENAMED, schema, undocumented, upgrade_names
from ftc_mj.rundir import read_metrics


def run(tmp_path: Path, args: list[str]) -> Path:
    res = CliRunner().invoke(app, ["run", *args, "--out", str(tmp_path), "-q"])
    assert res.exit_code == 0, res.output
    (run_dir,) = tmp_path.iterdir()
    return run_dir


def test_every_metric_of_real_runs_is_documented(tmp_path: Path) -> None:
    """A run with every kind of metric (a fault, FDI statistics with the PCRB, an IMM, a recording) and one
    without an estimator: each key they write is in the schema, and the schema file beside them is it."""
    full = run(tmp_path / "full", ["scenario2", "--duration", "10.5", "--estimator", "imm-ukf",
                                   "--set", "estimator.decision.statistics=true"])
    bare = run(tmp_path / "bare", ["scenario1", "--duration", "0.5", "--estimator", "none", "--no-rrd"])
    for run_dir in (full, bare):
        keys = json.loads((run_dir / "metrics.json").read_text())
        assert undocumented(keys) == [], undocumented(keys)
        assert json.loads((run_dir / "metrics.schema.json").read_text()) == schema()
    keys = json.loads((full / "metrics.json").read_text())
    assert {"fdi_records", "fdi_cumulative_kl", "onsets", "outcome", "rrd_write_s",
            "radius_loss_estimate_final_L", "position_estimate_final_error"} <= set(keys)
    kl, t = keys["fdi_cumulative_kl"], keys["fdi_cumulative_kl_t"]
    assert len(kl) == len(t) > 0 and t[0] == pytest.approx(keys["fault_onset_time"], abs=0.011)
    assert np.allclose(np.diff(t), 0.01)  # one value per estimator step (100 Hz)


def test_renamed_metrics_are_documented_and_old_results_read_under_the_new_name(tmp_path: Path) -> None:
    """A renamed metric says so in the table, and metrics.json / results tables written before the rename
    read back under the new name (a table with rows of both ages reads whole)."""
    assert RENAMED == {"position_final_error": "position_estimate_final_error",
                       "severity_R": "radius_loss_estimate_final_R", "severity_L": "radius_loss_estimate_final_L"}
    for old, new in RENAMED.items():
        assert new in METRICS and old not in METRICS
        assert f"renamed from `{old}` in 2026-12" in METRICS[new][1]
    assert upgrade_names({"position_final_error": 1.5, "status": "ok"}) == {"position_estimate_final_error": 1.5,
                                                                             "status": "ok"}
    (tmp_path / "metrics.json").write_text(json.dumps({"severity_L": 0.75}))
    assert read_metrics(tmp_path) == {"radius_loss_estimate_final_L": 0.75}
    df = upgrade_names(pl.DataFrame({"run_key": ["a", "b"], "position_final_error": [1.0, None],
                                     "position_estimate_final_error": [None, 2.0]}))
    assert df.columns == ["run_key", "position_estimate_final_error"]
    assert df["position_estimate_final_error"].to_list() == [1.0, 2.0]


def test_a_new_key_is_caught_and_every_entry_has_a_meaning() -> None:
    assert undocumented({"status", "brand_new_metric"}) == ["brand_new_metric"]
    assert all(meaning and "\n" not in meaning for _unit, meaning in METRICS.values())


def test_ftc_mj_metrics_prints_every_key_with_its_unit() -> None:
    res = CliRunner().invoke(app, ["metrics"])
    assert res.exit_code == 0
    lines = res.stdout.splitlines()
    assert len(lines) == len(METRICS)
    line = next(ln for ln in lines if ln.startswith("cross_track_max_recovered "))
    assert "[m]" in line and "5 s after the onset" in line


def test_docs_metrics_md_is_the_tools_table() -> None:
    docs = Path(__file__).resolve().parents[2] / "docs" / "metrics.md"
    res = CliRunner().invoke(app, ["metrics", "--markdown"])
    assert res.exit_code == 0
    assert res.stdout == docs.read_text(), "regenerate: ftc-mj metrics --markdown > docs/metrics.md"
