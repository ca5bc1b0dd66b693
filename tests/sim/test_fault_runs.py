"""Runs with servo and sensor faults: the truth in the trace (``fault_*`` columns) and the events, the
filters surviving a sensor dropout (update with the channels present, predict only when none is), and
the controller and policy never handed a NaN. Kinematic plant, 3 s runs."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
import tomli_w

from ftc_mj.config import config_to_toml_dict, load_config, validate_config
from ftc_mj.identity import run_identity
from ftc_mj.sim.loop import SimResult, simulate
from ftc_mj.telemetry.columns import FAULT_TRUTH_COLUMNS

BASE = {"plant.kind": "kinematic", "duration": 3.0}
DROP = {"faults.sensor": [{"sensor": "speed", "kind": "dropout", "onset": 1.0, "duration": 1.0}]}


def _run(**overrides: object) -> tuple[SimResult, object]:
    cfg = load_config("scenario1", {**BASE, **overrides})
    return simulate(cfg), cfg


def _finite_inputs_downstream(res: SimResult) -> None:
    """The estimate, the radii the policy handed the controller and the commands are finite on every row."""
    tr = res.trace
    for name in ("x_hat", "y_hat", "psi_hat", "R_R_hat", "R_L_hat", "R_R_model", "R_L_model", "omega_R_cmd",
                 "omega_L_cmd"):
        assert np.all(np.isfinite(tr[name])), name


@pytest.mark.parametrize("estimator", ["ekf", "ukf", "imm-ekf"])
def test_a_speed_dropout_makes_the_speed_only_filters_predict(estimator: str) -> None:
    """Speed sensor only, missing for 1 s: the trace marks the samples missing (NaN, dropout flag 1 on
    exactly those rows), the filter only predicts there (no innovation, NIS dof 0, the radii's σ grows at
    every step under the process noise) and counts no rejection, and updates again after the dropout
    (its σ falls)."""
    res, _ = _run(**DROP, **{"estimator.kind": estimator})
    tr = res.trace
    t, drop = tr["t"], tr["fault_speed_dropout"]
    inside = (t >= 1.0 - 1e-9) & (t < 2.0 - 1e-9)
    assert np.array_equal(drop == 1.0, inside) and np.array_equal(np.isnan(tr["v_meas"]), inside)
    assert np.all(tr["nis_dof"][inside] == 0) and np.all(np.isnan(tr["nis"][inside]))
    assert np.all(tr["nis_dof"][~inside] == 1)
    std = tr["R_L_std"][inside]
    assert np.all(np.diff(std) > 0)
    after = np.flatnonzero(~inside & (t > 2.0))
    assert tr["R_L_std"][after[5]] < std[-1]
    assert res.counters["filter_rejections"] == 0
    _finite_inputs_downstream(res)


def test_a_gyro_dropout_leaves_the_speed_update() -> None:
    """Speed and gyro, the gyro missing for 1 s: the filter updates with the speed alone there (NIS dof 1,
    else 2), nothing is rejected, and the gyro's offset column stays 0 (a dropout hides nothing)."""
    res, _ = _run(**{"sensors.yaw_rate_sigma": 0.01, "faults.sensor": [
        {"sensor": "yaw_rate", "kind": "dropout", "onset": 1.0, "duration": 1.0}]})
    tr = res.trace
    inside = tr["fault_yaw_rate_dropout"] == 1.0
    assert inside.sum() == 100 and np.all(np.isnan(tr["yaw_rate_meas"][inside]))
    assert np.all(tr["nis_dof"][inside] == 1) and np.all(tr["nis_dof"][~inside] == 2)
    assert np.all(tr["fault_yaw_rate_offset"] == 0.0) and "fault_speed_dropout" not in tr
    assert res.counters["filter_rejections"] == 0
    _finite_inputs_downstream(res)


def test_the_truth_of_the_faults_is_in_the_trace_and_the_events() -> None:
    """A locked left wheel at 1.509 s (the last physics step before the 1.51 s row) and a speed bias of
    0.3 m/s from 0.5 s: ``fault_lock_L`` is 0 until the row after the onset (the state that acted in the
    last physics step) and 1 from then on, the wheel's rate 0 with it; the speed offset column holds the
    bias from its onset; each fault has an onset event naming its class, target and size; a run without
    them has no such column."""
    res, _ = _run(**{"faults.actuator": [{"wheel": "left", "kind": "lock", "onset": 1.509}],
                     "faults.sensor": [{"sensor": "speed", "kind": "bias", "onset": 0.5, "size": 0.3}]})
    tr = res.trace
    t = tr["t"]
    assert set(FAULT_TRUTH_COLUMNS) & set(tr) == {"fault_effectiveness_R", "fault_effectiveness_L", "fault_lock_R",
                                                  "fault_lock_L", "fault_speed_offset", "fault_speed_dropout"}
    locked = t > 1.509
    assert np.array_equal(tr["fault_lock_L"] == 1.0, locked) and np.all(tr["fault_lock_R"] == 0.0)
    assert np.all(tr["omega_L"][locked] == 0.0) and np.all(tr["fault_effectiveness_L"] == 1.0)
    np.testing.assert_array_equal(tr["fault_speed_offset"], np.where(t >= 0.5 - 1e-9, 0.3, 0.0))
    texts = {(e.t, e.text) for e in res.events}
    assert (1.509, "fault injected: wheel_lock on left, size 1") in texts
    assert (0.5, "fault injected: speed_bias on speed, size 0.3 m/s") in texts
    healthy, _ = _run()
    assert not set(FAULT_TRUTH_COLUMNS) & set(healthy.trace)


def test_faults_round_trip_and_leave_a_healthy_identity_unchanged() -> None:
    """The resolved config of a run without servo or sensor faults has no ``actuator``/``sensor`` keys (its
    run id is the one it had before they existed); one with them writes them to ``config.toml`` as arrays
    of tables (inline) and reads back to the same config."""
    plain = load_config("scenario2")
    assert set(config_to_toml_dict(plain)["faults"]) == {"right", "left"}
    cfg = load_config("scenario2", {"faults.actuator": [{"wheel": "right", "kind": "loss", "onset": 3.0,
                                                         "effectiveness": 0.4}], **DROP})
    text = tomli_w.dumps(config_to_toml_dict(cfg))
    assert "actuator = [" in text and "sensor = [" in text
    back = validate_config(tomllib.loads(text))
    assert back == cfg and run_identity(back) == run_identity(cfg) != run_identity(plain)
