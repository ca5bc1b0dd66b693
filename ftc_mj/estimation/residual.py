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
from collections import deque

import numpy as np

from ..model.kinematics import numpy_step_jacobian
from .base import FilterOutput, Measurement
from .change import (
    HYPOTHESES,
    InnovationCUSUM,
    JumpGLR,
    Linearisation,
    channel_kinds,
    isolate,
    linearise_step,
    measurement_jacobian,
)
from .ekf import EKF
from .measurements import channels
from .null_model import HOLD_S, RADIUS_GAP, NullModel
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

    def __init__(self, setup: FilterSetup, shift: float, isolation_llr: float, glr_window: int,
                 physical: bool = False, glr: bool = True) -> None:
        """``setup``: the estimator's parameters; ``shift``: CUSUM design shift (σ); ``isolation_llr``:
        the lead (nats) a hypothesis needs to be isolated; ``glr_window``: onsets considered (steps);
        ``physical``: whiten under the physical robot's null model (:mod:`.null_model`: the one-step lag
        removed, tyre slip near the grip limit as effective-radius noise), else under the kinematic
        model alone (exact on the kinematic plant, where the null model changes nothing but the lag); ``glr``:
        run the GLR (off: ``glr_stat`` stays 0 — for a user of the CUSUM alone, the GLR being most of the cost)."""
        self.residual = ResidualGenerator(setup)
        self.setup = self.residual.setup
        self.null_model = (NullModel(self.setup.nominal_radius, self.setup.model.b, self.setup.dt) if physical
                           else None)
        self._u_prev: np.ndarray | None = None
        self._z_prev: Measurement | None = None
        self._demands: deque[float] = deque(maxlen=max(1, int(round(HOLD_S / self.setup.dt))))
        self.isolation_llr = isolation_llr
        self._window = glr_window
        self.cusum = InnovationCUSUM(shift)
        self.glr = JumpGLR(glr_window) if glr else None
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

    def step(self, t: float, u: np.ndarray, z: Measurement, radii: np.ndarray | None = None) -> None:
        """Advance the generator with wheel rates ``u`` (rad/s) and the measurement ``z`` of time ``t`` (s);
        the detectors advance on steps with a usable innovation and hold otherwise. ``radii``: the
        estimator's radius estimates ``[R_R, R_L]`` (m) the null model reads the demand at (``None``: the
        generator's own radii, :meth:`_physical`)."""
        u = np.asarray(u, float)
        q = 0.0
        if self.null_model is not None:
            t, z, q = self._physical(t, u, z, radii)
        out = self.residual.step(u, z)
        x = np.asarray(out.x, float)
        lin = None if out.rejected else self._linearise(x, out, u, channels(self.setup, z)[2], q)
        self._u_prev = u
        if lin is not None:
            self.white = lin.e
            e = lin.e[None, :]
            self.cusum_per_hypothesis = self.cusum.step(e, lin.W)[0].copy()
            self.cusum_stat = float(self.cusum_per_hypothesis.max())
            if self.glr is not None:
                self._step_glr(t, e, lin, u, x)
        self._x_prev = x

    def _step_glr(self, t: float, e: np.ndarray, lin: Linearisation, u: np.ndarray, x: np.ndarray) -> None:
        """Advance the GLR on the whitened innovation ``e`` (1, m) of time ``t`` (s) and its estimate."""
        assert self.glr is not None
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

    def _physical(self, t: float, u: np.ndarray, z: Measurement, radii: np.ndarray | None
                  ) -> tuple[float, Measurement, float]:
        """Under the physical null model (:mod:`.null_model`): the time (s) and measurement the generator
        takes with the rates ``u`` (rad/s) — the previous step's, measured when ``u`` was; nothing at the
        first step —, a channel dropped where its slip noise dominates
        (:meth:`.null_model.NullModel.drops`), and the demanded lateral acceleration (g) held over
        :data:`~.null_model.HOLD_S`: at the generator's radii, or the lower of that and the demand at the
        estimator's ``radii`` (m, when given) where they depart from the generator's by more than
        :data:`~.null_model.RADIUS_GAP` of the nominal radius. The generator's radii stay at their last re-anchoring, so
        after a puncture re-anchored on a tyre still settling the controller's compensating rates read at
        them as a demand of several g, the yaw channel is dropped, the detectors hold and nothing re-anchors
        them — a blind state that lasted until a second puncture was 2 s old (scenario 3 with the gyro, dev
        seeds 0–2: 2.06 s; with the lower demand 0.77 s, as with the kinematic null model); the estimator
        follows the radii but overshoots in the first tenths of a second of a change, when the generator's
        radii still hold the demand down, and reads a slip as a radius change — hence the gap."""
        nm = self.null_model
        assert nm is not None
        own = np.asarray(self.residual.x, float)[3:5]
        q_now = nm.demand(u, own)
        if radii is not None and max(abs(float(radii[0]) - own[0]), abs(float(radii[1]) - own[1])) > RADIUS_GAP * nm.R0:
            q_now = min(q_now, nm.demand(u, np.asarray(radii, float)))
        self._demands.append(q_now)
        q = max(self._demands)
        z_then, self._z_prev = self._z_prev, z
        if z_then is None:
            return t - self.setup.dt, Measurement(speed=None), q
        st = self.setup
        speed = None if nm.drops(q, u, st.speed_sigma, "speed") else z_then.speed
        yaw = None if nm.drops(q, u, st.yaw_rate_sigma, "yaw") else z_then.yaw_rate
        return t - st.dt, dataclasses.replace(z_then, speed=speed, yaw_rate=yaw), q

    def _linearise(self, x: np.ndarray, out: FilterOutput, u: np.ndarray, used: tuple[int, ...], q: float
                   ) -> Linearisation | None:
        """The detectors' view of the generator's step (:func:`.change.linearise_step`), its innovation
        covariance first widened by the :attr:`null_model`'s slip noise at the demanded acceleration ``q`` (g)."""
        y, S = np.asarray(out.innovation, float), np.asarray(out.S, float)
        kinds = channel_kinds(self.setup, int(y.size))
        if self.null_model is None or kinds is None or tuple(used) != kinds:
            return linearise_step(self.setup, x, np.asarray(out.P, float), y, S, u, used)
        H = measurement_jacobian(self.setup, x, u, kinds)
        S = self.null_model.covariance(S, H, q)
        return linearise_step(self.setup, x, np.asarray(out.P, float), y, S, u, used, H)

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
        if self.glr is not None and self.glr_stat > 0.0:
            phi, c = self.glr.jump()
            nu = self.glr.estimate()[1]
            self.residual.correct(nu * phi, phi / math.sqrt(c))
        self.restart()

    def restart(self) -> None:
        """Restart both detectors from zero, the residual generator untouched (a fresh start of their run
        lengths)."""
        self.cusum = InnovationCUSUM(self.cusum.shift)
        self.glr = JumpGLR(self._window) if self.glr is not None else None
        self.cusum_per_hypothesis = np.zeros(len(HYPOTHESES))
        self.glr_per_hypothesis = np.zeros(len(HYPOTHESES))
        self.cusum_stat = self.glr_stat = 0.0
