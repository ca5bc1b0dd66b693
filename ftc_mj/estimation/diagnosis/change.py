"""The diagnoser's fast tyre detector: the estimator's calibrated CUSUM on the diagnoser's own readings.

The tyre channels of :mod:`.residual` compare the arc rolled between pose fixes with the wheel's turn: they
read the pose at 5–10 Hz and need windows of fixes, so with a gyro they alarm about ten times Lorden's bound
after a step puncture, whose information the gyro delivers within a few hundredths of a second (docs/fdi.md,
"Split by sensor set"). :class:`TyreChangeAlarm` is the detection that information allows: the CUSUM of
:class:`~ftc_mj.estimation.residual.ChangeDetectors` — a filter matched to "no radius changed" stepped on the
speed, the gyro and the pose fixes at the estimator's rate, its innovations whitened under the method's null model
(the physical robot's slip where the method declares it) — at the threshold calibrated for the run's sensor set
on the MuJoCo robot (:func:`~ftc_mj.wiring.decision.calibrated_threshold`). It detects; it does not isolate or
size (the rolling-ratio channels do that): its alarm is the ``tyre_change`` channel, which no declaration reads.
After each declaration (a tyre's, or a sensor's whose offset the filter's readings have had removed since)
its radii restart from the filter's estimate with the prior's uncertainty, so that a second fault is detected
as the first.
"""

from __future__ import annotations

import math

import numpy as np

from ..residual import ChangeDetectors
from .base import DiagnosisInput


class TyreChangeAlarm:
    """The CUSUM of ``detectors`` at ``threshold`` (log-likelihood-ratio units) on each step's readings.

    Args:
        detectors: the run's residual generator with its CUSUM (a fresh one: it is stepped here; the GLR, if it
            has one, is not read).
        threshold: the CUSUM's calibrated threshold for the run's sensors.
    """

    def __init__(self, detectors: ChangeDetectors, threshold: float) -> None:
        self.detectors = detectors
        self.threshold = float(threshold)

    def step(self, z: DiagnosisInput) -> tuple[float, float]:
        """Advance on what the filter stepped on (``z.filter_input``: the wheel rates it predicted with and its
        measurement, the diagnosed sensor offsets removed — the inputs the detectors were calibrated on) and
        return the CUSUM statistic and the threshold; ``(0, threshold)`` at a step without a filter."""
        if z.filter_input is None:
            return 0.0, self.threshold
        u, m = z.filter_input
        self.detectors.step(z.t, np.asarray(u, float), m, None if z.radii is None else np.asarray(z.radii, float))
        stat = self.detectors.cusum_stat
        return (stat if math.isfinite(stat) else 0.0), self.threshold

    def anchor(self, radii: np.ndarray | None) -> None:
        """After a declaration: the generator's radii set to the filter's ``radii`` (m) with the prior's
        radius covariance, so that it learns them from the next innovations instead of carrying the error of a
        tyre still settling, and the detectors restarted; without ``radii``, moved by the GLR's estimated
        jump when the detectors run one (the diagnoser's are built without: restarted only)."""
        if radii is None:
            self.detectors.correct()
            return
        gen = self.detectors.residual
        x, P = np.array(gen.x, float), np.array(gen.P, float)
        x[3:5] = radii
        P[3:5, :] = 0.0
        P[:, 3:5] = 0.0
        P[3:5, 3:5] = gen.setup.P0[3:5, 3:5]
        gen.set_state(x, P)
        self.detectors.restart()
