"""Interacting multiple models (paper §2, Bar-Shalom's five steps) over EKF or UKF members.

One step, for ``M`` mode-matched filters with transition matrix ``Π`` (``Π[i, j]`` = P(i → j)):

1. mixing probabilities ``c̄_j = Σ_i Π_ij μ_i``, ``μ_{i|j} = Π_ij μ_i / c̄_j``;
2. mixing ``x⁰ʲ = Σ_i μ_{i|j} xⁱ``, ``P⁰ʲ = Σ_i μ_{i|j} (Pⁱ + (xⁱ - x⁰ʲ)(xⁱ - x⁰ʲ)ᵀ)``;
3. mode-matched filtering: each member predicts from ``(x⁰ʲ, P⁰ʲ)`` and updates with ``z``; the
   likelihood ``Λ_j = N(z; ẑʲ, Sʲ)`` is kept as a *log*-likelihood;
4. mode probabilities ``μ_j ∝ Λ_j c̄_j``, computed as ``c̄_j exp(log Λ_j - max log Λ)`` so that no
   likelihood underflows (a rejected/absent measurement leaves ``μ = c̄``);
5. combination ``x = Σ μ_j xʲ``, ``P = Σ μ_j (Pʲ + (xʲ - x)(xʲ - x)ᵀ)``.

All members are one batch: the ``M × 11`` sigma points (UKF) or ``M`` Jacobians (EKF) are evaluated
in one vectorised call of the kinematic model.

Model banks (paper): 4 models — no fault; 50 % right; 50 % left; both 50 % — with ``Π`` = 0.97 on the
diagonal, 0.01 elsewhere; 5 models add a linear left-wheel deflation at ``estimator.ramp_rate``
(0.96/0.01). ``μ0`` uniform. Two variants (``estimator.imm_variant``):

``paper``
    Literal: every member is the same filter (free radii, the paper's ``Q``), the models differ only
    in their *initial* radii. Mixing merges them within a few hundred steps (spread of radii → 0,
    ``μ`` stays uniform): kept so that the reproduction can show this collapse.

``hypothesis`` (default)
    Each member's *process model* encodes its hypothesis, so mixing cannot erase it:

    * a radius hypothesised at a fraction ``f`` of nominal is **pinned** in the model-matched
      prediction: after mixing, the member's radius mean is set to ``f·R0`` and its variance to
      ``hypothesis_sigma²``, uncorrelated with the other states; the prediction adds ``Q``; the
      update may refine the radius within that tolerance (absorbing small modelling errors), and
      the next mixing/pinning re-imposes the hypothesis. The pose states are mixed normally.
      (A softer anchor — the radius as ``f·R0`` plus a mean-reverting deviation with memory — was
      tried and rejected: with a yaw-rate gyro the data pull every member to the true radii within a
      few steps and the hypotheses are lost.)
    * the ramp member (5-model bank) pins ``R_R`` at nominal; its ``R_L`` keeps the *mixed* mean
      (so it starts from, and follows, the bank's estimate of the left radius) with the same
      variance ``hypothesis_sigma²``, and its prediction deflates it,
      ``R_L ← max(R_L - ramp_rate·dt, min_radius)``. All members are thus equally sharp, so no
      member wins for its predictive variance alone. The ramp member differs from the no-fault
      member only by following the left radius downwards: while the radius is constant the two fit
      (almost) equally well and share probability; once the radius keeps falling the pinned members
      fall behind and the ramp member takes over. Because it can follow a small constant offset of
      the left radius too, the decision layer requires the left radius to have actually dropped
      before it declares a fault from this member (:mod:`.decision`).

    Because the members predict different speeds (and yaw rates), their likelihoods differ and the
    mode probabilities discriminate; the combined radius estimate is the mode-weighted mixture.
    With speed alone, the 50 % right and 50 % left hypotheses predict the same speed when
    ``ω_R ≈ ω_L`` (straight or gently curved paths), so their probabilities split between them:
    isolation of the wheel needs the yaw-rate gyro or strongly asymmetric wheel rates.

Health rules are those of :mod:`._single`, applied to the whole bank: an update whose NIS exceeds
the gate for *every* member is rejected; a member whose covariance is not positive definite is
eigen-floored; divergence (non-finite numbers, or the mixture NIS above ``divergence_nis`` for
``divergence_dwell`` s) resets all members to their last finite estimates with ``reset_inflation·P0``.

A step is one call of the compiled kernel :func:`._kernels.imm_step` (``backend="numba"``, the
default) or the numpy reference code below (``backend="numpy"``); both work on the same buffers.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..config import EstimatorConfig, RunConfig, SensorConfig, section
from ._core import (
    SPEED,
    BufferView,
    EKFCore,
    FilterBuffers,
    FilterSetup,
    HealthCounters,
    UKFCore,
    assemble,
    eig_floor,
    kernel_inputs,
    resolve_backend,
)
from ._kernels import C_HYP, MU_FLOOR, P_RAMP_STEP, imm_step
from .base import FilterOutput, Hypothesis, Measurement

BANK_4: tuple[Hypothesis, ...] = (
    Hypothesis("no fault", 1.0, 1.0),
    Hypothesis("right 50%", 0.5, 1.0),
    Hypothesis("left 50%", 1.0, 0.5),
    Hypothesis("both 50%", 0.5, 0.5),
)
BANK_5: tuple[Hypothesis, ...] = (*BANK_4, Hypothesis("left ramp", 1.0, 1.0, ramp=True))


def transition_matrix(n: int, p_stay: float) -> np.ndarray:
    """``n × n`` matrix with ``p_stay`` on the diagonal and ``(1 - p_stay)/(n - 1)`` elsewhere."""
    off = (1.0 - p_stay) / (n - 1)
    return np.full((n, n), off) + np.eye(n) * (p_stay - off)


def configured_bank(est: EstimatorConfig) -> tuple[Hypothesis, ...]:
    """The bank ``est`` asks for: ``est.imm_bank`` in its order, else the paper's of ``imm_models`` members."""
    if est.imm_bank is not None:
        return tuple(Hypothesis(h.name, h.frac_R, h.frac_L, h.ramp) for h in est.imm_bank)
    return BANK_4 if est.imm_models == 4 else BANK_5


def configured_transition(est: EstimatorConfig, n: int) -> np.ndarray:
    """Transition matrix of an ``n``-member bank: ``est.p_stay`` on the diagonal if set, else ``p_stay_4``
    for 4 members and ``p_stay_5`` otherwise."""
    p = est.p_stay if est.p_stay is not None else (est.p_stay_4 if n == 4 else est.p_stay_5)
    return transition_matrix(n, p)


class IMM(HealthCounters):
    """IMM over EKF or UKF members: ``IMM(cfg, member="ukf").step(u, z) -> FilterOutput``.

    ``hypotheses``/``transition``/``variant`` default to the configured bank (``estimator.imm_bank``,
    else the paper's 4 or 5 models); they can be given explicitly (e.g. a 2-model bank in tests).
    The bank's :attr:`hypotheses` travel on every output (``FilterOutput.hypotheses``), so the
    decision layer knows what each mode probability means. ``settings``: the ``[estimator]``
    section when there is no run config (:meth:`from_settings`). ``backend``: ``"numba"`` (compiled
    step) or ``"numpy"`` (reference); default :data:`._core.DEFAULT_BACKEND`.

    ``X`` (M, 5), ``P`` (M, 5, 5), ``mu`` (M,), ``loglik`` (M,), ``x`` (5,) and ``P_comb`` (5, 5) are
    views of the bank's buffers: assigning to them copies into the buffers.
    """

    def __init__(
        self,
        cfg: RunConfig | None = None,
        member: str = "ukf",
        *,
        hypotheses: tuple[Hypothesis, ...] | None = None,
        transition: np.ndarray | None = None,
        variant: str | None = None,
        setup: FilterSetup | None = None,
        backend: str | None = None,
        settings: EstimatorConfig | None = None,
    ) -> None:
        if cfg is None and (setup is None or settings is None):
            raise TypeError("IMM: give a run config, or a FilterSetup and the estimator settings "
                            "(or use from_settings)")
        est = settings if settings is not None else cfg.estimator  # type: ignore[union-attr]
        self.setup = setup if setup is not None else FilterSetup.from_config(cfg)  # type: ignore[arg-type]
        self.backend = resolve_backend(backend)
        self.member = member
        self.core: UKFCore | EKFCore = UKFCore(self.setup) if member == "ukf" else EKFCore(self.setup)
        self.hypotheses: tuple[Hypothesis, ...] = tuple(hypotheses) if hypotheses is not None else configured_bank(est)
        """What each member assumes, in the order of the mode probabilities."""
        n = len(self.hypotheses)
        if transition is None:
            transition = configured_transition(est, n)
        self.Pi = np.asarray(transition, float)
        self.variant = variant if variant is not None else est.imm_variant
        R0 = self.setup.nominal_radius
        self._st = FilterBuffers(self.setup, n, member)
        self.frac = np.array([[h.frac_R, h.frac_L] for h in self.hypotheses])
        self.X = np.repeat(self.setup.x0[None, :], n, axis=0)
        self.X[:, 3] = self.frac[:, 0] * R0
        self.X[:, 4] = self.frac[:, 1] * R0
        if self.setup.x0[3] != R0 or self.setup.x0[4] != R0:
            # configured initial radii scale the members' *initial* radii (the paper variant's only
            # difference between members); the hypothesis variant pins fractions of nominal R0
            self.X[:, 3] *= self.setup.x0[3] / R0
            self.X[:, 4] *= self.setup.x0[4] / R0
        self.P = np.repeat(self.setup.P0[None, :, :], n, axis=0)
        self.mu = np.full(n, 1.0 / n)
        # hypothesis variant: pinned radius components (member, [R_R, R_L]) and the ramp member(s)
        hyp = self.variant == "hypothesis"
        self._ramp = np.array([hyp and h.ramp for h in self.hypotheses])
        self._pin = np.zeros((n, 2), dtype=bool)
        if hyp:
            self._pin[:, 0] = True
            self._pin[:, 1] = ~self._ramp
        self._pin_value = self.frac * R0
        self._sig_h2 = est.hypothesis_sigma**2
        self._ramp_step = est.ramp_rate * self.setup.dt
        self._hyp = hyp
        # masks: covariance entries kept (1) / dropped (0) and the re-imposed radius variances
        reimposed = self._pin | np.stack([np.zeros(n, bool), self._ramp], axis=1)
        keep = np.ones((n, 5, 5))
        self._reset_var = np.zeros((n, 5, 5))
        for j in range(n):
            for c in (0, 1):
                if reimposed[j, c]:
                    keep[j, 3 + c, :] = 0.0
                    keep[j, :, 3 + c] = 0.0
                    self._reset_var[j, 3 + c, 3 + c] = self._sig_h2
        self._keep = keep
        if hyp:
            self._hypothesis_radii(self.X, self.P)
        self._u_last = np.zeros(2)
        self.x, self.P_comb = self._combine(self.X, self.P, self.mu)
        # constants of the compiled step
        st = self._st
        st.Pi[:] = self.Pi
        st.pin_value[:], st.pin[:] = self._pin_value, self._pin
        st.keep[:], st.reset_var[:], st.ramp[:] = self._keep, self._reset_var, self._ramp
        st.prm[P_RAMP_STEP] = self._ramp_step
        st.cnt[C_HYP] = hyp

    @classmethod
    def from_settings(cls, member: str = "ukf", estimator: EstimatorConfig | Mapping[str, Any] | None = None,
                      sensors: SensorConfig | Mapping[str, Any] | None = None, *, wheel_radius: float = 2.0,
                      half_track: float = 1.0, initial_pose: Sequence[float] = (0.0, 0.0, 0.0),
                      backend: str | None = None) -> IMM:
        """The IMM built from its own settings, without a run config (the bank, transition matrix and
        variant from ``estimator``; the rest as :meth:`FilterSetup.from_settings`)."""
        est = section(EstimatorConfig, estimator, "estimator")
        setup = FilterSetup.from_settings(est, sensors, wheel_radius=wheel_radius, half_track=half_track,
                                          initial_pose=initial_pose)
        return cls(member=member, setup=setup, settings=est, backend=backend)

    @property
    def n_modes(self) -> int:
        """Members of the bank."""
        return len(self.hypotheses)

    # ---------------------------------------------------------------- state (views of the buffers)
    X = BufferView("X", "Member estimates (M, 5) (m, m, rad, m, m).")
    P = BufferView("P", "Member covariances (M, 5, 5).")
    mu = BufferView("mu", "Mode probabilities (M,).")
    loglik = BufferView("loglik", "Members' log-likelihoods of the last accepted measurement (M,) (0 before any).")
    x = BufferView("x", "Combined estimate (5,).")
    P_comb = BufferView("Pc", "Combined covariance (5, 5).")

    # ---------------------------------------------------------------- IMM steps
    def mixing_probabilities(self) -> tuple[np.ndarray, np.ndarray]:
        """Step 1: ``(c̄, ω)`` with ``ω[i, j] = μ_{i|j}``."""
        cbar = self.mu @ self.Pi
        omega = self.Pi * self.mu[:, None] / cbar[None, :]
        return cbar, omega

    @staticmethod
    def mix(X: np.ndarray, P: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Step 2: mixed initial conditions (M, 5), (M, 5, 5)."""
        W = omega.T  # W[j, i] = μ_{i|j}
        X0 = W @ X
        d = X[None, :, :] - X0[:, None, :]  # (j, i, 5)
        M = P.shape[0]
        P0 = (W @ P.reshape(M, 25)).reshape(M, 5, 5) + (d.swapaxes(1, 2) * W[:, None, :]) @ d
        return X0, P0

    @staticmethod
    def _combine(X: np.ndarray, P: np.ndarray, mu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Step 5: combined estimate and covariance."""
        x = mu @ X
        d = X - x
        Pc = (mu @ P.reshape(P.shape[0], 25)).reshape(5, 5) + (d.T * mu) @ d
        return x, Pc

    def _hypothesis_radii(self, X0: np.ndarray, P0: np.ndarray) -> None:
        """Impose each member's radius hypothesis on its mixed initial condition (in place): pinned
        means, and variance ``hypothesis_sigma²`` without correlation for pinned and ramp radii."""
        X0[:, 3:5] = np.where(self._pin, self._pin_value, X0[:, 3:5])
        P0 *= self._keep
        P0 += self._reset_var

    # ---------------------------------------------------------------- step
    def step(self, u: np.ndarray, z: Measurement) -> FilterOutput:
        """One IMM cycle with wheel rates ``u`` = [omega_R, omega_L] (rad/s) and measurement ``z``."""
        return self._step_numba(u, z) if self.backend == "numba" else self._step_numpy(u, z)

    def _step_numba(self, u: np.ndarray, z: Measurement) -> FilterOutput:
        st = self._st
        nis, sp_innov, sp_std, m, rejected, reset = imm_step(st.buf, st.cnt, *kernel_inputs(self.setup, u, z))
        return FilterOutput(
            x=st.x.copy(), P=st.Pc.copy(), innovation=st.y_of[m].copy(), S=st.S_of[m].copy(),
            nis=nis, speed_innovation=sp_innov, speed_innovation_std=sp_std,
            mode_probs=st.mu.copy(), hypotheses=self.hypotheses, model_x=st.X.copy(), rejected=rejected, reset=reset,
        )

    def _step_numpy(self, u: np.ndarray, z: Measurement) -> FilterOutput:
        u = np.asarray(u, dtype=float).reshape(2)
        if math.isfinite(u[0]) and math.isfinite(u[1]):
            self._u_last = u
        else:
            u = self._u_last
        X_prev, P_prev = self.X.copy(), self.P.copy()
        cbar, omega = self.mixing_probabilities()
        X0, P0 = self.mix(self.X, self.P, omega)
        if self._hyp:
            self._hypothesis_radii(X0, P0)
        Xp, Pp = self.core.predict(X0, P0, u)
        if self._hyp and self._ramp.any():
            r = self._ramp
            Xp[r, 4] = np.maximum(Xp[r, 4] - self._ramp_step, self.setup.min_radius)
        a = assemble(self.setup, z)
        rejected = a.dropped
        X, P, mu = Xp, Pp, cbar
        y = np.zeros(0)
        S = np.zeros((0, 0))
        nis = math.nan
        sp_innov = sp_std = math.nan
        if a.z.size:
            res = self.core.update(Xp, Pp, u, a)
            # mixture predictive density of z (weights c̄): innovation and S of the bank
            zbar = cbar @ res.zp
            dzp = res.zp - zbar
            mz = dzp.shape[1]
            S = (cbar @ res.S.reshape(len(cbar), mz * mz)).reshape(mz, mz) + (dzp.T * cbar) @ dzp
            y = a.z - zbar
            nis = float(y @ np.linalg.solve(S, y)) if y.size > 1 else float(y[0] * y[0] / S[0, 0])
            if SPEED in a.kinds:
                i = a.kinds.index(SPEED)
                sp_innov, sp_std = float(y[i]), math.sqrt(max(float(S[i, i]), 0.0))
            ok = np.isfinite(res.loglik)
            if ok.any() and np.min(np.where(ok, res.nis, np.inf)) <= self.setup.nis_gate:
                X, P = res.X, res.P
                ll = np.where(ok, res.loglik, -np.inf)
                self.loglik = ll
                w = cbar * np.exp(ll - ll.max())
                mu = w / w.sum()
            else:
                rejected = True
        P = 0.5 * (P + P.swapaxes(1, 2))
        reset = self._check_divergence(X, P, nis)
        if reset:
            X, P = self._reset_state(X_prev, P_prev)
        elif float(P.diagonal(0, 1, 2).min()) <= 0.0:  # (non-PD otherwise: repaired at the next Cholesky)
            bad = np.any(P.diagonal(0, 1, 2) <= 0.0, axis=1)
            P[bad] = eig_floor(P[bad])
        mu = np.maximum(mu, MU_FLOOR)  # no mode is ever impossible (as filterpy's likelihood floor)
        self.X, self.P, self.mu = X, P, mu / mu.sum()
        self.x, self.P_comb = self._combine(self.X, self.P, self.mu)
        if rejected:
            self.rejections += 1
        return FilterOutput(
            x=self.x.copy(), P=self.P_comb.copy(), innovation=np.array(y, float), S=np.array(S, float),
            nis=nis, speed_innovation=sp_innov, speed_innovation_std=sp_std,
            mode_probs=self.mu.copy(), hypotheses=self.hypotheses, model_x=self.X.copy(), rejected=rejected,
            reset=reset,
        )

    def _check_divergence(self, X: np.ndarray, P: np.ndarray, nis: float) -> bool:
        if not math.isfinite(float(X.sum()) + float(P.sum())):
            return True
        if math.isfinite(nis) and nis > self.setup.divergence_nis:
            self._bad_nis_steps += 1
        elif math.isfinite(nis):
            self._bad_nis_steps = 0
        return self._bad_nis_steps >= self.setup.divergence_steps

    def _reset_state(self, X_prev: np.ndarray, P_prev: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self.resets += 1
        self._bad_nis_steps = 0
        X = X_prev.copy()
        fallback = np.repeat(self.setup.x0[None, :], len(X), axis=0)
        X = np.where(np.isfinite(X), X, fallback)
        R0 = self.setup.nominal_radius
        X[:, 3:5] = np.clip(X[:, 3:5], self.setup.min_radius, 10.0 * R0)
        P = np.repeat(self.setup.reset_inflation * self.setup.P0[None, :, :], len(X), axis=0)
        return X, P

    # ---------------------------------------------------------------- convenience
    @property
    def wheels(self) -> tuple[str | None, ...]:
        """Faulty wheel(s) hypothesised by each member (``None`` = no fault)."""
        return tuple(h.wheel for h in self.hypotheses)
