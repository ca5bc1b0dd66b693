"""The diagnoser's fast tyre detector (:mod:`ftc_mj.estimation.diagnosis.change`) on noise-free readings of the
kinematic model: silent while nothing changes, over its threshold at once after a 10 % drop of the right radius
(the gyro sees 0.5 rad/s against σ 0.01 rad/s), silent again once anchored on the new radii."""

from __future__ import annotations

import numpy as np

from ftc_mj.config import RunConfig
from ftc_mj.estimation import Measurement
from ftc_mj.estimation.diagnosis import DiagnosisInput
from ftc_mj.estimation.diagnosis.change import TyreChangeAlarm
from ftc_mj.wiring.decision import build_change_detectors, calibrated_threshold

N, K_DROP, K_ANCHOR = 400, 200, 260


def test_silent_before_a_drop_over_the_threshold_after_it_and_silent_once_anchored() -> None:
    cfg = RunConfig.model_validate({"sensors": {"yaw_rate_sigma": 0.01}})
    alarm = TyreChangeAlarm(build_change_detectors(cfg), calibrated_threshold(cfg, "cusum"))
    b, R0, dt = cfg.model_half_track, cfg.robot.wheel_radius, 1.0 / cfg.estimator.rate
    u = np.array([5.0, 5.0])
    stats = []
    for k in range(N):
        radii = np.array([0.9 * R0 if k >= K_DROP else R0, R0])
        speed = 0.5 * float(radii @ u)
        yaw = (radii[0] * u[0] - radii[1] * u[1]) / (2.0 * b)
        z = DiagnosisInput(t=k * dt, omega=u, command=u, speed=speed, yaw_rate=yaw, pose=None, pose_sigma=0.0,
                           radii=radii, filter_input=(u, Measurement(speed=speed, yaw_rate=yaw)))
        if k == K_ANCHOR:
            alarm.anchor(radii)
        stats.append(alarm.step(z)[0])
    h = alarm.threshold
    s = np.asarray(stats)
    assert np.all(s[:K_DROP] < h)
    assert s[K_DROP + 1] >= h  # the first step after the drop (the detectors see each step a step late)
    assert np.all(s[K_ANCHOR + 1:] < h)


def test_the_cusum_is_the_same_without_the_glr() -> None:
    """The diagnoser builds its detectors without the GLR (most of their cost): the CUSUM does not read the GLR,
    so its statistic is bitwise the same at every step, through a drop and a restart, and the GLR's stays 0."""
    cfg = RunConfig.model_validate({"sensors": {"yaw_rate_sigma": 0.01}})
    full, cusum_only = build_change_detectors(cfg), build_change_detectors(cfg, glr=False)
    rng = np.random.default_rng(3)
    R0, b, u = cfg.robot.wheel_radius, cfg.model_half_track, np.array([5.0, 4.0])
    for k in range(300):
        radii = np.array([0.8 * R0 if k >= 150 else R0, R0])
        z = Measurement(speed=0.5 * float(radii @ u) + 0.05 * rng.standard_normal(),
                        yaw_rate=(radii[0] * u[0] - radii[1] * u[1]) / (2.0 * b) + 0.01 * rng.standard_normal())
        for det in (full, cusum_only):
            det.step(k * 0.01, u, z, radii)
            if k == 200:
                det.restart()
        assert cusum_only.cusum_stat == full.cusum_stat and cusum_only.glr_stat == 0.0
    assert full.glr_stat > 0.0  # the GLR ran on the other


def test_the_diagnosers_threshold_adds_the_drawn_conditions_offset() -> None:
    """The fast detector's threshold is the estimator's calibrated CUSUM threshold plus the offset shipped for the
    run's sensor set (``benchmarks/tyre_change_calibration.py``), whose mean time to a false alarm was measured over
    at least 1000 s of healthy development draws per sensor set."""
    from ftc_mj.estimation.calibration import TYRE_CHANGE_FILE, package_data, tyre_change_offset
    from ftc_mj.wiring.diagnosis import tyre_change_alarm

    data = package_data(TYRE_CHANGE_FILE)
    for gyro, key in ((None, "speed"), (0.01, "speed+yaw")):
        cfg = RunConfig.model_validate({"sensors": {"yaw_rate_sigma": gyro}, "diagnosis": {"tyre_change": True}})
        alarm = tyre_change_alarm(cfg)
        assert alarm is not None and alarm.detectors.glr is None
        assert tyre_change_offset(gyro is not None) == data["offsets"][key]
        assert alarm.threshold == calibrated_threshold(cfg, "cusum") + data["offsets"][key]
        assert data["after_launch"][key]["exposure"] >= 1000.0
