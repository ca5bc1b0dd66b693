"""Seeded sensors: noise levels, presence, position-fix rate, determinism."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.config import RunConfig, SensorSettings
from ftc_mj.plant import SensorReading, Sensors, Truth
from tests.plant.helpers import mujoco_plant


def truth_at(t: float, **kw: float) -> Truth:
    base = dict(
        t=t, x=1.0, y=2.0, psi=0.5, v=3.0, yaw_rate=0.2, omega_R=1.5, omega_L=1.4, R_R=2.0, R_L=2.0,
        roll=0.0, pitch=0.0, z_chassis=2.0, slip_R=0.0, slip_L=0.0, contact_R=True, contact_L=True, flags=0,
    )
    base.update(kw)
    return Truth(**base)  # type: ignore[arg-type]


def test_defaults_speed_only() -> None:
    s = Sensors(SensorSettings(), seed=1)
    z = s.read(truth_at(0.0))
    assert isinstance(z, SensorReading)
    assert z.yaw_rate is None and z.position is None
    assert z.omega_R == 1.5 and z.omega_L == 1.4  # encoder_sigma = 0
    np.testing.assert_array_equal(z.pose, [1.0, 2.0, 0.5])  # pose_sigma = 0: the true pose


def test_noise_statistics() -> None:
    cfg = SensorSettings(speed_sigma=0.5, yaw_rate_sigma=0.01, encoder_sigma=0.05, pose_sigma=0.1)
    s = Sensors(cfg, seed=3)
    zs = [s.read(truth_at(0.01 * k)) for k in range(20000)]
    sp = np.array([z.speed for z in zs]) - 3.0
    yr = np.array([z.yaw_rate for z in zs]) - 0.2
    wr = np.array([z.omega_R for z in zs]) - 1.5
    ps = np.array([z.pose[2] for z in zs]) - 0.5
    assert abs(sp.mean()) < 0.02 and sp.std() == pytest.approx(0.5, rel=0.03)
    assert yr.std() == pytest.approx(0.01, rel=0.03)
    assert wr.std() == pytest.approx(0.05, rel=0.03)
    assert ps.std() == pytest.approx(0.1, rel=0.03)
    assert abs(np.corrcoef(sp, yr)[0, 1]) < 0.03


def test_position_fix_rate() -> None:
    s = Sensors(SensorSettings(position_sigma=0.2, position_rate=2.0), seed=0)
    fixes = [k for k in range(300) if s.read(truth_at(0.01 * k)).position is not None]
    assert fixes == list(range(0, 300, 50))  # t = 0, 0.5, 1.0, ... at a 100 Hz read rate
    z = Sensors(SensorSettings(position_sigma=0.2), seed=0).read(truth_at(0.0))
    assert z.position is not None and z.position.shape == (2,)


def test_same_seed_same_readings_and_independent_streams() -> None:
    def seq(cfg: SensorSettings, seed: int) -> list[float]:
        s = Sensors(cfg, seed)
        return [s.read(truth_at(0.01 * k)).speed for k in range(100)]

    a = seq(SensorSettings(), 7)
    assert a == seq(SensorSettings(), 7)
    assert a != seq(SensorSettings(), 8)
    # switching on a gyro does not change the speed noise sequence
    assert a == seq(SensorSettings(yaw_rate_sigma=0.01), 7)
    s = Sensors(SensorSettings(), 7)
    first = s.read(truth_at(0.0)).speed
    s.reset()
    assert s.read(truth_at(0.0)).speed == first


def test_plant_and_sensors_deterministic_together() -> None:
    def run() -> list[tuple]:
        cfg = RunConfig(seed=5)
        cfg.sensors.yaw_rate_sigma = 0.01
        cfg.faults.right = [(0.2, 2.0), (0.2, 1.2)]
        plant = mujoco_plant(cfg)
        sensors = Sensors(cfg.sensors, cfg.seed)
        plant.set_command(2.0, 1.5)
        out = []
        for _ in range(60):
            plant.advance(10)
            tr = plant.truth()
            z = sensors.read(tr)
            out.append((tr.x, tr.y, tr.psi, tr.v, z.speed, z.yaw_rate, z.omega_R))
        return out

    assert run() == run()


def test_the_loop_hands_the_controller_the_sensors_pose(monkeypatch) -> None:
    """The pose the controller receives is the :class:`Sensors` reading checked above (noise included),
    not a second noise source of the loop's own."""
    from ftc_mj.config import load_config
    from ftc_mj.sim.loop import simulate

    readings, poses = _record_readings_and_poses(monkeypatch)
    cfg = load_config("scenario1", {"duration": 1.0, "controller.kind": "open-loop", "sensors.pose_sigma": 0.1,
                                    "plant.kind": "kinematic", "estimator.kind": "none"})
    res = simulate(cfg)
    assert len(poses) == 10 and len(readings) == 100  # 10 Hz controller, 100 Hz sensors
    for j, pose in enumerate(poses):
        np.testing.assert_array_equal(pose, readings[10 * j].pose)
    truth = np.stack([res.trace[c][::10] for c in ("x", "y", "psi")], axis=1)
    assert np.all(np.abs(np.array(poses) - truth) > 0)  # noise on every coordinate


def _pose_faulty(*faults: dict) -> Sensors:
    from ftc_mj.plant.faults import FaultSettings

    cfg = SensorSettings(position_sigma=0.05, position_rate=10.0, pose_source="sensor")
    return Sensors(cfg, seed=7, faults=FaultSettings(sensor=list(faults)))


def test_the_pose_fix_and_its_faults() -> None:
    """The pose sensor's fix is the filter's position fix plus a heading (σ: position σ per metre unless set); a
    jump displaces it by its size along the 45° diagonal for its duration and no longer, a dropout delivers no fix;
    the faults draw nothing (the other readings and the fixes outside the faults are the healthy run's)."""
    healthy, faulty = _pose_faulty(), _pose_faulty({"sensor": "pose", "kind": "jump", "onset": 1.0, "size": 2.0,
                                                    "duration": 0.5},
                                                   {"sensor": "pose", "kind": "dropout", "onset": 2.0, "duration": 0.3})
    for k in range(300):
        t = 0.01 * k
        a, b = healthy.read(truth_at(t)), faulty.read(truth_at(t))
        assert a.speed == b.speed and a.omega_R == b.omega_R
        if a.pose_fix is None:
            assert b.pose_fix is None and a.position is None
            continue
        np.testing.assert_array_equal(a.pose_fix[:2], a.position)
        if 1.0 <= t < 1.5:
            np.testing.assert_allclose(b.pose_fix - a.pose_fix, [2.0 / np.sqrt(2), 2.0 / np.sqrt(2), 0.0], atol=1e-12)
        elif 2.0 <= t < 2.3 - 1e-9:
            assert b.pose_fix is None and b.position is None
        else:
            np.testing.assert_array_equal(a.pose_fix, b.pose_fix)
            np.testing.assert_array_equal(a.position, b.position)
    fresh = _pose_faulty()
    heading = np.array([fresh.read(truth_at(0.1 * k)).pose_fix[2] for k in range(4000)]) - 0.5
    assert heading.std() == pytest.approx(0.05, rel=0.05)


def test_pose_settings_need_the_pose_sensor() -> None:
    """A pose from the sensor or a pose fault without the pose sensor, or a mode the pose sensor has not: one line
    naming the field."""
    from ftc_mj.config import load_config
    from ftc_mj.errors import BadInput

    with pytest.raises(BadInput, match=r"^sensors.*pose_source: 'sensor' needs the pose sensor"):
        load_config("scenario2", {"sensors.pose_source": "sensor"})
    with pytest.raises(BadInput, match=r"^faults.sensor\[0\].sensor: 'pose' needs the pose sensor"):
        load_config("scenario2", {"faults.sensor": [{"sensor": "pose", "kind": "bias", "onset": 1.0, "size": 0.3}]})
    with pytest.raises(BadInput, match=r"kind: 'drift' is not a fault of the pose sensor"):
        load_config("scenario2", {"sensors.position_sigma": 0.05,
                                  "faults.sensor": [{"sensor": "pose", "kind": "drift", "onset": 1.0, "size": 0.3}]})


@pytest.mark.parametrize("estimator", ["none", "ukf"])
def test_with_the_sensor_pose_source_the_controller_gets_the_filters_pose_or_the_last_fix(monkeypatch,
                                                                                         estimator: str) -> None:
    """``pose_source = "sensor"``: the controller's pose is the filter's pose estimate at the sample (it has taken
    in the fixes); without a filter the last fix, held between fixes (2 Hz fixes, 10 Hz controller)."""
    from ftc_mj.config import load_config
    from ftc_mj.sim.loop import simulate

    readings, poses = _record_readings_and_poses(monkeypatch)
    cfg = load_config("scenario1", {"duration": 2.0, "controller.kind": "open-loop", "sensors.position_sigma": 0.2,
                                    "sensors.position_rate": 2.0, "sensors.pose_source": "sensor",
                                    "plant.kind": "kinematic", "estimator.kind": estimator,
                                    "reconfiguration.policy": "none"})
    res = simulate(cfg)
    assert len(poses) == 20
    if estimator == "none":
        for j, pose in enumerate(poses):
            np.testing.assert_array_equal(pose, readings[50 * (j // 5)].pose_fix)
    else:
        est = np.stack([res.trace[c][::10] for c in ("x_hat", "y_hat", "psi_hat")], axis=1)
        np.testing.assert_array_equal(np.array(poses), est)


def _record_readings_and_poses(monkeypatch: pytest.MonkeyPatch) -> tuple[list[SensorReading], list[np.ndarray]]:
    """Lists that fill with every :class:`Sensors` reading and every pose the open-loop controller is handed."""
    from ftc_mj.control.open_loop import OpenLoopController

    readings: list[SensorReading] = []
    poses: list[np.ndarray] = []
    read = Sensors.read
    monkeypatch.setattr(Sensors, "read", lambda self, *a: readings.append(read(self, *a)) or readings[-1])
    solve = OpenLoopController.solve
    monkeypatch.setattr(OpenLoopController, "solve",
                        lambda self, t, pose, *a: poses.append(np.array(pose)) or solve(self, t, pose, *a))
    return readings, poses
