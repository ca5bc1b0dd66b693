"""The fault library on the plants and sensors: each fault changes the physics or the reading as its
docstring states (:mod:`ftc_mj.plant.faults.servo`, :mod:`ftc_mj.plant.faults.sensor`), and
:func:`~ftc_mj.plant.faults.records.fault_list` reports every configured fault."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from ftc_mj.config import FaultSettings, PlantSettings, RobotSettings, SensorSettings
from ftc_mj.plant import KinematicPlant, Plant, Sensors, Truth
from ftc_mj.plant.faults import FaultSpec, fault_list
from ftc_mj.registry import fault_classes

KV, TAU_MAX = 10_000.0, 1500.0
"""The shipped robot's servo gain (N m s/rad) and torque limit (N m) (ftc_mj/data/models/diffdrive.xml)."""


def _plant(actuator: list[dict], **plant: object) -> Plant:
    return Plant(PlantSettings(**plant), RobotSettings(), FaultSettings(actuator=actuator))


def _servo(p: Plant, i: int) -> tuple[float, float, float]:
    """(gain, bias, upper torque limit) of wheel ``i``'s servo in MuJoCo's arrays."""
    a = p.layout.actuators[i]
    return (float(p.model.actuator_gainprm[a, 0]), float(p.model.actuator_biasprm[a, 2]),
            float(p.model.actuator_forcerange[a, 1]))


def _peak_torques(p: Plant, steps: int) -> np.ndarray:
    """Largest |servo torque| (N m) of each wheel over ``steps`` physics steps of a full-rate command
    from rest (the wheels far from their command: the servos saturate)."""
    p.set_command(17.0, 17.0)
    peak = np.zeros(2)
    for _ in range(steps):
        p.advance(1)
        peak = np.maximum(peak, np.abs(p.data.actuator_force[list(p.layout.actuators)]))
    return peak


def test_a_50_percent_loss_halves_the_servo_torque_limit_and_gain() -> None:
    """Left servo at 50 % from 0.1 s: before it both saturate at τ_max = 1500 N m; after it MuJoCo's arrays
    hold gain kv/2 and limit τ_max/2 and the left servo's torque saturates at exactly 750 N m (clipping is
    exact: 1e-9 relative) while the right one still gives 1500 N m; in the linear range the torque is
    e kv (ω_cmd − ω) (1e-9 relative)."""
    p = _plant([{"wheel": "left", "kind": "loss", "onset": 0.1, "effectiveness": 0.5}])
    assert _servo(p, 1) == (KV, -KV, TAU_MAX)
    np.testing.assert_allclose(_peak_torques(p, 50), [TAU_MAX, TAU_MAX], rtol=1e-9)
    p.reset()
    p.advance(100)  # to the onset: the fault acts from step 100 on
    p.set_command(0.0, 0.0)
    p.advance(1)
    assert _servo(p, 1) == (KV / 2, -KV / 2, TAU_MAX / 2) and _servo(p, 0) == (KV, -KV, TAU_MAX)
    np.testing.assert_allclose(_peak_torques(p, 50), [TAU_MAX, TAU_MAX / 2], rtol=1e-9)
    p.set_command(0.0, p.truth().omega_L + 0.01)  # 0.01 rad/s error: 50 N m, far below the limit
    p.forward()
    a = p.layout.actuators[1]
    err = p.data.ctrl[a] - p.data.qvel[p.layout.hinge_v[1]]
    assert p.data.actuator_force[a] == pytest.approx(0.5 * KV * err, rel=1e-9)
    p.reset()
    assert _servo(p, 1) == (KV, -KV, TAU_MAX)  # a reset plant is healthy again until the onset


def test_an_unresponsive_servo_gives_no_torque_and_its_wheel_rolls_free() -> None:
    """Left servo dead from 0.2 s while the robot rolls at 4 m/s, both wheels commanded to stop: the dead
    servo's torque is 0 (exactly) and its wheel keeps rolling with the ground, at the rate (v − b ψ̇)/R of
    its contact point's speed (within 10 %: tyre creep and the hinge's damping; the healthy right servo
    stops its wheel, below 0.2 rad/s of its 2 rad/s)."""
    p = _plant([{"wheel": "left", "kind": "unresponsive", "onset": 0.2}])
    p.set_motion(4.0, 0.0)
    p.advance(200)
    p.set_command(0.0, 0.0)
    for _ in range(18):
        p.advance(100)
        tr = p.truth()
        p.forward()
        assert p.data.actuator_force[p.layout.actuators[1]] == 0.0
    b = RobotSettings().half_track
    assert tr.omega_L == pytest.approx((tr.v - b * tr.yaw_rate) / tr.R_L, rel=0.1) and abs(tr.omega_L) > 0.5
    assert abs(tr.omega_R) < 0.2


def test_a_locked_wheel_stays_put() -> None:
    """Left wheel locked at 0.1 s while the robot drives straight at 10 m/s (wheel rate 5 rad/s): from 50 ms
    after the lock its rate stays ≤ 2e-3 rad/s (0.04 % of 5 rad/s; measured 6e-4) while its tyre skids and
    the robot swerves towards it (the lock's dry friction, 1e5 N m, outweighs the ≤ 4000 N m on the wheel)."""
    p = _plant([{"wheel": "left", "kind": "lock", "onset": 0.1}])
    p.set_motion(10.0, 0.0)
    rates, yaw = [], []
    for _ in range(150):
        p.set_command(5.0, 5.0)
        p.advance(10)
        tr = p.truth()
        if tr.t >= 0.15:
            rates.append(abs(tr.omega_L))
            yaw.append(tr.yaw_rate)
    assert max(rates) <= 2e-3 and max(yaw) > 0.2  # turning left, about the locked left wheel
    p.reset()
    assert p.model.dof_frictionloss[p.layout.hinge_v[1]] == 0.0


def test_a_locked_wheel_on_the_kinematic_plant_pivots_the_robot() -> None:
    """Kinematic plant, left wheel locked at 0.5 s: its rate is 0 whatever the command and the robot
    pivots about it, yaw rate R ω_R / (2 b) (exact to 1e-12)."""
    faults = FaultSettings(actuator=[{"wheel": "left", "kind": "lock", "onset": 0.5}])
    p = KinematicPlant(PlantSettings(kind="kinematic"), RobotSettings(), faults)
    p.set_command(3.0, 3.0)
    p.advance(400)
    assert p.truth().omega_L == 3.0
    p.advance(200)
    p.set_command(3.0, 3.0)
    tr = p.truth()
    assert tr.omega_L == 0.0 and tr.omega_R == 3.0
    assert tr.yaw_rate == pytest.approx(2.0 * 3.0 / 2.0, abs=1e-12)


# ---------------------------------------------------------------------------- sensors
def _truth(v: float = 10.0, yaw: float = 0.2) -> Truth:
    return Truth(t=0.0, x=0.0, y=0.0, psi=0.0, v=v, yaw_rate=yaw, omega_R=5.0, omega_L=5.0, R_R=2.0, R_L=2.0,
                 roll=0.0, pitch=0.0, z_chassis=2.0, slip_R=0.0, slip_L=0.0, contact_R=True, contact_L=True,
                 flags=0)


def _readings(faults: list[dict], n: int, gyro: float = 0.01) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, speed, yaw rate) of ``n`` readings at 100 Hz of a constant truth (10 m/s, 0.2 rad/s)."""
    s = Sensors(SensorSettings(yaw_rate_sigma=gyro), 7, FaultSettings(sensor=faults))
    t = np.arange(n) * 0.01
    rd = [s.read(_truth(), ti) for ti in t]
    return t, np.array([r.speed for r in rd]), np.array([r.yaw_rate for r in rd])


N = 4000
"""Readings per sensor statistic (100 Hz, 40 s)."""


@pytest.mark.parametrize(("sensor", "size", "sigma", "truth"), [("speed", 0.3, 0.5, 10.0),
                                                                ("yaw_rate", 0.05, 0.01, 0.2)])
def test_a_bias_shifts_the_mean_by_the_bias(sensor: str, size: float, sigma: float, truth: float) -> None:
    """A bias from t = 0 shifts the mean of N = 4000 readings by the bias within 3σ/√N of the sensor's
    noise (speed σ = 0.5 m/s: 0.024 m/s; gyro σ = 0.01 rad/s: 4.7e-4 rad/s), and a reading differs from
    its healthy twin (same seed) by exactly the bias (1e-12)."""
    _, v, w = _readings([{"sensor": sensor, "kind": "bias", "onset": 0.0, "size": size}], N)
    _, v0, w0 = _readings([], N)
    got, healthy = (v, v0) if sensor == "speed" else (w, w0)
    assert abs(got.mean() - truth - size) <= 3 * sigma / math.sqrt(N)
    np.testing.assert_allclose(got - healthy, size, atol=1e-12)
    np.testing.assert_array_equal(w if sensor == "speed" else v, w0 if sensor == "speed" else v0)


@pytest.mark.parametrize("sensor", ["speed", "yaw_rate"])
def test_a_drift_grows_linearly_from_its_onset_and_ends_with_it(sensor: str) -> None:
    """A drift of 0.01 per s from 10 s for 20 s: the reading minus its healthy twin is 0 before 10 s,
    0.01 (t − 10) until 30 s and 0 after (1e-12)."""
    t, v, w = _readings([{"sensor": sensor, "kind": "drift", "onset": 10.0, "size": 0.01, "duration": 20.0}], N)
    _, v0, w0 = _readings([], N)
    diff = v - v0 if sensor == "speed" else w - w0
    want = np.where((t >= 10.0 - 1e-9) & (t < 30.0 - 1e-9), 0.01 * (t - 10.0), 0.0)
    np.testing.assert_allclose(diff, want, atol=1e-12)


@pytest.mark.parametrize("sensor", ["speed", "yaw_rate"])
def test_a_dropout_misses_its_samples_and_leaves_the_others(sensor: str) -> None:
    """A dropout from 1 s for 0.5 s: exactly the 50 samples in [1, 1.5) s are NaN, the other sensor's
    readings (and this one's outside the window) are those of the healthy twin."""
    t, v, w = _readings([{"sensor": sensor, "kind": "dropout", "onset": 1.0, "duration": 0.5}], 300)
    _, v0, w0 = _readings([], 300)
    got, other, got0, other0 = (v, w, v0, w0) if sensor == "speed" else (w, v, w0, v0)
    missing = np.isnan(got)
    assert missing.sum() == 50 and np.all(missing == ((t >= 1.0 - 1e-9) & (t < 1.5 - 1e-9)))
    np.testing.assert_array_equal(got[~missing], got0[~missing])
    np.testing.assert_array_equal(other, other0)


# ---------------------------------------------------------------------------- the fault list
def test_fault_list_reports_every_configured_fault() -> None:
    """Step and ramp punctures on either wheel (size = radius lost, m), servo and sensor faults (size in
    the class's unit), in configuration order; a schedule that never leaves nominal is no fault."""
    faults = FaultSettings(
        right=[[5.0, 2.0], [5.0, 1.4]], left=[[10.0, 2.0], [29.0, 0.1]],
        actuator=[{"wheel": "left", "kind": "loss", "onset": 3.0, "effectiveness": 0.25},
                  {"wheel": "right", "kind": "lock", "onset": 4.0},
                  {"wheel": "left", "kind": "unresponsive", "onset": 6.0}],
        sensor=[{"sensor": "speed", "kind": "bias", "onset": 1.0, "size": -0.3},
                {"sensor": "yaw_rate", "kind": "drift", "onset": 2.0, "size": 0.002},
                {"sensor": "yaw_rate", "kind": "dropout", "onset": 7.0, "duration": 1.5}])
    specs = fault_list(faults, 2.0)
    assert [(s.fault_class, s.target, s.onset) for s in specs] == [
        ("puncture", "right", 5.0), ("puncture", "left", 10.0), ("actuator_loss", "left", 3.0),
        ("wheel_lock", "right", 4.0), ("actuator_unresponsive", "left", 6.0), ("speed_bias", "speed", 1.0),
        ("gyro_drift", "yaw_rate", 2.0), ("gyro_dropout", "yaw_rate", 7.0)]
    assert [s.size for s in specs] == pytest.approx([0.6, 1.9, 0.75, 1.0, 1.0, -0.3, 0.002, 1.5])
    assert {s.fault_class for s in specs} <= set(fault_classes.names())
    assert fault_list(FaultSettings(left=[[3.0, 2.0], [9.0, 2.0]]), 2.0) == []
    assert FaultSpec("gyro_bias", "yaw_rate", 1.0, 0.05).describe() == "gyro_bias on yaw_rate, size 0.05 rad/s"
    both = FaultSettings(right=[[8.0, 2.0], [8.0, 1.0]], left=[[8.0, 2.0], [8.0, 1.0]])
    assert [(s.target, s.size) for s in fault_list(both, 2.0)] == [("right", 1.0), ("left", 1.0)]


def test_servo_faults_leave_the_physics_step_untouched_without_them() -> None:
    """Without servo faults an advance is one ``mj_step(m, d, n)`` (the plant's state equals that of a bare
    MuJoCo copy stepped alike, bitwise)."""
    p = _plant([])
    p.set_motion(10.0, 0.2)
    m, d = p.model, mujoco.MjData(p.model)
    d.qpos[:], d.qvel[:], d.ctrl[:] = p.data.qpos, p.data.qvel, p.data.ctrl
    mujoco.mj_forward(m, d)
    p.advance(250)
    mujoco.mj_step(m, d, 250)
    np.testing.assert_array_equal(p.data.qpos, d.qpos)


def test_the_docs_fault_table_is_the_classes_and_each_class_is_one_registered_object() -> None:
    """docs/scenarios.md's table is generated from the registered classes; every class names its targets,
    truth columns of each target and the measurements that observe it (a gyro fault: the gyro alone)."""
    from pathlib import Path

    from ftc_mj.plant.faults import all_classes, fault_class
    from ftc_mj.plant.faults.base import markdown_table

    builtin = [c for c in all_classes() if fault_classes.get(c.name).origin == "built-in"]
    doc = (Path(__file__).resolve().parents[2] / "docs" / "scenarios.md").read_text()
    assert markdown_table(builtin) in doc
    assert {c.name for c in builtin} == {"puncture", "actuator_loss", "wheel_lock", "actuator_unresponsive",
                                         *(f"{s}_{m}" for s in ("speed", "gyro") for m in ("bias", "drift", "dropout")),
                                         *(f"pose_{m}" for m in ("bias", "jump", "dropout"))}
    for c in builtin:
        assert c.targets and all(c.columns(t) for t in c.targets) and c.observed_by, c.name
    assert fault_class("gyro_bias").observed_by == ("yaw_rate",) and fault_class("speed_drift").unit == "m/s²"
    assert fault_class("pose_jump").component == "pose sensor" and fault_class("pose_jump").targets == ("pose",)
