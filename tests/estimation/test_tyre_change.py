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
