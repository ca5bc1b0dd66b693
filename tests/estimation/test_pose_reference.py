"""The batched step search of the pose GLR (:func:`ftc_mj.estimation.diagnosis.pose.step_statistics`) against
its loop reference (tests/support/reference_pose.py), on the windows a diagnoser meets in synthetic runs with a
displaced pose sensor, a puncture and a healthy robot: the same statistics, displacements and covariances to
round-off where the candidate's normal matrix is well conditioned (cond < 1e8: the two differ only in the
order of the sums of the 2n-row products, n ≤ 40 fixes, so 1e-16 × cond ≤ 1e-8 of the window's largest value;
tolerance 1e-7), a statistic of ~0 in both where it is not (a step at the window's last fix is confounded with
the kink there), and the same most likely fix."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.context import RunContext
from ftc_mj.estimation.diagnosis import ResidualDiagnoser, ResidualDiagnoserSettings
from ftc_mj.estimation.diagnosis import pose as pose_module
from ftc_mj.model.sensors import SensorSettings
from tests.estimation.test_history_reference import DT, R0, B, inputs
from tests.support.reference_pose import reference_step_statistics


@pytest.mark.parametrize("fault", [{}, {"kind": "puncture", "t": 6.0, "fix_every": 10},
                                   {"kind": "speed", "t": 6.0, "fix_every": 10}])
def test_the_batched_step_search_equals_its_reference(fault: dict, monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[tuple] = []
    batched = pose_module.step_statistics

    def both(D, cand, Q, y_perp):  # noqa: ANN001, ANN202 - the function's own signature
        out = batched(D, cand, Q, y_perp)
        calls.append((out, reference_step_statistics(D, cand, Q, y_perp)))
        return out

    monkeypatch.setattr(pose_module, "step_statistics", both)
    context = RunContext(seed=0, duration=12.0, physics_dt=1e-3, estimator_dt=DT, controller_dt=0.1,
                         nominal_radii=(R0, R0), half_track=B, omega_max=20.0, initial_pose=(0.0, 0.0, 0.0),
                         sensors=SensorSettings(speed_sigma=0.3, yaw_rate_sigma=0.01))
    diag = ResidualDiagnoser(ResidualDiagnoserSettings(), context)
    for z in inputs(fault, 12.0, None, 0.05):
        diag.step(z)
    assert len(calls) > 20  # the windows of a run at 10 Hz fixes
    well = 0
    for (stat, d, cov), (rstat, rd, rcov, cond) in calls:
        ok = cond < 1e8  # round-off of the two orders of summation, amplified by cond(G), stays below 1e-7
        well += int(ok.sum())
        scale = float(np.max(np.abs(rstat[ok])))
        np.testing.assert_allclose(stat[ok], rstat[ok], rtol=0, atol=1e-7 * scale)
        np.testing.assert_allclose(d[ok], rd[ok], rtol=1e-7, atol=1e-7 * float(np.max(np.abs(rd[ok]))))
        np.testing.assert_allclose(cov[ok], rcov[ok], rtol=1e-7, atol=1e-7 * float(np.max(np.abs(rcov[ok]))))
        # a confounded candidate explains nothing beyond its kink, in both: never the most likely step
        assert np.all(np.abs(stat[~ok]) < 1e-3 * scale) and np.all(np.abs(rstat[~ok]) < 1e-3 * scale)
        assert int(np.argmax(stat)) == int(np.argmax(rstat))
    assert well > 10 * len(calls)
