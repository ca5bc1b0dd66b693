"""The compact time series of a study's rows: the extra trace columns of ``[analysis] timeseries_columns``,
the sampling (every row at the estimator rate), and the study identity (changed only by a study that sets
them). Fast: an instantaneous fake run function, nothing simulates."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pytest

from ftc_mj.config import RunConfig
from ftc_mj.errors import BadInput
from ftc_mj.study.plan import plan_study
from ftc_mj.study.runner import run_study
from ftc_mj.study.worker import TS_COLUMNS, compact_timeseries
from tests.support.fake_runs import FakeOutcome, FakeResult

STUDY = """
name = "ts"
scenario = "scenario2"
seeds = [3]
[base]
duration = 0.5
[[axes]]
key = "controller.kind"
values = ["nmpc", "pf-nmpc"]
"""


def write(tmp_path: Path, analysis: str = "", name: str = "ts.toml") -> Path:
    p = tmp_path / name
    p.write_text(textwrap.dedent(STUDY) + textwrap.dedent(analysis))
    return p


def _trace(n: int, rate: float) -> dict[str, np.ndarray]:
    t = np.arange(n) / rate
    return {"t": t, "v": 10.0 - t, "yaw_rate": 0.2 + 0 * t, "plant_flags": (t > 0.2).astype(float) * 8,
            "R_L": np.full(n, 2.0), "cross_track_error": np.where(t > 0.3, np.nan, 0.01 * t)}


def fake_run(cfg: RunConfig, out_root: Path | None, rrd: bool) -> FakeOutcome:
    """One row per estimator step over the run's duration; no metric beyond the status."""
    n = int(round(cfg.duration * cfg.estimator.rate))
    return FakeOutcome({"status": "ok"}, FakeResult(_trace(n, cfg.estimator.rate)))


def test_extra_columns_are_kept_and_every_row_at_the_estimator_rate() -> None:
    tr = _trace(10, 100.0)
    full = compact_timeseries(tr, 100.0, 100.0, ("v", "yaw_rate", "plant_flags", "R_L", "no_such_column"))
    assert full["ts_t"] == tr["t"].tolist() and full["ts_v"] == tr["v"].tolist()
    assert full["ts_plant_flags"] == tr["plant_flags"].tolist()
    assert "ts_no_such_column" not in full  # a column the trace lacks is left out
    assert list(full).count("ts_R_L") == 1  # a column of TS_COLUMNS is not stored twice
    assert "R_L" in TS_COLUMNS
    # without extra columns only TS_COLUMNS; 50 Hz from 100 Hz rows keeps rows 0, 2, 4, …
    half = compact_timeseries(tr, 100.0, 50.0)
    assert set(half) == {"ts_t", "ts_R_L", "ts_cross_track_error"}
    assert half["ts_t"] == tr["t"][::2].tolist()


def test_study_rows_keep_the_extra_columns(tmp_path: Path) -> None:
    p = write(tmp_path, """
        [analysis]
        timeseries_rate = 100.0
        timeseries_columns = ["v", "yaw_rate", "plant_flags"]
        """)
    rep = run_study(plan_study(p), tmp_path / "out", serial=True, run_fn=fake_run, analyse=False)
    df = rep.results
    assert df is not None and df.height == 2
    for row in df.to_dicts():
        assert len(row["ts_t"]) == 50 and row["ts_t"][:3] == pytest.approx([0.0, 0.01, 0.02])
        assert row["ts_v"] == pytest.approx((10.0 - np.arange(50) / 100.0).tolist())
        assert row["ts_plant_flags"][20] == 0.0 and row["ts_plant_flags"][21] == 8.0
        assert row["ts_cross_track_error"][31] is None  # NaN is stored as a missing value
    plain = run_study(plan_study(write(tmp_path, name="plain.toml")), tmp_path / "plain", serial=True,
                      run_fn=fake_run, analyse=False).results
    assert plain is not None and "ts_v" not in plain.columns and len(plain["ts_t"][0]) == 1  # 2 Hz over 0.5 s


def test_identity_changes_only_for_a_study_that_sets_columns(tmp_path: Path) -> None:
    plain = plan_study(write(tmp_path))
    assert plain.identity["spec"]["analysis"] == {"timeseries_rate": 2.0}  # what older studies hashed
    cols = plan_study(write(tmp_path, '[analysis]\ntimeseries_columns = ["v"]\n', "cols.toml"))
    assert cols.identity["spec"]["analysis"]["timeseries_columns"] == ["v"]
    assert cols.study_hash != plain.study_hash
    assert [r.key for r in cols.runs] == [r.key for r in plain.runs]  # the runs are the same runs


@pytest.mark.parametrize("columns, message", [('["v", "v"]', "timeseries_columns\\[1\\]: duplicate column 'v'"),
                                              ('["v-x"]', "analysis.timeseries_columns: String should match pattern")])
def test_bad_columns_are_one_line_errors(tmp_path: Path, columns: str, message: str) -> None:
    with pytest.raises(BadInput, match=message):
        plan_study(write(tmp_path, f"[analysis]\ntimeseries_columns = {columns}\n"))
