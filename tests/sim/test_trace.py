"""The trace writer: preallocated NaN columns, filled cell by cell, cut at a failure."""

from __future__ import annotations

import numpy as np

from ftc_mj.control.base import ControlOutput
from ftc_mj.sim.trace import TraceWriter
from ftc_mj.telemetry.columns import BASE_COLUMNS


def test_columns_start_as_nan_and_hold_what_a_step_wrote() -> None:
    w = TraceWriter(4, extra=("pf_lateral_accel",), n_modes=2)
    assert list(w.columns) == [*BASE_COLUMNS, "pf_lateral_accel", "mode_prob_1", "mode_prob_2"]
    assert all(v.shape == (4,) and np.isnan(v).all() for v in w.columns.values())
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
