"""The pose fix in the filters: its heading fused (the innovation wrapped), its χ² gate (a jump rejected, a lasting
offset re-acquired after the streak's limit), and what a run records of it.

The data: the kinematic model (half track 1 m, radii 2 m) on a circle at 5.5 m/s and 0.5 rad/s for 30 s (the
heading turns 15 rad), a speed sensor (σ 0.5 m/s), a gyro (σ 0.005 rad/s) biased by 0.05 rad/s — a gyro-bias
fault — and pose fixes at 10 Hz (σ 0.03 m and 0.03 rad) whose heading is an angle in [-π, π).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from scipy.stats import chi2

from ftc_mj.estimation import EKF, IMM, UKF, Measurement
from ftc_mj.estimation.setup import gate_quantile
from ftc_mj.model.kinematics import KinematicModel

SENSORS = {"yaw_rate_sigma": 0.005, "position_sigma": 0.03, "heading_sigma": 0.03, "position_rate": 10.0}
JUMP = np.array([math.sqrt(2.0), math.sqrt(2.0)])
"""A 2 m displacement of the fix along the diagonal (m)."""
Offset = Callable[[int], np.ndarray | float]


def wrap(a: np.ndarray | float) -> np.ndarray | float:
    """An angle (rad) in [-π, π)."""
    return (np.asarray(a) + math.pi) % (2.0 * math.pi) - math.pi


def make(kind: str, **estimator: object) -> EKF | UKF | IMM:
    """The filter ``kind`` with the pose sensor of :data:`SENSORS` and the model's geometry."""
    geometry = {"wheel_radius": 2.0, "half_track": 1.0}
    if kind.startswith("imm"):
        return IMM.from_settings(kind.removeprefix("imm-"), estimator, SENSORS, **geometry)
    return {"ekf": EKF, "ukf": UKF}[kind].from_settings(estimator, SENSORS, **geometry)


def track(f: EKF | UKF | IMM, heading: bool = True, offset: Offset | None = None, n: int = 3000
          ) -> tuple[np.ndarray, np.ndarray]:
    """Step ``f`` through the data (module docstring), the fixes displaced by ``offset(k)`` (m); its heading
    error (rad, wrapped) and position error (m) at every step."""
    m = KinematicModel(b=1.0, dt=0.01)
    rng = np.random.default_rng(1)
    x = np.array([0.0, 0.0, 0.0, 2.0, 2.0])
    u = np.array([3.0, 2.5])
    psi_err, pos_err = np.empty(n), np.empty(n)
    for k in range(n):
        x = m.step(x, u)
        e = rng.standard_normal(5)
        pos = psi = None
        if k % 10 == 0:
            pos = x[:2] + 0.03 * e[2:4] + (offset(k) if offset else 0.0)
            psi = float(wrap(x[2] + 0.03 * e[4])) if heading else None
        z = Measurement(float(m.speed(x, u)) + 0.5 * e[0], float(m.yaw_rate(x, u)) + 0.05 + 0.005 * e[1], pos, psi)
        out = f.step(u, z)
        psi_err[k] = wrap(out.x[2] - x[2])
        pos_err[k] = math.hypot(out.x[0] - x[0], out.x[1] - x[1])
    return psi_err, pos_err


def test_the_gate_quantile_is_a_chi2s() -> None:
    """The gate of a false-rejection probability p is the upper-p χ² quantile of 2 dof (the fix's x, y)."""
    q = gate_quantile(1e-4)
    assert chi2.sf(q, 2) == pytest.approx(1e-4)
    assert q == pytest.approx(-2.0 * math.log(1e-4))  # the 2-dof χ² is exponential
    assert gate_quantile(None) == math.inf


@pytest.mark.parametrize("kind", ["ekf", "ukf", "imm-ukf"])
def test_the_fix_heading_holds_the_heading_against_a_gyro_bias(kind: str) -> None:
    """With a 0.05 rad/s gyro bias the heading from the gyro drifts; the fixes' x, y alone hold it to ~0.45 rad
    (RMS over the last 10 s), their heading fused too to within 0.1 rad — given as an angle in [-π, π) while the
    filter's heading counts 15 rad of turning: the innovation is wrapped (unwrapped, every heading would be
    2π-multiples off and gated or worse), so no fix's heading is rejected for it."""
    without, _ = track(make(kind), heading=False)
    f = make(kind)
    with_heading, pos_err = track(f)
    rms = [float(np.sqrt(np.mean(np.square(e[-1000:])))) for e in (without, with_heading)]
    assert rms[0] > 0.3 and rms[1] < 0.1, rms
    assert pos_err[-1000:].max() < 0.2
    assert f.pose_rejections <= 10  # of 300 fixes


@pytest.mark.parametrize("kind", ["ekf", "ukf", "imm-ekf"])
def test_a_pose_jump_is_rejected_and_counted(kind: str) -> None:
    """A 2 m jump of the fixes for 1 s (10 fixes): ungated (``pose_gate = None``) the filter's position follows
    it; gated, the 10 fixes are rejected, counted, and the position stays within 0.3 m of the truth."""
    def jump(k: int) -> np.ndarray | float:
        return JUMP if 1000 <= k < 1100 else 0.0

    _, ungated = track(make(kind, pose_gate=None), offset=jump)
    f = make(kind)
    _, gated = track(f, offset=jump)
    assert ungated[1000:1100].max() > 1.5
    assert gated[1000:1200].max() < 0.3
    assert f.pose_rejections >= 10


@pytest.mark.parametrize("kind", ["ekf", "imm-ukf"])
def test_a_lasting_pose_offset_is_reacquired_after_the_streak(kind: str) -> None:
    """A 2 m offset of the fixes from 10 s on (a pose bias): rejected for ``pose_gate_reacquire`` (2 s: 20 fixes
    at 10 Hz), then fused: the filter follows the fixes (its position ~2 m off the truth at the end, as the fixes
    are) — the gate cannot lock the filter out of its pose sensor for ever. With 0.5 s the re-acquisition comes
    after 5 fixes."""
    def bias(k: int) -> np.ndarray | float:
        return JUMP if k >= 1000 else 0.0

    for streak, back in ((20, 1200), (5, 1050)):
        f = make(kind, pose_gate_reacquire=streak / 10.0)
        psi_err, err = track(f, offset=bias)
        assert err[1000:back - 10].max() < 0.3, streak  # rejected while the streak lasts
        assert abs(err[-500:].mean() - 2.0) < 0.15, streak  # then following the fixes
        assert streak <= f.pose_rejections <= streak + 10
        assert np.abs(psi_err[back:]).max() < 0.1  # the re-acquisition moves the position, the heading holds


def test_a_run_records_the_rejected_fixes() -> None:
    """A run with a pose sensor (10 Hz, σ 0.02 m) and a 2 m pose jump from 1 s to 2 s: the trace's
    ``pose_rejected`` is 1 on the jump's rows with a fix, 0 on the other fix rows and NaN between fixes; the
    count is ``filter_pose_rejections`` in the metrics; the filter's position — the controller's, with
    ``pose_source = "sensor"`` — stays within 0.3 m of the truth. A run without the pose sensor has neither."""
    import ftc_mj

    jump = {"sensor": "pose", "kind": "jump", "onset": 1.0, "size": 2.0, "duration": 1.0}
    base = {"duration": 3.0, "plant.kind": "kinematic", "controller.kind": "open-loop",
            "reconfiguration.policy": "none"}
    run = ftc_mj.run(ftc_mj.load_config("scenario1", {**base, "sensors.position_sigma": 0.02,
                                                      "sensors.position_rate": 10.0, "sensors.pose_source": "sensor",
                                                      "faults.sensor": [jump]}), rrd=False)
    tr = {c: run.trace[c].to_numpy() for c in ("t", "pose_rejected", "x_meas", "x", "y", "x_hat", "y_hat")}
    fix = np.isfinite(tr["x_meas"])
    np.testing.assert_array_equal(np.isfinite(tr["pose_rejected"]), fix)
    in_jump = (tr["t"] >= 1.0 - 1e-9) & (tr["t"] < 2.0 - 1e-9)
    np.testing.assert_array_equal(tr["pose_rejected"][fix], in_jump[fix].astype(float))
    assert run.metrics["filter_pose_rejections"] == int(np.nansum(tr["pose_rejected"])) == 10
    assert np.hypot(tr["x_hat"] - tr["x"], tr["y_hat"] - tr["y"])[in_jump].max() < 0.3
    plain = ftc_mj.run(ftc_mj.load_config("scenario1", base), rrd=False)
    assert "pose_rejected" not in plain.trace.columns and "filter_pose_rejections" not in plain.metrics
