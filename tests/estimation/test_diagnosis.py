"""The built-in diagnoser on a synthetic robot whose truth is known exactly: each fault class is declared
with its component, target and mode (and a size close to the truth), a healthy robot is not, and a record
survives the trace."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ftc_mj.context import RunContext
from ftc_mj.estimation.diagnosis import (
    DIAGNOSIS_COLUMNS,
    DiagnosisInput,
    ResidualDiagnoser,
    ResidualDiagnoserSettings,
    diagnoses_from_trace,
)
from ftc_mj.model.diagnosis import Diagnosis
from ftc_mj.model.sensors import SensorSettings
from ftc_mj.sim.trace import TraceWriter

DT, R0, B = 0.01, 2.0, 1.0


def context(gyro: float | None = 0.01, speed_sigma: float = 0.3) -> RunContext:
    return RunContext(seed=0, duration=30.0, physics_dt=1e-3, estimator_dt=DT, controller_dt=0.1,
                      nominal_radii=(R0, R0), half_track=B, omega_max=20.0, initial_pose=(0.0, 0.0, 0.0),
                      sensors=SensorSettings(speed_sigma=speed_sigma, yaw_rate_sigma=gyro))


def drive(fault: dict, duration: float = 20.0, gyro: float | None = 0.01, pose_sigma: float = 0.02,
          seed: int = 3, **settings: float) -> list[Diagnosis]:
    """A unicycle on a 50 m circle at 10 m/s with first-order wheel servos (gain α per step) under a steady
    load, exact kinematics and Gaussian sensors; ``fault``: ``{"kind": ..., "t": onset, ...}``; returns the
    declarations."""
    rng = np.random.default_rng(seed)
    diag = ResidualDiagnoser(ResidualDiagnoserSettings(**settings), context(gyro))
    x = y = psi = 0.0
    radii = np.array([R0, R0])
    alpha = np.array([0.1, 0.1])
    omega = np.array([5.1, 4.9])
    cmd = omega.copy()
    v_ref, r_ref = 10.0, 50.0
    for k in range(int(duration / DT)):
        t = k * DT
        on = t >= fault.get("t", math.inf)
        kind = fault.get("kind")
        if on and kind == "puncture":
            radii[fault["wheel"]] = R0 * fault["fraction"]
        if on and kind == "loss":
            alpha[fault["wheel"]] = 0.1 * fault["effectiveness"]
        if k % 10 == 0:  # a 10 Hz controller holding the path's wheel rates, with a small dither
            psidot = v_ref / r_ref
            cmd = np.array([(v_ref + B * psidot) / radii[0], (v_ref - B * psidot) / radii[1]])
            cmd = cmd + 0.2 * rng.standard_normal(2)
        omega = omega + alpha * (cmd - omega) - np.array([0.003, -0.003])  # a steady load: lags of ±0.03 rad/s
        if on and kind == "lock":
            omega[fault["wheel"]] = 0.0
        v = 0.5 * (radii[0] * omega[0] + radii[1] * omega[1])
        w = (radii[0] * omega[0] - radii[1] * omega[1]) / (2 * B)
        x, y, psi = x + v * math.cos(psi) * DT, y + v * math.sin(psi) * DT, psi + w * DT
        speed = v + 0.3 * rng.standard_normal() + (fault.get("bias", 0.0) if on and kind == "speed" else 0.0)
        if on and kind == "speed_drift":
            speed += fault["rate"] * (t - fault["t"])
        yaw = None if gyro is None else w + gyro * rng.standard_normal()
        if yaw is not None and on and kind == "gyro":
            yaw += fault["bias"]
        if on and kind == "dropout":
            speed = None
        pose = np.array([x, y, psi]) + pose_sigma * rng.standard_normal(3)
        if on and kind in ("pose_bias", "pose_jump") and t < fault["t"] + fault.get("duration", math.inf):
            pose[:2] += fault["size"] * math.sqrt(0.5)  # along the 45° diagonal, as the fault library displaces it
        if on and kind == "pose_dropout" and t < fault["t"] + fault["duration"]:
            pose = None
        diag.step(DiagnosisInput(t=t, omega=omega.copy(), command=cmd.copy(), speed=speed, yaw_rate=yaw,
                                 pose=pose, pose_sigma=pose_sigma))
    return diag.declared


@pytest.mark.parametrize("sensing", [{}, {"gyro": None, "pose_sigma": 0.05, "pose_rate": 10.0}])
def test_a_healthy_robot_is_not_diagnosed(sensing: dict) -> None:
    assert drive({}, duration=30.0, **sensing) == []


@pytest.mark.parametrize("wheel, fraction", [(1, 0.5), (0, 0.95), (1, 0.3)])
def test_a_puncture_is_declared_on_its_tyre_within_two_seconds_with_its_remaining_fraction(
        wheel: int, fraction: float) -> None:
    found = drive({"kind": "puncture", "t": 10.0, "wheel": wheel, "fraction": fraction})
    assert {d.key for d in found} == {("tyre", ("right", "left")[wheel], "puncture")}  # its size may be re-declared
    assert 10.0 <= found[0].declared <= 12.0 and found[0].statistic > found[0].threshold
    assert found[-1].size == pytest.approx(fraction, abs=0.05)  # the mean since a change time on the windows' grid


def test_a_servo_loss_is_declared_on_its_servo_with_its_gain_fraction() -> None:
    found = drive({"kind": "loss", "t": 10.0, "wheel": 1, "effectiveness": 0.3}, servo_size_exponent=1.0)
    assert [d.key for d in found] == [("servo", "left", "loss")]
    assert found[0].size == pytest.approx(0.3, abs=0.1)  # without the closed loop's bias: the gain ratio itself


def test_a_locked_wheel_is_a_servo_lock_not_a_puncture() -> None:
    found = drive({"kind": "lock", "t": 10.0, "wheel": 0})
    assert found[0].key == ("servo", "right", "lock")
    assert found[0].declared <= 10.5
    assert all(d.component == "servo" for d in found)


def test_a_speed_bias_is_declared_as_such_with_its_size() -> None:
    found = drive({"kind": "speed", "t": 10.0, "bias": 0.4})
    assert [d.key for d in found] == [("speed sensor", "speed", "bias")]
    assert found[0].size == pytest.approx(0.4, abs=0.1)


def test_a_speed_drift_is_told_from_a_bias() -> None:
    found = drive({"kind": "speed_drift", "t": 8.0, "rate": 0.1}, duration=20.0)
    assert found[-1].key == ("speed sensor", "speed", "drift")
    assert found[-1].size == pytest.approx(0.1, rel=0.5)


def test_a_gyro_bias_is_declared_on_the_gyro_and_not_without_one() -> None:
    found = drive({"kind": "gyro", "t": 10.0, "bias": 0.05}, pose_sigma=0.005)  # heading σ per 0.5 s: 0.014 rad/s
    assert [d.key for d in found] == [("gyro", "yaw_rate", "bias")]
    assert found[0].size == pytest.approx(0.05, abs=max(0.01, 3.0 * found[0].sigma))
    assert drive({"kind": "gyro", "t": 10.0, "bias": 0.05}, gyro=None) == []


def test_a_dropout_is_declared_at_once() -> None:
    found = drive({"kind": "dropout", "t": 10.0})
    assert found[0].key == ("speed sensor", "speed", "dropout")
    assert found[0].declared <= 10.1


def test_the_declarations_are_rebuilt_from_the_trace() -> None:
    """The trace's declaration columns carry every field of each :class:`Diagnosis` (a new one where the count
    grows), so metrics need nothing but the trace."""
    found = drive({"kind": "puncture", "t": 5.0, "wheel": 1, "fraction": 0.5}, duration=8.0)
    diag_step = type("S", (), {})()
    w = TraceWriter(3)
    assert set(DIAGNOSIS_COLUMNS) <= set(w.columns)
    for k, declared in enumerate(([], found, found)):
        diag_step.statistics, diag_step.alarms, diag_step.declared = {"tyre_L": 1.0}, {"tyre_L": True}, declared
        w.diagnosis(k, diag_step)
    assert diagnoses_from_trace(w.columns) == found


def test_a_puncture_without_a_gyro_is_isolated_from_a_noisy_10_hz_pose() -> None:
    """The pose's heading change makes the left/right split observable without a gyro: σ = 5 cm (and rad)
    fixes at 10 Hz still isolate a 50 % left puncture within 2 s."""
    found = drive({"kind": "puncture", "t": 10.0, "wheel": 1, "fraction": 0.5}, gyro=None, pose_sigma=0.05,
                  pose_rate=10.0)
    assert {d.key for d in found} == {("tyre", "left", "puncture")}
    assert found[0].declared <= 12.0


POSE = {"pose_sigma": 0.03, "pose_rate": 10.0}  # a 10 Hz pose sensor of σ 3 cm


@pytest.mark.parametrize("size", [0.3, -1.5])
def test_a_displaced_pose_sensor_is_a_pose_bias_with_its_offset(size: float) -> None:
    found = drive({"kind": "pose_bias", "t": 10.0, "size": size}, **POSE)
    assert [d.key for d in found] == [("pose sensor", "pose", "bias")]
    assert 10.0 <= found[0].declared <= 11.5
    assert found[0].size == pytest.approx(size, abs=0.1)


def test_a_displacement_that_returns_is_a_pose_jump() -> None:
    found = drive({"kind": "pose_jump", "t": 10.0, "size": 2.0, "duration": 2.0}, **POSE)
    assert [d.key for d in found] == [("pose sensor", "pose", "bias"), ("pose sensor", "pose", "jump")]
    assert found[-1].size == pytest.approx(2.0, abs=0.1) and found[-1].onset == pytest.approx(10.0, abs=0.2)
    assert 12.0 <= found[-1].declared <= 13.5


def test_missing_pose_fixes_are_a_pose_dropout_within_a_few_intervals() -> None:
    found = drive({"kind": "pose_dropout", "t": 10.0, "duration": 3.0}, **POSE)
    assert [d.key for d in found] == [("pose sensor", "pose", "dropout")]
    assert 10.0 <= found[0].declared <= 10.45  # three 0.1 s intervals after the last fix
