"""The diagnoser's fast path equals its reference bitwise: the same synthetic runs stepped through a
:class:`~ftc_mj.estimation.diagnosis.ResidualDiagnoser` as shipped and through one with the reference
history (tests/support/reference_history.py: one call per sum, no per-step batching), without the per-fix
memo of the GLR windows and without the quiet-step shortcut of the isolation give the same statistics,
alarms and declarations at every step and the same sums."""

from __future__ import annotations

import math
from dataclasses import astuple

import numpy as np
import pytest

from ftc_mj.context import RunContext
from ftc_mj.estimation.diagnosis import DiagnosisInput, ResidualDiagnoser, ResidualDiagnoserSettings
from ftc_mj.estimation.diagnosis.servo import LagSums
from ftc_mj.model.sensors import SensorSettings
from tests.support.reference_history import ReferenceHistory

DT, R0, B = 0.01, 2.0, 1.0


def inputs(fault: dict, duration: float, gyro: float | None, pose_sigma: float, seed: int = 5
           ) -> list[DiagnosisInput]:
    """A unicycle on a 50 m circle at 10 m/s with first-order wheel servos, a 10 Hz dithered command, Gaussian
    sensors and a pose fix every ``fix_every`` steps; ``fault``: ``{"kind": ..., "t": onset, ...}`` (kinds:
    puncture, loss, lock, speed bias, gyro bias, dropouts of both readings)."""
    rng = np.random.default_rng(seed)
    x = y = psi = 0.0
    radii, alpha = np.array([R0, R0]), np.array([0.1, 0.1])
    omega = np.array([5.1, 4.9])
    cmd, out = None, []
    for k in range(int(duration / DT)):
        t = k * DT
        on, kind = t >= fault.get("t", math.inf), fault.get("kind")
        if on and kind == "puncture":
            radii[0] = R0 * 0.85
        if on and kind == "loss":
            alpha[1] = 0.03
        if k % 10 == 5:  # the first command arrives after the first steps (command None before)
            cmd = np.array([(10.0 + B * 0.2) / radii[0], (10.0 - B * 0.2) / radii[1]]) + 0.2 * rng.standard_normal(2)
        if cmd is not None:
            omega = omega + alpha * (cmd - omega) - np.array([0.003, -0.003])
        if on and kind == "lock":
            omega[0] = 0.0
        v = 0.5 * (radii[0] * omega[0] + radii[1] * omega[1])
        w = (radii[0] * omega[0] - radii[1] * omega[1]) / (2 * B)
        x, y, psi = x + v * math.cos(psi) * DT, y + v * math.sin(psi) * DT, psi + w * DT
        speed = v + 0.3 * rng.standard_normal() + (0.8 if on and kind == "speed" else 0.0)
        yaw = None if gyro is None else w + gyro * rng.standard_normal() + (0.05 if on and kind == "gyro" else 0.0)
        if on and kind == "dropout" and t < fault["t"] + 1.0:
            speed = yaw = None
        pose = np.array([x, y, psi]) + pose_sigma * rng.standard_normal(3) if k % fault.get("fix_every", 1) == 0 \
            else None
        out.append(DiagnosisInput(t=t, omega=omega.copy(), command=None if cmd is None else cmd.copy(), speed=speed,
                                  yaw_rate=yaw, pose=pose, pose_sigma=pose_sigma))
    return out


def same(a: object, b: object) -> bool:
    """Bitwise-equal floats (NaN equal to NaN), or equal objects."""
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    return a == b


@pytest.mark.parametrize("fault", [{}, {"kind": "puncture", "t": 9.0}, {"kind": "loss", "t": 9.0},
                                   {"kind": "lock", "t": 9.0}, {"kind": "speed", "t": 8.0},
                                   {"kind": "gyro", "t": 8.0}, {"kind": "dropout", "t": 6.0},
                                   {"kind": "puncture", "t": 9.0, "fix_every": 10}])
def test_the_fast_history_equals_the_reference(fault: dict) -> None:
    context = RunContext(seed=0, duration=20.0, physics_dt=1e-3, estimator_dt=DT, controller_dt=0.1,
                         nominal_radii=(R0, R0), half_track=B, omega_max=20.0, initial_pose=(0.0, 0.0, 0.0),
                         sensors=SensorSettings(speed_sigma=0.3, yaw_rate_sigma=0.01))
    settings = ResidualDiagnoserSettings()
    fast, ref = ResidualDiagnoser(settings, context), ResidualDiagnoser(settings, context)
    ref.history = ReferenceHistory(ref.dt)
    ref.lags = LagSums(ref.history)  # the load test's extra sums beside the reference history
    ref._pairs = ref._window_pairs  # no memo
    ref._quiet = lambda alarms: False  # every step isolates
    for z in inputs(fault, 20.0, 0.01, 0.02):
        a, b = fast.step(z), ref.step(z)
        assert a.alarms == b.alarms, z.t
        assert all(same(a.statistics[c], b.statistics[c]) for c in b.statistics), z.t
        for mine, theirs in ((a.new, b.new), (a.declared, b.declared)):
            assert len(mine) == len(theirs), z.t
            assert all(same(u, v) for d, e in zip(mine, theirs, strict=True)
                       for u, v in zip(astuple(d), astuple(e), strict=True)), z.t
    assert fast.history.k == ref.history.k
    for name, seq in ref.history.sums.items():
        assert fast.history.sums[name] == seq, name
    assert fault.get("kind") in (None, "dropout") or fast.declared  # the run exercised a declaration
