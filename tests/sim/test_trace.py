"""The trace writer: preallocated NaN columns, filled cell by cell, cut at a failure; trace.parquet keeps
the integer codes as integers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from ftc_mj.config import load_config
from ftc_mj.control.base import ControlOutput
from ftc_mj.io import write_parquet
from ftc_mj.rundir import read_trace
from ftc_mj.sim.run import execute
from ftc_mj.sim.trace import TraceWriter
from ftc_mj.telemetry.columns import BASE_COLUMNS, INTEGER_COLUMNS


def test_columns_start_as_nan_and_hold_what_a_step_wrote() -> None:
    w = TraceWriter(4, extra=("pf_lateral_accel",), n_modes=2)
    assert list(w.columns) == [*BASE_COLUMNS, "pf_lateral_accel", "mode_prob_1", "mode_prob_2"]
    assert all(v.shape == (4,) and np.isnan(v).all() for k, v in w.columns.items() if k != "plant_flags")
    assert w.columns["plant_flags"].dtype == np.int64  # a bit set written on every row
    cmd = ControlOutput(omega=np.array([5.0, 4.0]), solve_time=0.002, iterations=3, success=True,
                        telemetry={"pf_lateral_accel": 1.5})
    w.solve(0, cmd)
    w.held(1, 2.0, cmd.omega, np.array([2.0, 1.5]))
    c = w.columns
    assert (c["solve_time_ms"][0], c["solver_iterations"][0], c["solver_ok"][0]) == (2.0, 3.0, 1.0)
    assert c["pf_lateral_accel"][0] == 1.5 and np.isnan(c["solve_time_ms"][1])
    assert (c["reconfig_state"][1], c["omega_R_cmd"][1], c["omega_L_cmd"][1]) == (2.0, 5.0, 4.0)
    assert (c["R_R_model"][1], c["R_L_model"][1]) == (2.0, 1.5)
    cut = w.first_rows(2)
    assert set(cut) == set(c) and all(v.size == 2 for v in cut.values())


def test_integer_columns_are_stored_as_integers_with_nulls_and_read_back_equal(tmp_path: Path) -> None:
    """plant_flags (int64 in memory), the decision's codes and the solver's counts are int64 in trace.parquet,
    null where the run produced no value; read back they equal the in-memory floats."""
    out = execute(load_config("scenario2", {"duration": 3.0}), tmp_path, rrd=False)
    assert out.result.trace["plant_flags"].dtype == np.int64
    schema = pq.read_schema(out.run_dir / "trace.parquet")
    assert {c for c in INTEGER_COLUMNS if schema.field(c).type == pa.int64()} == set(INTEGER_COLUMNS)
    table = pq.read_table(out.run_dir / "trace.parquet")
    assert table.column("solver_iterations").null_count > 0 and table.column("plant_flags").null_count == 0
    back = read_trace(out.run_dir)
    for name, col in out.result.trace.items():
        assert np.array_equal(np.asarray(col, float), back[name], equal_nan=True), name


def test_a_column_with_a_fraction_is_not_rounded(tmp_path: Path) -> None:
    write_parquet(tmp_path / "x.parquet", {"a": np.array([1.0, np.nan]), "b": np.array([0.5, 1.0])},
                  integers=("a", "b"))
    t = pq.read_table(tmp_path / "x.parquet")
    assert t.column("a").type == pa.int64() and t.column("a").to_pylist() == [1, None]
    assert t.column("b").type == pa.float64() and t.column("b").to_pylist() == [0.5, 1.0]


def test_cross_track_error_is_the_references_at_every_row_written() -> None:
    """The cross-track error is filled from the trace's true x, y when the columns are read (vectorised): on
    every path kind, every row equals the reference's ``cross_track`` of that row's position alone, and rows
    not yet written stay NaN."""
    from ftc_mj.sim.loop import ClosedLoop

    for kind in ("circle", "line", "figure8"):
        loop = ClosedLoop(load_config("scenario2", {"duration": 0.5, "reference.kind": kind}))
        for k in range(30):
            loop.step(k)
        c = loop.trace.columns
        ref = loop.parts.reference
        want = [float(ref.cross_track(x, y)) for x, y in zip(c["x"][:30], c["y"][:30], strict=True)]
        assert np.array_equal(c["cross_track_error"][:30], want), kind
        assert np.isnan(c["cross_track_error"][30:]).all() and np.abs(want).max() > 0.0
