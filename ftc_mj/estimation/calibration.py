"""Thresholds of the change detectors (:mod:`.change`) for a target mean time between false alarms.

Thresholds from a target mean time between false alarms ``decision.arl0`` (s),
:func:`arl0_threshold` (called by the decision factory): a Monte Carlo of the detector on its null
model, the filter at its nominal operating point (the reference's speed and yaw rate at nominal
radii; ``P`` after 20 s of the filter's own Riccati recursion from ``P0``; speed and yaw-rate
channels, position fixes ignored) when nothing changes: :class:`NullInnovations` simulates its
estimation error with the radii *constant*, the no-fault truth. Those innovations are not
``N(0, I)``: the filters' random-walk ``Q`` makes ``S`` overstate the radius uncertainty and the
mismatched gain colours them (docs/fdi.md). The threshold is the one whose censored first-alarm rate
(alarms / exposure up to each chain's first alarm) is ``1/arl0``. With the filters' own model as the
truth the innovations are ``N(0, I)`` and the calibration of a single CUSUM reproduces Siegmund's
approximation ``ARL0 ≈ (e^{b} - b - 1)/(δ²/2)``, ``b = h + 1.166 δ`` (tested). Targets beyond 200 s are
calibrated at 200 s and extended by ``h += log(arl0/200 s)`` (the LLR scale: ``ARL0 ∝ e^h``
asymptotically, Lorden 1971), which errs on the long side for a GLR.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from ..model.kinematics import inverse_rates
from .change import DIRECTIONS, HYPOTHESES, InnovationCUSUM, JumpGLR, channel_kinds, noise_variances
from .measurements import measure_jacobian
from .pcrb import information_bound
from .setup import FilterSetup

CALIBRATION_HORIZON_S = 200.0
"""Longest null run simulated (s); longer targets are extrapolated on the LLR scale."""
NOMINAL_SETTLE_S = 20.0
"""Riccati recursion (s) from ``P0`` that sets the nominal covariance."""
NULL_BURN_IN = 500
"""Steps of the null error recursion before its first innovation."""


@dataclass(frozen=True)
class NominalPoint:
    """The filter at its nominal operating point (see the module docstring), as hashable numbers."""

    H: tuple[float, ...]
    """(m, 5) measurement Jacobian."""
    L: tuple[float, ...]
    """(m, m) lower Cholesky factor of the filter's innovation covariance ``S``."""
    K: tuple[float, ...]
    """(5, m) filter gain ``P Hᵀ R⁻¹``."""
    F: tuple[float, ...]
    """(5, 5) prediction Jacobian."""
    r_sd: tuple[float, ...]
    """(m,) measurement-noise σ."""
    q_sd: tuple[float, ...]
    """(5,) the filters' process-noise σ per step (diagonal ``Q``)."""

    @property
    def m(self) -> int:
        return len(self.r_sd)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(W, F, A)``: ``W = L⁻¹ H``, ``F``, ``A = I - K H`` as the detectors take them."""
        m = self.m
        H, L, K = np.array(self.H).reshape(m, 5), np.array(self.L).reshape(m, m), np.array(self.K).reshape(5, m)
        return np.linalg.solve(L, H), np.array(self.F).reshape(5, 5), np.eye(5) - K @ H


def nominal_point(setup: FilterSetup, speed: float, yaw_rate: float) -> NominalPoint:
    """Speed (+ yaw-rate) channels of the filter ``setup`` at a steady ``speed`` (m/s) and ``yaw_rate``
    (rad/s) with nominal radii; the covariance after :data:`NOMINAL_SETTLE_S` of the filter's Riccati
    recursion from ``P0``."""
    R0 = setup.nominal_radius
    u = np.array(inverse_rates(speed, yaw_rate, R0, R0, setup.model.b), float)
    x = np.array([0.0, 0.0, 0.0, R0, R0])
    kinds = channel_kinds(setup, 2 if setup.yaw_rate_sigma is not None else 1)
    assert kinds is not None
    H = measure_jacobian(setup.model, x[None, :], u, kinds)[0]
    var = noise_variances(setup, kinds)
    F = setup.model.step_jacobian(x, u)
    n = int(round(NOMINAL_SETTLE_S / setup.dt))
    P = information_bound(np.broadcast_to(F, (n, 5, 5)), [H] * n, [np.diag(var)] * n, setup.Q, setup.P0)[-1]
    Pm = F @ P @ F.T + setup.Q
    L = np.linalg.cholesky(H @ Pm @ H.T + np.diag(var))
    K = P @ H.T / var
    return NominalPoint(tuple(H.ravel()), tuple(L.ravel()), tuple(K.ravel()), tuple(F.ravel()),
                        tuple(np.sqrt(var)), tuple(np.sqrt(np.diag(setup.Q))))


class NullInnovations:
    """Whitened innovations of the nominal filter when nothing changes, for a batch of ``chains``.

    The estimation error of the linearised filter follows ``y = H ε⁻ + v``, ``ε⁺ = ε⁻ - K y``,
    ``ε⁻ ← F ε⁺ + w``, with ``v ~ N(0, R)`` and the *true* process noise ``w``: the filters' ``Q`` except
    for the radii, whose σ per step is ``q_radius`` (0: the radii are constant — the no-fault truth).
    With ``q_radius`` = the filters' own value the innovations ``e = L⁻¹ y`` are i.i.d. ``N(0, I)``;
    with constant radii they are smaller (the random-walk model overstates the radius uncertainty the
    innovation covariance ``S`` includes) and correlated. :data:`NULL_BURN_IN` steps reach the stationary
    error before the first innovation is returned.
    """

    def __init__(self, point: NominalPoint, chains: int, rng: np.random.Generator, q_radius: float = 0.0) -> None:
        m = point.m
        self.H = np.array(point.H).reshape(m, 5)
        self.Linv = np.linalg.inv(np.array(point.L).reshape(m, m))
        self.K = np.array(point.K).reshape(5, m)
        self.F = np.array(point.F).reshape(5, 5)
        self.r_sd = np.array(point.r_sd)
        q = np.array(point.q_sd)
        q[3:5] = q_radius
        self.q_sd = q
        self.rng = rng
        self.eps = np.zeros((chains, 5))
        for _ in range(NULL_BURN_IN):
            self.next()

    def next(self) -> np.ndarray:
        """Whitened innovations (chains, m) of the next step."""
        n = self.eps.shape[0]
        y = self.eps @ self.H.T + self.rng.standard_normal((n, self.r_sd.size)) * self.r_sd
        self.eps = (self.eps - y @ self.K.T) @ self.F.T + self.rng.standard_normal((n, 5)) * self.q_sd
        return y @ self.Linv.T


def null_running_max(kind: str, point: NominalPoint, *, shift: float, window: int, steps: int, chains: int,
                     q_radius: float = 0.0, seed: int = 0) -> np.ndarray:
    """Running maximum (chains, steps) of a detector's statistic on :class:`NullInnovations` at the nominal
    point: the null distribution of its first-alarm time for every threshold at once."""
    W, F, A = point.arrays()
    rng = np.random.default_rng([seed, 17, point.m])
    null = NullInnovations(point, chains, rng, q_radius)
    out = np.empty((chains, steps))
    run = np.zeros(chains)
    if kind == "cusum":
        det_c = InnovationCUSUM(shift, chains)
        for k in range(steps):
            run = np.maximum(run, det_c.step(null.next(), W).max(axis=1))
            out[:, k] = run
    elif kind == "glr":
        det_g = JumpGLR(informative_lags(point, window), chains)
        for k in range(steps):
            run = np.maximum(run, det_g.step(null.next(), W, F, A))
            out[:, k] = run
    else:
        raise ValueError(f"unknown change detector {kind!r}")
    return out


def informative_lags(point: NominalPoint, window: int, keep: float = 1.0 - 1e-6) -> int:
    """Lags (≤ ``window``) that carry the fraction ``keep`` of a jump's signature information at the
    nominal point. Beyond them a jump's log-likelihood ratio no longer changes, so the running maximum
    of the statistic — all a first alarm depends on — is the same with the shorter window."""
    W, F, A = point.arrays()
    phi = DIRECTIONS.copy()
    info = np.zeros((window, len(HYPOTHESES)))
    for j in range(window):
        info[j] = np.sum((phi @ W.T) ** 2, axis=1)
        phi = phi @ A.T @ F.T
    cum = np.cumsum(info, axis=0)
    total = cum[-1]
    need = np.all(cum >= keep * total, axis=1)
    return int(np.argmax(need)) + 1 if need.any() else window


def first_alarm_rate(running_max: np.ndarray, h: float) -> float:
    """Censored first-alarm rate (alarms per step) at threshold ``h``: chains alarming / steps observed up
    to each chain's first alarm (the maximum-likelihood rate of an exponential first-alarm time)."""
    hit = running_max >= h
    alarmed = hit[:, -1]
    first = np.where(alarmed, hit.argmax(axis=1) + 1, running_max.shape[1])
    return float(alarmed.sum()) / float(first.sum())


@functools.lru_cache(maxsize=32)
def null_threshold(kind: str, point: NominalPoint, shift: float, window: int, arl0_steps: int,
                   q_radius: float = 0.0) -> float:
    """Threshold whose censored first-alarm rate on :class:`NullInnovations` (radius noise ``q_radius``) is
    ``1/arl0_steps`` (bisection on 160 chains of ``arl0_steps`` steps; cached)."""
    chains = 160  # ≈ 100 first alarms at the target: the rate to ±10 %, the threshold to ±0.1 nats
    M = null_running_max(kind, point, shift=shift, window=window, steps=arl0_steps, chains=chains, q_radius=q_radius)
    lo, hi = 0.0, float(M.max()) + 1.0
    target = 1.0 / arl0_steps
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        if first_alarm_rate(M, mid) > target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def arl0_threshold(kind: str, point: NominalPoint, *, arl0: float, shift: float, window: int,
                   rate: float) -> float:
    """Threshold (log-likelihood-ratio units) of the ``cusum`` or ``glr`` detector for a mean time
    ``arl0`` (s) between false alarms at the nominal ``point``: calibrated on a horizon of at most
    :data:`CALIBRATION_HORIZON_S` at the filter ``rate`` (Hz) and extrapolated to ``arl0``; ``shift``
    the CUSUM design shift (σ), ``window`` the GLR window (steps)."""
    horizon = min(arl0, CALIBRATION_HORIZON_S)
    h = null_threshold(kind, point, float(shift), window, int(round(horizon * rate)))
    return h + math.log(arl0 / horizon)


def siegmund_arl0(h: float, shift: float) -> float:
    """Siegmund's approximation of a single Gaussian CUSUM's ARL0 (steps) at threshold ``h`` (LLR units)
    for a design shift ``shift`` (σ): ``(e^b - b - 1)/(δ²/2)``, ``b = h + 1.166 δ``."""
    b = h + 1.166 * shift
    return (math.exp(b) - b - 1.0) / (0.5 * shift * shift)
