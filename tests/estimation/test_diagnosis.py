"""The built-in diagnoser on a synthetic robot whose truth is known exactly: each fault class is declared
with its component, target and mode (and a size close to the truth), a healthy robot is not, and a record
survives the trace."""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

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
from ftc_mj.sim.summary import diagnosis_lines
from ftc_mj.sim.trace import TraceWriter

DT, R0, B = 0.01, 2.0, 1.0


def context(gyro: float | None = 0.01, speed_sigma: float = 0.3) -> RunContext:
    return RunContext(seed=0, duration=30.0, physics_dt=1e-3, estimator_dt=DT, controller_dt=0.1,
                      nominal_radii=(R0, R0), half_track=B, omega_max=20.0, initial_pose=(0.0, 0.0, 0.0),
                      sensors=SensorSettings(speed_sigma=speed_sigma, yaw_rate_sigma=gyro))


def drive(fault: dict, duration: float = 20.0, gyro: float | None = 0.01, pose_sigma: float = 0.02,
          seed: int = 3, fixes: list | None = None, lock: tuple[float, int] | None = None,
          change: object = None, **settings: float) -> list[Diagnosis]:
    """A unicycle on a 50 m circle at 10 m/s with first-order wheel servos (gain α per step) under a steady
    load, exact kinematics and Gaussian sensors; ``fault``: ``{"kind": ..., "t": onset, ...}`` (a puncture with
    ``"reverse"``: from that time the pose moves backwards while the wheels roll forwards, as a robot that has
    lost the path and skids); ``lock``: ``(t, wheel)``, that wheel also locked from ``t`` (s); ``change``: the fast
    tyre detector handed to the diagnoser (none by default); returns the
    declarations, and appends ``(t, fix, true position)`` of each pose
    fix handed over to ``fixes``."""
    rng = np.random.default_rng(seed)
    diag = ResidualDiagnoser(ResidualDiagnoserSettings(**settings), context(gyro), change)
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
        if lock is not None and t >= lock[0]:
            omega[lock[1]] = 0.0
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
        if on and kind == "puncture" and t >= fault.get("reverse", math.inf):
            x, y = x - 2.0 * v * math.cos(psi) * DT, y - 2.0 * v * math.sin(psi) * DT
        pose = np.array([x, y, psi]) + pose_sigma * rng.standard_normal(3)
        if on and kind in ("pose_bias", "pose_jump") and t < fault["t"] + fault.get("duration", math.inf):
            pose[:2] += fault["size"] * math.sqrt(0.5)  # along the 45° diagonal, as the fault library displaces it
        if on and kind == "pose_dropout" and t < fault["t"] + fault["duration"]:
            pose = None
        diag.step(DiagnosisInput(t=t, omega=omega.copy(), command=cmd.copy(), speed=speed, yaw_rate=yaw,
                                 pose=pose, pose_sigma=pose_sigma))
        if fixes is not None and pose is not None and diag.history.fix_t and diag.history.fix_t[-1] == t:
            fixes.append((t, pose[:2].copy(), np.array([x, y])))
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


class AlarmBetween:
    """A fast tyre detector (:class:`~ftc_mj.estimation.diagnosis.change.TyreChangeAlarm`'s interface) in alarm
    from ``start`` to ``end`` (s) and quiet otherwise."""

    def __init__(self, start: float, end: float) -> None:
        self.start, self.end = start, end

    def step(self, z: DiagnosisInput) -> tuple[float, float]:
        return (10.0 if self.start <= z.t < self.end else 0.0), 5.0

    def anchor(self, radii: object) -> None:
        pass


def test_no_servo_loss_is_declared_while_the_fast_tyre_detector_is_in_alarm() -> None:
    """A radius changing explains a lag change as well as a servo does: the loss declared at 11.15 s without the
    detector waits for it to fall quiet at 13 s, and is then declared at once (its alarm confirmed meanwhile)."""
    fault = {"kind": "loss", "t": 10.0, "wheel": 1, "effectiveness": 0.3}
    alone = drive(fault, duration=16.0, servo_size_exponent=1.0)
    assert [d.key for d in alone] == [("servo", "left", "loss")] and alone[0].declared < 12.0
    found = drive(fault, duration=16.0, servo_size_exponent=1.0, change=AlarmBetween(9.5, 13.0))
    assert [d.key for d in found] == [("servo", "left", "loss")]
    assert 13.0 <= found[0].declared <= 13.0 + 2 * DT and found[0].size == pytest.approx(alone[0].size, abs=0.1)


def test_a_locked_wheel_is_a_servo_lock_not_a_puncture() -> None:
    found = drive({"kind": "lock", "t": 10.0, "wheel": 0})
    assert found[0].key == ("servo", "right", "lock")
    s = ResidualDiagnoserSettings()  # the window's mean crosses the alarm within it, then the alarm holds lock_confirm
    assert found[0].declared <= 10.0 + s.lock_window + s.lock_confirm + 2 * DT
    assert all(d.component == "servo" for d in found)


@pytest.mark.parametrize("lock_confirm, declared", [(0.1, False), (0.0, True)])
def test_a_wheel_commanded_to_reverse_is_not_a_lock(lock_confirm: float, declared: bool) -> None:
    """A wheel commanded from +0.45 to −1.5 rad/s (dev draw 54's left wheel) passes through rest at its servo's
    pace (5 rad/s², here 0.1 rad/s per step after 0.2 s of lag): the lock statistic, ``1 − |mean ω| / |mean
    command|`` over 0.1 s, exceeds the alarm while it crosses zero, for less than ``lock_confirm``'s 0.1 s; at 0 s
    that is a false lock."""
    diag = ResidualDiagnoser(ResidualDiagnoserSettings(lock_confirm=lock_confirm), context(0.01))
    omega, found = np.array([3.0, 0.45]), []
    for k in range(300):
        t = k * DT
        cmd = np.array([3.0, 0.45 if t < 1.0 else -1.5])
        if t >= 1.2:  # the servo's lag, then its acceleration limit
            omega[1] = max(omega[1] - 0.05, -1.5)
        v, w = 0.5 * R0 * (omega[0] + omega[1]), R0 * (omega[0] - omega[1]) / (2 * B)
        found += diag.step(DiagnosisInput(t=t, omega=omega.copy(), command=cmd, speed=v, yaw_rate=w, pose=None,
                                          pose_sigma=0.02)).new
    assert any(d.key == ("servo", "left", "lock") for d in found) is declared


def test_a_wheel_that_locks_after_a_puncture_is_still_a_servo_lock() -> None:
    """A lock is a wheel at rest under its command, whatever its tyre: declared after a declared puncture as soon as
    on a healthy robot (the servo regression, which a puncture disturbs, stays silent after one)."""
    found = drive({"kind": "puncture", "t": 5.0, "wheel": 1, "fraction": 0.5}, duration=14.0, lock=(10.0, 0))
    assert found[0].key == ("tyre", "left", "puncture") and found[0].declared < 10.0
    servo = [d for d in found if d.component == "servo"]
    assert [d.key for d in servo] == [("servo", "right", "lock")]
    assert 10.0 <= servo[0].declared <= 10.5


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


@pytest.mark.parametrize("seed", [3, 4, 5])
def test_a_pose_bias_corrected_by_its_offset_leaves_fixes_of_zero_mean_error(seed: int) -> None:
    """The record carries the displacement as a vector ``(dx, dy)`` with its σ per axis; the fixes after the
    declaration less that offset scatter about the true position with zero mean: each axis's mean error over the
    N fixes lies within 4σ of 0, σ² = σ_axis² + σ_fix² / N (the offset's error is common to every fix)."""
    fixes: list = []
    size = 0.4
    found = drive({"kind": "pose_bias", "t": 10.0, "size": size}, seed=seed, fixes=fixes, **POSE)
    (d,) = found
    assert d.offset is not None and min(d.offset_sigma) > 0.0
    truth = size * math.sqrt(0.5)
    assert all(abs(o - truth) <= 4.0 * s for o, s in zip(d.offset, d.offset_sigma, strict=True))
    after = [(fix, true) for t, fix, true in fixes if t > d.declared]
    errors = np.asarray([fix - np.asarray(d.offset) - true for fix, true in after])
    n = len(errors)
    assert n > 50
    tolerance = 4.0 * np.sqrt(np.asarray(d.offset_sigma) ** 2 + POSE["pose_sigma"] ** 2 / n)
    assert np.all(np.abs(errors.mean(axis=0)) <= tolerance)


def test_a_returned_jump_withdraws_the_offset() -> None:
    """A jump seen to return is re-declared with the offset ``(0, 0)``: the fixes are taken as they come."""
    found = drive({"kind": "pose_jump", "t": 10.0, "size": 2.0, "duration": 2.0}, **POSE)
    bias, jump = found
    assert bias.offset == pytest.approx((2.0 * math.sqrt(0.5),) * 2, abs=0.1)
    assert jump.offset == (0.0, 0.0)


def test_a_tyre_is_never_declared_outside_its_physical_size() -> None:
    """A 50 % left puncture, then the robot skids backwards while its wheels roll forwards (a loop that has lost
    the path): the rolling ratio leaves (0, 1]; no declaration reads it — the declared size stands."""
    found = drive({"kind": "puncture", "t": 5.0, "wheel": 1, "fraction": 0.5, "reverse": 9.0}, duration=16.0)
    tyres = [d for d in found if d.component == "tyre"]
    assert tyres and all(0.0 < d.size <= 1.0 for d in tyres)
    assert tyres[-1].size == pytest.approx(0.5, abs=0.1)


def test_the_record_bounds_a_tyre_size_and_round_trips_its_offset() -> None:
    """A tyre's size lies in (0, 1]; an offset comes with its σ, on a pose bias or jump only, and survives the
    dict/JSON form and the trace."""
    for size in (0.0, -0.2, 1.2, math.nan):
        with pytest.raises(ValueError, match=r"outside \(0, 1\]"):
            Diagnosis("tyre", "left", "puncture", size, 0.01, 1.0, 1.5, 20.0, 12.5)
    with pytest.raises(ValueError, match="no offset vector"):
        Diagnosis("speed sensor", "speed", "bias", 0.2, 0.01, 1.0, 1.5, 20.0, 12.5, (0.2, 0.0), (0.01, 0.01))
    with pytest.raises(ValueError, match="together"):
        Diagnosis("pose sensor", "pose", "bias", 0.2, 0.01, 1.0, 1.5, 20.0, 12.5, offset=(0.1, 0.1))
    d = Diagnosis("pose sensor", "pose", "bias", -0.3, 0.02, 10.0, 10.4, 30.0, 20.0, (-0.2, -0.22), (0.015, 0.02))
    assert Diagnosis.from_dict(json.loads(json.dumps(d.as_dict()))) == d
    (line,) = diagnosis_lines({"diagnoses": [d.as_dict()]})
    assert line.endswith("size -0.3, offset (-0.2, -0.22) m (onset 10.00 s)")
    old = {k: v for k, v in d.as_dict().items() if not k.startswith("offset")}  # a record written before them
    assert Diagnosis.from_dict(old).offset is None
    w, step = TraceWriter(3), type("S", (), {"statistics": {}, "alarms": {}})()
    tyre = Diagnosis("tyre", "left", "puncture", 0.5, 0.01, 1.0, 1.2, 20.0, 12.5)
    unbounded = SimpleNamespace(**{**tyre.as_dict(), "size": -0.4, "declared": 12.0})  # as an older version wrote
    for k, declared in enumerate(([tyre], [tyre, d], [tyre, d, unbounded])):
        step.declared = declared
        w.diagnosis(k, step)
    assert diagnoses_from_trace(w.columns) == [tyre, d]  # the tyre below 0 of an older trace is left out
