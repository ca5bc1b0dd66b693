"""The Python API: configs with overrides, runs in memory and on disk, loading runs and studies back,
and components built from their own settings giving the numbers they give inside a run."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import numpy as np
import polars as pl
import pytest

import ftc_mj
from ftc_mj.errors import BadInput
from ftc_mj.estimation import IMM, UKF, Measurement

SHORT = {"duration": 2.0, "plant.kind": "kinematic", "faults.left": [[0.5, 2.0], [0.5, 1.0]],
         "sensors.yaw_rate_sigma": 0.01}
"""A 2 s run on the kinematic plant with a left puncture at 0.5 s and a gyro."""


def test_load_config_overrides_and_one_line_errors() -> None:
    cfg = ftc_mj.load_config("scenario2", {"sensors.yaw_rate_sigma": 0.01, "estimator.kind": "ekf"})
    assert cfg.name == "scenario2" and cfg.sensors.yaw_rate_sigma == 0.01 and cfg.estimator.kind == "ekf"
    assert cfg.plant.model_file == "builtin:diffdrive.xml"
    with pytest.raises(BadInput, match=r"^sensors.yaw_rate_sigma: must be a finite number in \(0, 1e\+06\]"):
        ftc_mj.load_config("scenario2", {"sensors.yaw_rate_sigma": -1.0})
    with pytest.raises(BadInput, match=r"^sensors.yaw_rate: unknown key"):
        ftc_mj.load_config("scenario2", {"sensors.yaw_rate": 0.01})
    with pytest.raises(BadInput, match="no such built-in scenario or file: scenario9"):
        ftc_mj.load_config("scenario9")


def test_run_in_memory_and_on_disk_and_load_back(tmp_path: Path) -> None:
    mem = ftc_mj.run("scenario2", overrides=SHORT)
    assert mem.path is None and mem.status == "ok" and isinstance(mem.trace, pl.DataFrame)
    assert mem.trace.height == 200 and {"t", "R_L", "R_L_hat", "omega_R_cmd"} <= set(mem.trace.columns)
    texts = [e.text for e in mem.events]
    assert any(t.startswith("fault injected: left") for t in texts) and any("fault declared" in t for t in texts)
    disk = ftc_mj.run(mem.config, tmp_path, rrd=False)
    assert disk.run_id == mem.run_id and disk.path == tmp_path / mem.run_id
    assert sorted(p.name for p in disk.path.iterdir()) == ["config.toml", "events.json", "metrics.json",
                                                           "metrics.schema.json", "record.json", "trace.parquet"]
    back = ftc_mj.load_run(disk.path)
    wall = ["solve_time_ms"]  # wall-clock solve times differ between runs
    assert back.trace.drop(wall).equals(mem.trace.drop(wall), null_equal=True)
    assert [(e.t, e.level, e.text) for e in back.events] == [(e.t, e.level, e.text) for e in mem.events]
    assert back.config == mem.config and back.run_id == mem.run_id and back.metrics["status"] == "ok"
    with pytest.raises(BadInput, match="is not a run directory"):
        ftc_mj.load_run(tmp_path)


def test_run_study_serially_and_load_it_back(tmp_path: Path) -> None:
    study = tmp_path / "s.toml"
    study.write_text(textwrap.dedent("""
        name = "s"
        scenario = "scenario1"
        [base]
        duration = 0.5
        "plant.kind" = "kinematic"
        [[axes]]
        key = "estimator.kind"
        values = ["ekf", "ukf"]
        [analysis]
        figures = false
    """))
    res = ftc_mj.run_study(study, tmp_path / "out", serial=True)
    assert res.results.height == 2 and res.results["estimator.kind"].to_list() == ["ekf", "ukf"]
    back = ftc_mj.load_study(tmp_path / "out")
    assert back.results.equals(res.results) and back.plan["study"] == "s" and len(back.plan["runs"]) == 2
    with pytest.raises(BadInput, match="no results.parquet"):
        ftc_mj.load_study(tmp_path)


def test_ukf_from_its_own_settings_steps_to_the_estimates_of_a_run() -> None:
    """Stepped on the run's measured wheel rates and sensor readings, a UKF built from the
    ``[estimator]``/``[sensors]`` sections and the model geometry alone reproduces every estimate
    and σ of the run exactly (the same maths on the same numbers: no tolerance)."""
    est = {"q_diffusion": [0.25, 0.25, 1e-4, 0.01, 0.01], "p0_sigma": [0.5, 0.5, 0.02, 0.3, 0.3]}
    run = ftc_mj.run("scenario2", overrides={**SHORT, **{f"estimator.{k}": v for k, v in est.items()}})
    tr = run.trace
    ukf = UKF.from_settings(est, {"yaw_rate_sigma": 0.01}, wheel_radius=2.0, half_track=1.0)
    x_hat, std = _step_on(ukf, tr)
    for i, name in enumerate(("x", "y", "psi", "R_R", "R_L")):
        np.testing.assert_array_equal(x_hat[:, i], tr[f"{name}_hat"].to_numpy(), err_msg=name)
        np.testing.assert_array_equal(std[:, i], tr[f"{name}_std"].to_numpy(), err_msg=name)
    # and the settings are used: the paper's Q and P0, or no gyro, give other estimates
    for other in (UKF.from_settings(None, {"yaw_rate_sigma": 0.01}), UKF.from_settings(est, None)):
        assert not np.array_equal(_step_on(other, tr)[0][:, 4], tr["R_L_hat"].to_numpy())
    with pytest.raises(BadInput, match=r"^estimator.q_diffusion: "):
        UKF.from_settings({"q_diffusion": [1.0]})
    with pytest.raises(BadInput, match=r"q_rate: replaced by q_diffusion"):
        UKF.from_settings({"q_rate": [5.0, 5.0, 0.1, 2.0, 2.0]})
    with pytest.raises(BadInput, match=r"^sensors.speed_sigma: "):
        UKF.from_settings(None, {"speed_sigma": 0.0})


def _step_on(flt: UKF, tr: pl.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """Estimates and σ (n, 5) of ``flt`` stepped as the loop steps it on the run's measured wheel rates
    (those of the previous step) and sensor readings (speed and, if the filter has one, the gyro)."""
    u = np.stack([tr["omega_R_meas"].to_numpy(), tr["omega_L_meas"].to_numpy()], axis=1)
    x_hat, std = np.empty((tr.height, 5)), np.empty((tr.height, 5))
    for k in range(tr.height):
        z = Measurement(speed=float(tr["v_meas"][k]), yaw_rate=float(tr["yaw_rate_meas"][k]))
        out = flt.step(u[k - 1] if k else u[0], z)
        x_hat[k], std[k] = out.x, np.sqrt(np.diag(out.P))
    return x_hat, std


def test_imm_from_its_own_settings_declares_its_bank() -> None:
    bank = [{"name": "ok"}, {"name": "left 30 %", "frac_L": 0.7}, {"name": "right 30 %", "frac_R": 0.7}]
    imm = IMM.from_settings("ekf", {"imm_bank": bank, "p_stay": 0.95})
    assert imm.n_modes == 3 and [h.wheel for h in imm.hypotheses] == [None, "left", "right"]
    np.testing.assert_allclose(np.diag(imm.Pi), 0.95)
    out = imm.step(np.array([5.0, 5.0]), Measurement(speed=10.0))
    assert out.hypotheses == imm.hypotheses and out.mode_probs is not None and out.mode_probs.shape == (3,)


def test_plant_and_controller_from_their_own_settings() -> None:
    """A plant and a controller built from their sections alone: the kinematic plant under a constant
    command moves at ``V = R ω`` (10 m/s; exact integration, so to round-off), and the NMPC on the
    counter-clockwise circle commands the reference's speed (mean wheel rate ``V / R`` = 5 rad/s; the
    cost has no reason to change speed on the path, 0.05 rad/s = 1 % allowed) turning left
    (``ω_R > ω_L``)."""
    from ftc_mj.control import CircleReference
    from ftc_mj.wiring.control import controller_from_settings
    from ftc_mj.wiring.plant import plant_from_settings

    plant = plant_from_settings({"kind": "kinematic"}, robot={"wheel_radius": 2.0})
    plant.set_command(5.0, 5.0)
    plant.advance(1000)
    tr = plant.truth()
    assert abs(tr.v - 10.0) < 1e-9 and abs(tr.x - 10.0) < 1e-6
    ref = CircleReference(50.0, 10.0)
    ctl = controller_from_settings({"kind": "nmpc", "nodes": 20}, ref)
    cmd = ctl.solve(0.0, np.zeros(3), np.array([2.0, 2.0]), np.array([5.0, 5.0]))
    assert cmd.success and abs(float(np.mean(cmd.omega)) - 5.0) < 0.05 and cmd.omega[0] > cmd.omega[1]
    with pytest.raises(BadInput, match=r"^controller.nodes: "):
        controller_from_settings({"nodes": 1}, ref)
    with pytest.raises(BadInput, match=r"^plant.kind: "):
        plant_from_settings({"kind": "lego"})


def test_version_and_public_names() -> None:
    assert ftc_mj.__version__ == "0.1.0"
    assert set(ftc_mj.components()) == {"estimators", "decision_rules", "controllers", "policies", "references",
                                        "fault_classes", "diagnosers"}
    assert "actuator_loss" in ftc_mj.components()["fault_classes"] and callable(ftc_mj.register_fault_class)
    assert "residual" in ftc_mj.components()["diagnosers"] and callable(ftc_mj.register_diagnoser)
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        _ = ftc_mj.nope  # type: ignore[attr-defined]
    assert json.loads(json.dumps(ftc_mj.__all__))  # plain names
