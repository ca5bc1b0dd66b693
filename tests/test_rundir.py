"""Tests of :mod:`ftc_mj.rundir`, the one reader of a run directory: a complete run read back, the
trace as numpy columns, events from ``events.json`` or (older runs) from the trace, and the one-line
errors naming ``RUN_DIR``. (That reading a run leaves rerun unimported is checked in a fresh
interpreter by tests/cli/test_packaging.py.)"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from ftc_mj import rundir
from ftc_mj.errors import BadInput


def test_read_run_gives_config_metrics_trace_events(policy_runs: list[Path]) -> None:
    safe = policy_runs[1]
    cfg, metrics, trace, events = rundir.read_run(safe)
    assert cfg.reconfiguration.policy == "safe"
    assert metrics == json.loads((safe / "metrics.json").read_text())
    assert trace.columns == pq.read_schema(safe / "trace.parquet").names and trace.height > 100
    assert [(e.t, e.level, e.text) for e in events] == [
        (e["t"], e["level"], e["text"]) for e in json.loads((safe / "events.json").read_text())]


def test_events_of_a_run_without_events_json_come_from_the_trace(policy_runs: list[Path], tmp_path: Path) -> None:
    old = tmp_path / "old"
    shutil.copytree(policy_runs[1], old)
    (old / "events.json").unlink()
    events = rundir.read_run(old)[3]
    texts = [e.text for e in events]
    assert texts[0] == "fault_detected: fault declared" and "reconfig_state: radii handed over" in texts
    trace = rundir.read_trace(old)
    i = int(np.flatnonzero(trace["fault_detected"] > 0.5)[0])
    assert events[0].t == trace["t"][i]


def test_read_trace_is_numpy_columns(policy_runs: list[Path]) -> None:
    d = policy_runs[0]
    trace = rundir.read_trace(d / "trace.parquet")
    table = pq.read_table(d / "trace.parquet")
    assert list(trace) == table.column_names
    for name in ("t", "R_L_hat", "reconfig_state"):
        assert trace[name].dtype == np.float64
        np.testing.assert_array_equal(trace[name], table.column(name).to_numpy())
    assert rundir.read_trace(d).keys() == trace.keys()      # a run directory stands for its trace
    assert set(rundir.read_run_trace(d)) == set(trace)       # every column of a run trace is numeric


def test_bad_run_directories(policy_runs: list[Path], tmp_path: Path) -> None:
    with pytest.raises(BadInput, match=r"^RUN_DIR: .* is not a run directory \(no config.toml\)$"):
        rundir.read_run(tmp_path)
    broken = tmp_path / "broken"
    shutil.copytree(policy_runs[0], broken)
    (broken / "metrics.json").write_text("{")
    with pytest.raises(BadInput, match=r"^RUN_DIR: .*broken: unreadable run \("):
        rundir.read_run(broken)
    pq.write_table(pq.read_table(broken / "trace.parquet").drop(["x"]), broken / "trace.parquet")
    with pytest.raises(BadInput, match=r"no column 'x'; not a run trace"):
        rundir.read_run_trace(broken)
