"""The change detectors' residual generator: a filter matched to the no-fault hypothesis, one null model
for every estimator.

The CUSUM and GLR (:mod:`.change`) need innovations whose law under "nothing changed" is known. The
estimators' own innovations do not qualify: the single filters model the radii as a random walk
(``estimator.q_diffusion``), so on a fault-free truth their innovation covariance overstates the
radius uncertainty (the gyro channel's whitened variance is about 0.04 instead of 1), and an IMM's
innovation is that of a Gaussian mixture whose covariance also spans the spread of its pinned
hypotheses. Each estimator would need its own null model.

:class:`ResidualGenerator` is an EKF over the same state ``[x, y, psi, R_R, R_L]``, stepped on the same
wheel rates and measurements as the estimator, whose model *is* the no-fault hypothesis: the radii are
constant (radius process noise 0), nothing is gated and it never resets. On the kinematic plant without
a fault its speed and yaw-rate innovations are then exactly ``N(0, S)`` and white (the radius
sub-problem is linear-Gaussian and the truth's radii are constant; the pose does not enter these
channels), so the whitened innovations ``e = L⁻¹ y`` are i.i.d. ``N(0, I)`` — for whichever estimator
the run uses. The same holds with position fixes up to the linearisation of the pose.

:class:`ChangeDetectors` runs the CUSUM and the GLR on those innovations and, after a declared change,
re-anchors the generator on the GLR's maximum-likelihood jump (Willsky & Jones 1976: the estimate is
corrected by ``ν̂ φ(k, θ̂)`` and its covariance by ``φ φᵀ / C``), so that it is matched again to "no
further change" and a second puncture is detected and isolated as the first.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..model.kinematics import numpy_step_jacobian
from .base import Measurement
from .change import HYPOTHESES, InnovationCUSUM, JumpGLR, isolate, linearise_step
from .ekf import EKF
from .measurements import channels
from .setup import FilterSetup

_EYE5 = np.eye(5)


def residual_setup(setup: FilterSetup) -> FilterSetup:
    """The no-fault hypothesis' filter of ``setup``: its radius process noise 0, no NIS gate, no divergence
    reset (a fault must show in the innovations, not be rejected or forgotten)."""
    Q = setup.Q.copy()
    Q[3, 3] = Q[4, 4] = 0.0
    return dataclasses.replace(setup, Q=Q, nis_gate=math.inf, divergence_nis=math.inf)


class ResidualGenerator(EKF):
    """An :class:`~ftc_mj.estimation.EKF` of :func:`residual_setup` (module docstring)."""

    def __init__(self, setup: FilterSetup) -> None:
        """``setup``: the estimator's resolved parameters; the generator keeps its model, sensors, ``P0``
        and pose noise and drops its radius noise."""
        super().__init__(residual_setup(setup))

    def correct(self, delta: np.ndarray, var_direction: np.ndarray) -> None:
        """Move the estimate by ``delta`` (5,) and add ``var_direction var_directionᵀ`` to the covariance
        (the uncertainty of an estimated jump along its direction)."""
        v = np.asarray(var_direction, float)
        self.set_state(self.x + np.asarray(delta, float), self.P + np.outer(v, v))


class ChangeDetectors:
    """CUSUM and GLR on the innovations of a :class:`ResidualGenerator` (module docstring).

    :meth:`step` feeds the estimator's wheel rates and measurement; afterwards ``cusum_stat``/``glr_stat``
    (log-likelihood-ratio units) and ``cusum_per_hypothesis``/``glr_per_hypothesis`` hold the statistics,
    ``white`` the whitened innovation and ``glr_drop`` (m per affected wheel) / ``glr_onset`` (s) the
    GLR's estimate of the leading jump. :meth:`wheel` isolates; :meth:`correct` re-anchors after a
    declaration.
    """

    def __init__(self, setup: FilterSetup, shift: float, isolation_llr: float, glr_window: int) -> None:
        """``setup``: the estimator's parameters; ``shift``: CUSUM design shift (σ); ``isolation_llr``:
        the lead (nats) a hypothesis needs to be isolated; ``glr_window``: onsets considered (steps)."""
        self.residual = ResidualGenerator(setup)
        self.setup = self.residual.setup
        self.isolation_llr = isolation_llr
        self._window = glr_window
        self.cusum = InnovationCUSUM(shift)
        self.glr = JumpGLR(glr_window)
        self.white: np.ndarray | None = None
        self._x_prev: np.ndarray | None = None
        self.cusum_per_hypothesis = np.zeros(len(HYPOTHESES))
        self.glr_per_hypothesis = np.zeros(len(HYPOTHESES))
        self.cusum_stat = self.glr_stat = 0.0
        self.glr_drop = self.glr_onset = math.nan

    @property
    def settle_time(self) -> float:
        """Half the GLR window (s): how long a declared change is watched before its size is booked."""
        return 0.5 * self._window * self.setup.dt

    def step(self, t: float, u: np.ndarray, z: Measurement) -> None:
        """Advance the generator with wheel rates ``u`` (rad/s) and the measurement ``z`` of time ``t`` (s);
        the detectors advance on steps with a usable innovation and hold otherwise."""
        u = np.asarray(u, float)
        out = self.residual.step(u, z)
        x = np.asarray(out.x, float)
        lin = None if out.rejected else linearise_step(self.setup, x, np.asarray(out.P, float),
                                                        np.asarray(out.innovation, float), np.asarray(out.S, float), u,
                                                        channels(self.setup, z)[2])
        if lin is not None:
            self.white = lin.e
            e = lin.e[None, :]
            self.cusum_per_hypothesis = self.cusum.step(e, lin.W)[0].copy()
            self.cusum_stat = float(self.cusum_per_hypothesis.max())
            if self.setup.position_sigma is None:
                F = _EYE5  # no channel sees the pose: its rows of F do not reach any signature
            else:
                x_lin = self._x_prev if self._x_prev is not None else x
                F = numpy_step_jacobian(self.setup.model, x_lin, u, self.setup.dt)
            self.glr_stat = float(self.glr.step(e, lin.W, F, lin.A)[0])
            self.glr_per_hypothesis = self.glr.per_hypothesis[0].copy()
            if self.glr_stat > 0.0:
                hyp, nu, lag = self.glr.estimate()
                self.glr_drop = nu * (math.sqrt(0.5) if hyp == "both" else 1.0)
                self.glr_onset = t - lag * self.setup.dt
            else:
                self.glr_drop = self.glr_onset = math.nan
        self._x_prev = x

    def wheel(self, kind: str) -> str | None:
        """The ``cusum`` or ``glr`` statistic's isolation: the hypothesis leading the runner-up by
        ``isolation_llr``, ``'unknown'`` when none does (with speed alone on a steady circle the
        hypotheses' signatures are collinear and tie exactly), ``None`` when every statistic is 0."""
        per = self.cusum_per_hypothesis if kind == "cusum" else self.glr_per_hypothesis
        return isolate(per, self.isolation_llr)

    def correct(self) -> None:
        """After a declared change: move the generator by the GLR's maximum-likelihood jump (hypothesis,
        size ``ν̂ = D/C`` and onset), add its uncertainty ``1/C`` along the jump's current error direction,
        and restart both detectors (the next change is tested against the corrected model)."""
        if self.glr_stat > 0.0:
            phi, c = self.glr.jump()
            nu = self.glr.estimate()[1]
            self.residual.correct(nu * phi, phi / math.sqrt(c))
        self.cusum = InnovationCUSUM(self.cusum.shift)
        self.glr = JumpGLR(self._window)
        self.cusum_per_hypothesis = np.zeros(len(HYPOTHESES))
        self.glr_per_hypothesis = np.zeros(len(HYPOTHESES))
        self.cusum_stat = self.glr_stat = 0.0
