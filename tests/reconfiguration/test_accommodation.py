"""Accommodation per diagnosed mode, the truth as a diagnosis (the oracle) and the safe stop.

Unit level: the truth source declares each configured fault at its onset with the truth's size and withdraws a
sensor fault at its end; the accommodation stops on a lock, scales the actuator model on a loss, corrects biased
readings and excludes dropped channels; the stop law brakes along the profile, within the traction bound, steers
towards the path and commands nothing at rest. Closed loop (MuJoCo, scenario 2's circle): a locked left wheel at
10 s is braked to rest inside the corridor (acceptance 3 of issue 42, dev seed), and a servo at 30 % is tracked
with the actuator model scaled (acceptance 4) — each against the loop without the accommodation.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ftc_mj.config import load_config
from ftc_mj.control.reference import CircleReference
from ftc_mj.control.stop import SafeStop, SafeStopSettings, StopLimits
from ftc_mj.errors import BadInput
from ftc_mj.estimation.base import FilterOutput, Measurement
from ftc_mj.estimation.decision import DecisionState
from ftc_mj.model.diagnosis import Diagnosis
from ftc_mj.plant.faults import FaultSettings
from ftc_mj.reconfiguration.accommodation import Accommodation, AccommodationMode, AccommodationSettings
from ftc_mj.reconfiguration.oracle import TruthDiagnoses
from ftc_mj.rerun.read import read_scalar_series
from ftc_mj.rerun.record import write_rrd
from ftc_mj.sim.loop import simulate

NAN = float("nan")
LIMITS = StopLimits(half_track=1.0, omega_max=10.0, omega_rate_max=20.0, sample_time=0.1, liftoff_accel=3.92,
                    braking_trade=0.75, max_longitudinal_accel=3.0)


def _diag(component: str, target: str, mode: str, size: float, onset: float = 1.0) -> Diagnosis:
    return Diagnosis(component, target, mode, size, 0.0, onset, onset, NAN, NAN)


def _stop(path=None) -> SafeStop:
    return SafeStop(SafeStopSettings(), LIMITS, path or CircleReference(radius=50.0, speed=10.0))


def _accommodation() -> Accommodation:
    return Accommodation(AccommodationSettings(mode="all"), _stop())


# ---------------------------------------------------------------- the truth as a diagnosis
def test_truth_declares_each_fault_from_its_onset_with_the_truths_size() -> None:
    """A ramp puncture (2 → 1 m over 10–20 s), a 30 % servo, a lock and a speed bias that ends: nothing before
    the onsets; at 15 s the tyre is declared at its current 75 %, the servo at 0.3, the lock at 0; the bias
    (0.5 m/s, 12–14 s) is withdrawn at its end."""
    faults = FaultSettings(left=[[10.0, 2.0], [20.0, 1.0]],
                           actuator=[{"wheel": "left", "kind": "loss", "onset": 11.0, "effectiveness": 0.3},
                                     {"wheel": "right", "kind": "lock", "onset": 14.0}],
                           sensor=[{"sensor": "speed", "kind": "bias", "onset": 12.0, "size": 0.5, "duration": 2.0}])
    truth = TruthDiagnoses(faults, 2.0)
    assert truth.diagnoses(9.99) == ()
    at = {d.key: d for d in truth.diagnoses(13.0)}
    assert set(at) == {("tyre", "left", "puncture"), ("servo", "left", "loss"), ("speed sensor", "speed", "bias")}
    assert at["tyre", "left", "puncture"].size == pytest.approx(0.85)
    assert at["servo", "left", "loss"].size == 0.3 and at["servo", "left", "loss"].declared == 11.0
    assert at["speed sensor", "speed", "bias"].size == 0.5
    later = {d.key: d for d in truth.diagnoses(15.0)}
    assert ("speed sensor", "speed", "bias") not in later
    assert later["tyre", "left", "puncture"].size == pytest.approx(0.75)
    assert later["servo", "right", "lock"].size == 0.0


def test_accommodating_every_mode_needs_a_diagnosis_source() -> None:
    """``mode = "all"`` with neither a diagnoser nor ``oracle = true``: a one-line error naming the field; the
    default diagnoser or an oracle run is a source."""
    with pytest.raises(BadInput, match=r"reconfiguration\.accommodation\.mode"):
        load_config("scenario2", {"reconfiguration.accommodation.mode": "all", "diagnosis.kind": "none"})
    assert load_config("scenario2", {"reconfiguration.accommodation.mode": "all", "diagnosis.kind": "none",
                                     "oracle": True}).oracle
    assert load_config("scenario2", {"reconfiguration.accommodation.mode": "all"}).diagnosis.kind == "residual"


def test_in_force_keeps_the_latest_declaration_per_component() -> None:
    """A diagnoser's re-declarations replace its earlier words on the same (component, target)."""
    from ftc_mj.model.diagnosis import Diagnosis, in_force

    bias = Diagnosis("gyro", "yaw_rate", "bias", 0.04, 0.01, 10.0, 11.7, 30.0, 20.0)
    drift = Diagnosis("gyro", "yaw_rate", "drift", 0.005, 0.001, 10.0, 14.0, 40.0, 20.0)
    tyre = Diagnosis("tyre", "left", "puncture", 0.5, 0.02, 10.0, 10.6, 50.0, 20.0)
    assert in_force([bias, tyre, drift]) == (tyre, drift)
    assert in_force([]) == ()


# ---------------------------------------------------------------- per mode
def test_a_lock_enters_the_safe_stop_for_good_with_its_reason() -> None:
    acc = _accommodation()
    acc.update(5.0, ())
    assert acc.state == AccommodationMode.NOMINAL and not acc.events
    acc.update(10.0, (_diag("servo", "left", "lock", 0.0, 10.0),))
    assert acc.stopping and acc.state == AccommodationMode.STOPPING
    assert "left servo lock declared at 10.00 s" in acc.stop_reason
    assert [e.text for e in acc.events if e.text.startswith("safe stop: ")] == [f"safe stop: {acc.stop_reason}"]
    acc.update(11.0, ())  # a withdrawn declaration does not restart the robot
    assert acc.stopping


@pytest.mark.parametrize(("diagnosis", "stops"), [
    (("servo", "left", "loss", 0.3), False), (("servo", "right", "loss", 0.04), True),
    (("servo", "left", "unresponsive", 0.0), True), (("tyre", "left", "puncture", 0.3), False),
    (("tyre", "right", "puncture", 0.05), False), (("tyre", "right", "puncture", 0.015), True)])
def test_what_leaves_the_path_out_of_reach(diagnosis, stops: bool) -> None:
    acc = _accommodation()
    acc.update(1.0, (_diag(*diagnosis),))
    assert acc.stopping is stops


def test_a_servo_loss_scales_the_actuator_model_once() -> None:
    """Effectiveness per wheel handed to the controller with one event; the same declaration again changes
    nothing and logs nothing."""
    acc = _accommodation()

    class Controller:
        given = None

        def set_actuator_effectiveness(self, e):
            self.given = e

    ctl = Controller()
    loss = (_diag("servo", "left", "loss", 0.3),)
    assert acc.update(1.0, loss)
    acc.hand_actuator(1.0, ctl)
    assert np.array_equal(ctl.given, [1.0, 0.3]) and acc.state == AccommodationMode.ACCOMMODATED
    n = len(acc.events)
    assert not acc.update(1.1, loss)
    assert len(acc.events) == n
    assert any("actuator model changed" in e.text for e in acc.events)


def test_sensor_offsets_are_removed_and_dropped_channels_excluded() -> None:
    """Bias subtracted, drift subtracted as its rate times the time since onset, a gyro dropout and a pose jump
    excluded; the controller's pose is then the filter's."""
    acc = _accommodation()
    acc.update(3.0, (_diag("speed sensor", "speed", "drift", 0.2, 1.0), _diag("gyro", "yaw_rate", "dropout", 2.0),
                     _diag("pose sensor", "pose", "jump", 1.5)))
    z = acc.correct(3.0, Measurement(speed=10.4, yaw_rate=None, position=np.array([1.0, 2.0])))
    assert z.speed == pytest.approx(10.0) and z.yaw_rate is None and z.position is None
    assert acc.events[-1].text == ("accommodation: speed speed sensor drift (0.2): reading corrected, yaw_rate gyro "
                                   "dropout (2): excluded from the filter, pose pose sensor jump (1.5): excluded from "
                                   "the filter and the controller's pose")
    out = FilterOutput(x=np.array([1.1, 2.1, 0.3, 2.0, 2.0]), P=np.eye(5), innovation=np.zeros(1), S=np.eye(1),
                       nis=1.0, speed_innovation=0.0, speed_innovation_std=1.0)
    assert np.array_equal(acc.controller_pose(np.array([1.0, 2.0, 0.2]), out), [1.1, 2.1, 0.3])
    acc.update(3.1, (_diag("speed sensor", "speed", "bias", 0.5),))
    assert acc.correct(3.1, Measurement(speed=10.5)).speed == pytest.approx(10.0)


def test_a_dropped_channel_is_taken_again_once_it_delivers() -> None:
    """A declared dropout excludes its channel while it delivers nothing; its first reading after the declaration
    ends the dropout (one event) and is taken, as are the later ones, although the declaration stays in force; a
    new dropout of the same channel (a later declaration) excludes it again. The pose sensor's return gives the
    controller the sensors' pose again. (The truth withdraws a dropout at its end: the oracle's semantics.)"""
    acc = _accommodation()
    gyro = _diag("gyro", "yaw_rate", "dropout", 0.3, 2.0)
    pose = Diagnosis("pose sensor", "pose", "dropout", 0.3, 0.0, 2.0, 2.3, 0.3, 0.3)
    acc.update(2.4, (gyro, pose))
    assert acc.excluded == {"yaw_rate", "position"}
    out = FilterOutput(x=np.array([1.1, 2.1, 0.3, 2.0, 2.0]), P=np.eye(5), innovation=np.zeros(1), S=np.eye(1),
                       nis=1.0, speed_innovation=0.0, speed_innovation_std=1.0)
    assert np.array_equal(acc.controller_pose(np.array([1.0, 2.0, 0.2]), out), [1.1, 2.1, 0.3])
    assert acc.correct(2.5, Measurement(speed=10.0)).speed == 10.0  # nothing from either: still out
    assert acc.excluded == {"yaw_rate", "position"}
    z = acc.correct(2.6, Measurement(speed=10.0, yaw_rate=0.2))
    assert z.yaw_rate == 0.2 and acc.excluded == {"position"}
    assert acc.events[-1].text == ("accommodation: yaw_rate gyro dropout (0.3): delivers again: readings taken as "
                                   "they come")
    n = len(acc.events)
    acc.update(2.7, (gyro, pose))  # the declarations stay in force; the gyro is not excluded again
    assert acc.excluded == {"position"} and len(acc.events) == n
    z = acc.correct(2.8, Measurement(speed=10.0, yaw_rate=0.1, position=np.array([1.0, 2.0]), heading=0.2))
    assert z.yaw_rate == 0.1 and np.array_equal(z.position, [1.0, 2.0]) and acc.excluded == frozenset()
    assert acc.events[-1].text.endswith("pose sensor dropout (0.3): delivers again: fixes taken as they come")
    assert np.array_equal(acc.controller_pose(np.array([1.0, 2.0, 0.2]), out), [1.0, 2.0, 0.2])
    acc.update(2.9, (gyro, pose))
    assert acc.excluded == frozenset() and len(acc.events) == n + 1
    acc.update(5.0, (_diag("gyro", "yaw_rate", "dropout", 0.3, 4.7), pose))  # a second dropout: out again
    assert acc.excluded == {"yaw_rate"}
    assert acc.correct(5.1, Measurement(speed=10.0, yaw_rate=0.1)).yaw_rate == 0.1 and acc.excluded == frozenset()


def _pose(mode: str, offset: tuple[float, float], sigma: tuple[float, float] = (0.01, 0.01)) -> Diagnosis:
    return Diagnosis("pose sensor", "pose", mode, sum(offset) * 0.5**0.5, 0.01, 1.0, 1.4, 30.0, 20.0, offset, sigma)


def test_a_pose_offset_is_subtracted_from_the_fixes_and_withdrawn_when_it_returns() -> None:
    """A declared pose bias with its offset: the fix's (x, y) less the offset, its heading untouched, the channel
    kept (the controller's pose stays the loop's); a jump seen to return (offset 0) leaves the fixes as they come;
    an offset whose σ exceeds ``pose_correct_sigma`` of its length, or one without an offset, excludes them."""
    acc = _accommodation()
    acc.update(2.0, (_pose("bias", (0.3, 0.3)),))
    z = acc.correct(2.0, Measurement(speed=10.0, position=np.array([1.0, 2.0]), heading=0.4))
    assert np.allclose(z.position, [0.7, 1.7]) and z.heading == 0.4 and z.speed == 10.0
    assert "position" not in acc.excluded
    assert np.array_equal(acc.controller_pose(np.array([1.0, 2.0, 0.2]), None), [1.0, 2.0, 0.2])
    assert acc.events[-1].text.endswith("fixes corrected by (0.3, 0.3) m")
    acc.update(4.0, (_pose("jump", (0.0, 0.0)),))
    assert np.array_equal(acc.correct(4.0, Measurement(speed=10.0, position=np.array([1.0, 2.0]))).position, [1.0, 2.0])
    assert acc.events[-1].text.endswith("returned: fixes taken as they come")
    acc.update(5.0, (_pose("bias", (0.3, 0.0), (0.2, 0.01)),))  # σ 0.2 m > 0.5 × 0.3 m
    assert acc.correct(5.0, Measurement(speed=10.0, position=np.array([1.0, 2.0]))).position is None
    acc.update(6.0, (_diag("pose sensor", "pose", "bias", 0.3),))
    assert "position" in acc.excluded


def _pose_at(declared: float, offset: tuple[float, float]) -> Diagnosis:
    return Diagnosis("pose sensor", "pose", "bias", sum(offset) * 0.5**0.5, 0.01, 1.0, declared, 30.0, 20.0, offset,
                     (0.01, 0.01))


def test_a_pose_offset_is_corrected_once_settled_and_not_after_too_many_declarations() -> None:
    """A new offset excludes the fixes for ``pose_settle`` (0.5 s), then corrects them (with an event); the
    fourth displacement declared in a run (``pose_max_declarations`` 3) excludes the pose sensor for good."""
    acc = _accommodation()
    acc.update(1.5, (_pose_at(1.4, (0.3, 0.3)),))
    assert "position" in acc.excluded
    acc.update(1.9, (_pose_at(1.4, (0.3, 0.3)),))
    assert "position" not in acc.excluded and "position" in acc.corrections
    assert acc.events[-1].text.endswith("fixes corrected by (0.3, 0.3) m")
    for k, t in enumerate((3.0, 5.0, 7.0)):
        acc.update(t + 1.0, (_pose_at(t, (0.3 + k, 0.3)),))
    assert "position" in acc.excluded and "position" not in acc.corrections


def test_the_truth_carries_a_pose_offset_along_the_diagonal() -> None:
    """The oracle's pose bias carries its displacement as the offset vector, σ 0; a schedule above the nominal
    radius is declared at size 1 (the record holds tyre sizes in (0, 1])."""
    faults = FaultSettings(left=[[5.0, 2.2]], sensor=[{"sensor": "pose", "kind": "bias", "onset": 3.0, "size": -0.4}])
    at = {d.key: d for d in TruthDiagnoses(faults, 2.0).diagnoses(6.0)}
    assert at["pose sensor", "pose", "bias"].offset == pytest.approx((-0.4 * 0.5**0.5,) * 2)
    assert at["pose sensor", "pose", "bias"].offset_sigma == (0.0, 0.0)
    assert at["tyre", "left", "puncture"].size == 1.0


def test_a_declared_tyre_reaches_the_controller_only_when_asked() -> None:
    """``tyre = "policy"`` (default): the policy's radii pass unchanged where it has handed a radius over, and a
    declared tyre it still holds at the nominal radius (its decision rule has not isolated the wheel) takes the
    declared size; ``"diagnosis"``: the declared size × the nominal radius for the declared wheel, the policy's
    radius for the other."""
    policy = np.array([2.0, 2.0])
    declared = (_diag("tyre", "left", "puncture", 0.7, 10.0),)
    acc = _accommodation()
    assert np.array_equal(acc.radii(policy, 2.0), policy)  # nothing declared yet
    acc.update(10.5, declared)
    assert np.allclose(acc.radii(policy, 2.0), [2.0, 1.4])  # the policy holds nominal: the declared size
    assert np.allclose(acc.radii(np.array([2.0, 1.1]), 2.0), [2.0, 1.1])  # handed over: the policy's
    acc = Accommodation(AccommodationSettings(mode="all", tyre="diagnosis"), _stop())
    assert np.array_equal(acc.radii(policy, 2.0), policy)  # nothing declared yet
    acc.update(10.5, declared)
    assert np.allclose(acc.radii(np.array([1.9, 2.0]), 2.0), [1.9, 1.4])


# ---------------------------------------------------------------- the stop law
def test_the_stop_brakes_along_its_profile_within_the_traction_bound() -> None:
    """From 10 m/s at 3 m/s² (the controller's longitudinal bound caps the setting): the wheels' mean speed
    follows the profile, the planned lateral acceleration stays within 0.8 × lift-off − β a, and at rest the
    command is zero."""
    stop = _stop()
    stop.begin(0.0, 10.0)
    assert stop.deceleration == 3.0 and stop.rest_time() == pytest.approx(10.0 / 3.0)
    bound = 0.8 * 3.92 - 0.75 * 3.0
    u = np.array([5.0, 5.0])
    for k in range(40):
        t = 0.1 * k
        pose = np.array([3.0, -40.0, 0.5])  # far off the circle: the steering saturates
        u = stop.solve(t, pose, np.array([2.0, 2.0]), u).omega
        V, r = (u[0] + u[1]), (2.0 * u[0] - 2.0 * u[1]) / 2.0
        assert V <= stop.speed(t) + 1e-9
        assert abs(V * r) <= bound + 1e-9
    assert np.array_equal(u, [0.0, 0.0])


def test_the_stop_steers_towards_the_path() -> None:
    """On the counter-clockwise 50 m circle at 3 m/s (the traction bound then allows 0.3 rad/s) a robot 1 m left
    of it (inside) turns right of the path's curvature, 1 m right of it turns left of it."""
    stop = _stop()
    path_r = 3.0 / 50.0
    inside = stop.yaw_rate(np.array([0.0, 1.0, 0.0]), 3.0)
    stop.s = None
    outside = stop.yaw_rate(np.array([0.0, -1.0, 0.0]), 3.0)
    assert inside < path_r - 0.01 and outside > path_r + 0.01


def test_with_a_free_wheel_the_other_one_steers() -> None:
    """Left servo unresponsive, the left wheel rolling at 5 rad/s (10 m/s on 2 m): its command is its own rate
    (it can do nothing else); the counter-clockwise circle's ``r = V/50`` would need the right one to run faster
    by ``2 b r``, which would take the robot above the stop's plan (10 m/s at its start), so it runs at the free
    wheel's speed; the right free instead: the left one runs slower by ``2 b r`` (braking, it may)."""
    acc = _accommodation()
    acc.update(10.0, (_diag("servo", "left", "unresponsive", 0.0, 10.0),))
    assert acc.free == 1 and acc.stopping
    pose, radii, rates = np.array([0.0, 0.0, 0.0]), np.array([2.0, 2.0]), np.array([5.0, 5.0])
    om = acc.command(10.0, pose, radii, rates, rates).omega
    assert om[1] == 5.0 and om[0] == pytest.approx(5.0)
    stop = _stop()
    stop.begin(10.0, 10.0)
    om = stop.solve(10.0, pose, radii, rates, free=0, rates=rates).omega
    assert om[0] == 5.0 and 10.0 - 2.0 * om[1] == pytest.approx(2.0 * 1.0 * 10.0 / 50.0)


def test_with_a_free_wheel_a_robot_faster_than_the_plan_is_braked_not_pushed() -> None:
    """Left servo unresponsive on the counter-clockwise circle (the path turns towards the free wheel, which only
    a pushing right wheel could follow): once the robot is faster than the stop's plan, the right wheel brakes
    within the traction bound, ``v_R = v_L − 2 b · 0.8 A / V``, instead of pushing; it never runs backwards, and
    keeps rolling at ``one_wheel_roll`` (0.2) of the free wheel's speed (:mod:`tests.control.test_stop_one_wheel`)."""
    stop = _stop()
    stop.begin(10.0, 10.0)
    pose, radii, rates = np.array([0.0, 0.0, 0.0]), np.array([2.0, 2.0]), np.array([5.0, 5.0])
    om = stop.solve(10.0, pose, radii, rates, free=1, rates=rates).omega  # on the plan: no push above it
    assert om[0] == pytest.approx(5.0)
    om = stop.solve(11.0, pose, radii, rates, free=1, rates=rates).omega  # plan at 7 m/s, robot at 10
    assert 2.0 * om[0] == pytest.approx(10.0 - 2.0 * 0.8 * 3.92 / 10.0)
    slow = np.array([0.2, 0.2])
    om = stop.solve(14.0, pose, radii, slow, free=1, rates=slow).omega
    assert om[0] == pytest.approx(0.2 * 0.2) and om[1] == 0.2


@pytest.mark.parametrize("locked", [1, 0])
def test_with_a_locked_wheel_the_other_brakes_at_its_limit_and_steers(locked: int) -> None:
    """One wheel locked (left, then right), the other turning at 5 rad/s on the counter-clockwise circle: heading
    along the path, it is commanded ``lock_brake`` (0.5 rad/s) below its rate (its servo's full braking torque);
    heading 0.2 rad away from the locked side it drives (the drag's yaw towards the locked side then grows), heading
    0.2 rad towards it, it brakes harder; the locked wheel is commanded 0, and nothing runs backwards."""
    stop = _stop()
    stop.begin(10.0, 10.0)
    w = 1 - locked
    radii, rates = np.array([2.0, 2.0]), np.array([5.0, 5.0])
    rates[locked] = 0.0
    om = stop.solve(10.0, np.array([0.0, 0.0, 0.0]), radii, rates, locked=locked, rates=rates).omega
    assert om[locked] == 0.0 and om[w] == pytest.approx(4.5)
    towards_locked = 0.2 if locked == 1 else -0.2  # heading error (rad) of a robot turned towards the locked side
    away = stop.solve(10.1, np.array([0.0, 0.0, -towards_locked]), radii, rates, locked=locked, rates=rates).omega
    assert away[w] == pytest.approx(5.5)  # 4.5 + 5 · 0.2, clipped to the rate + lock_brake
    more = stop.solve(10.2, np.array([0.0, 0.0, towards_locked]), radii, rates, locked=locked, rates=rates).omega
    assert more[w] == pytest.approx(3.5)
    at_rest = stop.solve(10.3, np.zeros(3), radii, np.zeros(2), locked=locked, rates=np.zeros(2)).omega
    assert np.array_equal(at_rest, [0.0, 0.0])


# ---------------------------------------------------------------- closed loop
def _run(scenario: str, duration: float, all_modes: bool, **extra):
    over = {"duration": duration, "controller.kind": "pf-nmpc", "output.rrd": False, **extra}
    if all_modes:
        over.update({"oracle": True, "reconfiguration.accommodation.mode": "all"})
    return simulate(load_config(scenario, over))


LOCK = {"faults": {"actuator": [{"wheel": "left", "kind": "lock", "onset": 10.0}]}}
"""Scenario 2's faults replaced by a locked left wheel at 10 s."""


def test_a_locked_wheel_is_braked_to_rest_inside_the_corridor(tmp_path) -> None:
    """Scenario 2's circle, left wheel locked at 10 s (dev seed 0): the safe stop is entered at the lock's
    declaration (the truth's, at 10 s), the robot is at rest (< 0.1 m/s) by 15 s, never more than 2 m from
    the path, not tipped; the mode is in the Rerun recording; without the accommodation it leaves the corridor."""
    res = _run("scenario2", 17.0, True, **LOCK)
    tr = res.trace
    t, v, e = tr["t"], tr["v"], tr["cross_track_error"]
    stops = [ev for ev in res.events if ev.text.startswith("safe stop: ")]
    assert stops and stops[0].t == pytest.approx(10.0) and "left servo lock" in stops[0].text
    assert np.all(np.abs(v[t >= 15.0]) < 0.1)
    print(f"\n[accom] lock: max |e| {np.abs(e).max():.2f} m, speed at 15 s {v[t >= 15.0][0]:.3f} m/s")
    assert np.abs(e).max() <= 2.0
    assert np.all(np.abs(tr["roll"]) < 0.5) and np.all(np.abs(tr["pitch"]) < 0.5)
    assert np.all(tr["accommodation_mode"][t >= 15.0] == AccommodationMode.AT_REST)
    write_rrd(tmp_path / "run.rrd", tr, run_id="lock", events=res.events)
    t_rec, mode = read_scalar_series(tmp_path / "run.rrd", "/accommodation/mode")
    assert mode[t_rec < 9.95].max() == 0.0 and mode[(t_rec >= 10.0) & (t_rec < 11.0)].min() == 2.0
    plain = _run("scenario2", 17.0, False, **LOCK).trace
    assert np.abs(plain["cross_track_error"]).max() > 2.0


def test_a_weakened_servo_is_tracked_with_its_actuator_model() -> None:
    """The shipped ``servo_loss30`` (left servo at 30 % from 10 s), dev seed 0: an event says the controller's
    actuator model changed, the robot stays within 0.5 m from 15 s on and, its compliance now modelled, runs
    nearer the desired 10 m/s than the unaccommodated loop, which overestimates its weak wheel's rate."""
    acc = _run("servo_loss30", 20.0, True)
    plain = _run("servo_loss30", 20.0, False)
    assert any("actuator model changed" in ev.text for ev in acc.events)
    t = acc.trace["t"]
    late = t >= 15.0
    assert np.abs(acc.trace["cross_track_error"][late]).max() <= 0.5
    err_acc = np.abs(acc.trace["v"][late] - 10.0).mean()
    err_plain = np.abs(plain.trace["v"][late] - 10.0).mean()
    print(f"\n[accom] servo 30 %: |V − 10| accommodated {err_acc:.3f} m/s, plain {err_plain:.3f} m/s")
    assert err_acc < err_plain


def test_a_declared_tyre_counts_as_isolated_for_the_policy() -> None:
    """Where the decision has isolated one wheel and the diagnoser has declared the other's tyre too, the policy reads
    both as isolated (it would otherwise condition the first on the second being nominal); a decision that isolates
    nothing, has declared nothing, or already covers the declared tyres is handed over as it is."""
    acc = _accommodation()
    left = DecisionState(detected=True, time=8.0, wheel="left", severity_R=0.0, severity_L=0.44)
    assert acc.isolation(left) is left and acc.isolation(None) is None  # nothing declared
    acc.update(8.5, [_diag("tyre", "left", "puncture", 0.56, 7.0)])
    assert acc.isolation(left) is left  # the same wheel
    acc.update(12.3, [_diag("tyre", "left", "puncture", 0.56, 7.0),
                      _diag("tyre", "right", "puncture", 0.9, 11.8)])
    assert acc.isolation(left).wheel == "both" and left.wheel == "left"
    for ds in (replace(left, wheel="unknown"), replace(left, detected=False), replace(left, wheel="both")):
        assert acc.isolation(ds) is ds
