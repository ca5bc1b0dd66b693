"""Sequential change detectors on a filter's innovations: CUSUM and GLR for a drop in a wheel radius.

Both work on the *whitened* innovation ``e_k = L_k⁻¹ y_k`` (``S_k = L_k L_kᵀ``, Cholesky), which is
i.i.d. ``N(0, I)`` while the filter's model holds (a consistent filter on a fault-free run), and on
the innovation *signature* of a puncture: a drop of ``ν`` metres along the state direction
``f_i`` (hypothesis ``i`` = right, left or both wheels, :data:`HYPOTHESES`) just before step ``θ``
shifts the prior estimation error by ``ν f_i`` and hence the mean of ``e_k`` by ``ν ρ_i(k, θ)`` with
(Willsky & Jones 1976)::

    ρ_i(k, θ) = L_k⁻¹ H_k φ_i(k, θ),   φ_i(θ, θ) = f_i,
    φ_i(k+1, θ) = F_{k+1} (I - K_k H_k) φ_i(k, θ),   K_k = P_k Hₖᵀ R_k⁻¹,

where ``H`` is the measurement Jacobian, ``F`` the prediction Jacobian (model automatic
differentiation) and ``K`` the filter's gain, obtained from its posterior covariance ``P`` by the
Kalman identity ``K = P Hᵀ R⁻¹``. The filter adapts to the new radius, so ``ρ`` decays: the
innovations carry the evidence of a fault only during that transient (its total information is
``Σ_k |ρ(k, θ)|²`` per m² of drop).

CUSUM (Page 1954) per hypothesis, for a mean shift of ``δ`` (``decision.cusum_shift``, σ units)
along the unit direction ``u_i = ρ_i(θ, θ) / |ρ_i(θ, θ)|``::

    C_i ← max(0, C_i + δ u_iᵀ e_k - δ²/2),

the log-likelihood-ratio CUSUM of ``N(δ, 1)`` against ``N(0, 1)`` for ``z = u_iᵀ e``.

GLR (Willsky & Jones): for every onset ``θ`` in the last ``decision.glr_window`` seconds and every
hypothesis, ``D = Σ_{k≥θ} ρᵀ e_k``, ``C = Σ_{k≥θ} |ρ|²``; the maximum-likelihood drop is
``ν̂ = D / C`` and the log-likelihood ratio of "drop ν̂ at θ" against "no change" is
``D² / (2C)`` (kept when ``ν̂ > 0``: a puncture lowers the radius). The statistic is the maximum over
``θ`` and hypotheses; its maximiser estimates the onset, the wheel and the size.

Isolation: the hypothesis with the largest statistic is isolated when it leads the runner-up by
``decision.isolation_llr`` (nats; 4.6 ≈ 99:1 odds); otherwise the wheel is ``'unknown'``. With
speed alone the signatures of the hypotheses are collinear (every drop lowers the speed and nothing
else is measured), the statistics tie and nothing is isolated.

Thresholds: :mod:`.calibration` (from a target mean time between false alarms).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from ..model.kinematics import numpy_rates_jacobian
from .kernels.jit import njit
from .kernels.layout import POS_X, POS_Y, SPEED, YAW
from .measurements import measure_jacobian
from .setup import FilterSetup

HYPOTHESES: tuple[str, ...] = ("right", "left", "both")
"""Fault hypotheses of the detectors, in the order of their statistics."""
DIRECTIONS = np.array([
    [0.0, 0.0, 0.0, -1.0, 0.0],
    [0.0, 0.0, 0.0, 0.0, -1.0],
    [0.0, 0.0, 0.0, -math.sqrt(0.5), -math.sqrt(0.5)],
])
"""State change ``f_i`` per metre of drop under each hypothesis (unit vectors; 'both' drops each wheel by
``ν/√2``)."""
WHEEL_CODES: dict[str | None, int] = {None: 0, "right": 1, "left": 2, "both": 3, "unknown": 4}
"""Code of an isolation result in the trace (``*_wheel`` columns)."""


def channel_kinds(setup: FilterSetup, m: int) -> tuple[int, ...] | None:
    """Channel codes of an ``m``-channel innovation (order speed, yaw rate, x, y) for the configured
    sensors; ``None`` when ``m`` does not match a complete set (a channel was dropped that step)."""
    base = (SPEED, YAW) if setup.yaw_rate_sigma is not None else (SPEED,)
    if m == len(base):
        return base
    if setup.position_sigma is not None and m == len(base) + 2:
        return (*base, POS_X, POS_Y)
    return None


@functools.lru_cache(maxsize=64)
def _variances(sigmas: tuple[float | None, ...], kinds: tuple[int, ...]) -> np.ndarray:
    v = np.array([sigmas[k] ** 2 for k in kinds], float)  # type: ignore[operator]
    v.flags.writeable = False
    return v


def noise_variances(setup: FilterSetup, kinds: tuple[int, ...]) -> np.ndarray:
    """Measurement-noise variances of the channels ``kinds`` (read-only array, cached)."""
    sigmas = (setup.speed_sigma, setup.yaw_rate_sigma, setup.position_sigma, setup.position_sigma)
    return _variances(sigmas, kinds)


def isolate(per_hypothesis: np.ndarray, margin: float) -> str | None:
    """The hypothesis whose statistic leads the runner-up by ``margin``, ``'unknown'`` if none does,
    ``None`` if every statistic is zero."""
    v = per_hypothesis.tolist()
    best = max(range(len(v)), key=v.__getitem__)
    if not v[best] > 0.0:
        return None
    second = max(x for i, x in enumerate(v) if i != best)
    return HYPOTHESES[best] if v[best] - second >= margin else "unknown"


# ---------------------------------------------------------------------------- detectors (batched)
class InnovationCUSUM:
    """One CUSUM per hypothesis, over a batch of ``batch`` independent sequences (1 online)."""

    def __init__(self, shift: float, batch: int = 1) -> None:
        self.shift = float(shift)
        self.C = np.zeros((batch, len(HYPOTHESES)))

    def step(self, e: np.ndarray, W: np.ndarray) -> np.ndarray:
        """Advance with whitened innovations ``e`` (batch, m) and ``W = L⁻¹ H`` (m, 5), which gives the
        instantaneous signatures ``W f_i``; returns the statistics (batch, hypotheses), in
        log-likelihood-ratio units."""
        _cusum_step(self.C, np.ascontiguousarray(e, dtype=float), np.ascontiguousarray(W, dtype=float),
                    DIRECTIONS, self.shift)
        return self.C

    def running_max(self, E: np.ndarray, W: np.ndarray, run: np.ndarray, out: np.ndarray) -> None:
        """Advance through the steps of ``E`` (steps, batch, m) — as :meth:`step` once per step, compiled in one
        call — writing into ``out`` (batch, steps) the running maximum over hypotheses and steps, carried in
        ``run`` (batch,): the null distribution of the first-alarm time (:mod:`.calibration`)."""
        _cusum_running_max(self.C, np.ascontiguousarray(E, dtype=float), np.ascontiguousarray(W, dtype=float),
                           DIRECTIONS, self.shift, run, out)


@njit(cache=True, error_model="numpy")
def _cusum_running_max(C: np.ndarray, E: np.ndarray, W: np.ndarray, f: np.ndarray, shift: float,
                       run: np.ndarray, out: np.ndarray) -> None:
    """Compiled :meth:`InnovationCUSUM.running_max`: :func:`_cusum_step` per step, then the batch's running
    maximum (exact: maxima do not round)."""
    for k in range(E.shape[0]):
        _cusum_step(C, E[k], W, f, shift)
        for b in range(C.shape[0]):
            top = run[b]
            for h in range(C.shape[1]):
                if C[b, h] > top:
                    top = C[b, h]
            run[b] = top
            out[b, k] = top


@njit(cache=True, error_model="numpy")
def _row_dot(A: np.ndarray, i: int, B: np.ndarray, j: int) -> float:
    """``Σ_k A[i, k] B[j, k]`` over the columns of ``B``, accumulated from 0.0 in column order."""
    acc = 0.0
    for k in range(B.shape[1]):
        acc += A[i, k] * B[j, k]
    return acc


@njit(cache=True, error_model="numpy")
def _cusum_step(C: np.ndarray, e: np.ndarray, W: np.ndarray, f: np.ndarray, shift: float) -> None:
    """Compiled step of :class:`InnovationCUSUM` (in place); a hypothesis without a signature (zero wheel
    rates) only drifts down."""
    nb, m = e.shape
    nh = f.shape[0]
    u = np.empty(m)
    for h in range(nh):
        n2 = 0.0
        for r in range(m):
            acc = _row_dot(W, r, f, h)
            u[r] = acc
            n2 += acc * acc
        n = math.sqrt(n2)
        for b in range(nb):
            z = 0.0
            if n > 0.0:
                for r in range(m):
                    z += u[r] * e[b, r]
                z /= n
            C[b, h] = max(0.0, C[b, h] + shift * z - 0.5 * shift * shift)


class JumpGLR:
    """Window-limited Willsky–Jones GLR for each hypothesis over a batch of sequences (1 online).

    The onsets of the window live in a ring of ``window`` slots; slot :attr:`pos` holds the onset of the
    latest step (lag 0), slot ``pos - j`` (mod window) lag ``j``. ``phi`` (slot, hypothesis, 5) holds the
    signatures of the estimation error and ``C`` (slot, hypothesis) the information sums (shared by the
    batch: they do not depend on the data), ``D`` (batch, slot, hypothesis) the correlation sums.
    After :meth:`step`, ``best`` (batch,) is the statistic, ``best_index`` (batch,) its flat
    (slot, hypothesis) index and ``per_hypothesis`` (batch, hypothesis) each hypothesis' maximum.
    """

    def __init__(self, window: int, batch: int = 1) -> None:
        nh = len(HYPOTHESES)
        self.window = window
        self.pos = -1
        self.phi = np.zeros((window, nh, 5))
        self.D = np.zeros((batch, window, nh))
        self.C = np.zeros((window, nh))
        self.best = np.zeros(batch)
        self.best_index = np.zeros(batch, dtype=np.int64)
        self.per_hypothesis = np.zeros((batch, nh))
        self._A_prev = np.eye(5)

    def step(self, e: np.ndarray, W: np.ndarray, F: np.ndarray, A: np.ndarray) -> np.ndarray:
        """Advance one step and return :attr:`best`.

        ``e`` (batch, m): whitened innovations; ``W = L⁻¹ H`` (m, 5); ``F`` (5, 5): Jacobian of the
        prediction into this step; ``A = I - K H`` (5, 5): the update's error propagation.
        """
        self.pos = (self.pos + 1) % self.window
        G = np.asarray(F, float) @ self._A_prev  # older onsets: through the last update, then this prediction
        _glr_step(self.phi, self.D, self.C, self.pos, np.ascontiguousarray(e, dtype=float),
                  np.ascontiguousarray(W, dtype=float), G, DIRECTIONS, self.best, self.best_index,
                  self.per_hypothesis)
        self._A_prev = np.asarray(A, float)
        return self.best

    def jump(self, index: int = 0) -> tuple[np.ndarray, float]:
        """Leading (onset, hypothesis) of batch member ``index``: the estimation error it leaves per metre of
        drop after the latest update (5,), and its information ``C`` (1/m²; ``ν̂`` has variance ``1/C``)."""
        slot, hyp = divmod(int(self.best_index[index]), len(HYPOTHESES))
        return self._A_prev @ self.phi[slot, hyp], float(self.C[slot, hyp])

    def estimate(self, index: int = 0) -> tuple[str, float, int]:
        """Leading hypothesis of batch member ``index``: its name, the drop ``ν̂ = D/C`` (m along its unit
        direction) and the lag (steps) of its onset."""
        slot, hyp = divmod(int(self.best_index[index]), len(HYPOTHESES))
        return HYPOTHESES[hyp], float(self.D[index, slot, hyp] / self.C[slot, hyp]), (self.pos - slot) % self.window


@njit(cache=True, error_model="numpy")
def _glr_step(phi: np.ndarray, D: np.ndarray, C: np.ndarray, pos: int, e: np.ndarray, W: np.ndarray,
              G: np.ndarray, f: np.ndarray, best: np.ndarray, best_index: np.ndarray, per_hyp: np.ndarray) -> None:
    """Compiled step of :class:`JumpGLR` (in place): propagate the older signatures by ``G`` (the last
    update's ``I - KH``, then this step's prediction), start the onset of this step in slot ``pos``,
    accumulate ``D``/``C`` and keep the maxima of ``D²/2C`` (``D > 0``)."""
    L, nh, d = phi.shape
    nb, m = e.shape
    for b in range(nb):
        best[b] = 0.0
        best_index[b] = 0
        for h in range(nh):
            per_hyp[b, h] = 0.0
    v = np.empty(d)
    rho = np.empty(m)
    for sl in range(L):
        for h in range(nh):
            p = phi[sl, h]
            if sl == pos:
                for i in range(d):
                    p[i] = f[h, i]
                C[sl, h] = 0.0
                for b in range(nb):
                    D[b, sl, h] = 0.0
            else:
                for i in range(d):
                    acc = 0.0
                    for j in range(d):
                        acc += G[i, j] * p[j]
                    v[i] = acc
                for i in range(d):
                    p[i] = v[i]
            c = 0.0
            for r in range(m):
                acc = 0.0
                for j in range(d):
                    acc += W[r, j] * p[j]
                rho[r] = acc
                c += acc * acc
            cs = C[sl, h] + c
            C[sl, h] = cs
            for b in range(nb):
                acc = D[b, sl, h]
                for r in range(m):
                    acc += rho[r] * e[b, r]
                D[b, sl, h] = acc
                if acc > 0.0 and cs > 0.0:
                    g = 0.5 * acc * acc / cs
                    if g > per_hyp[b, h]:
                        per_hyp[b, h] = g
                    if g > best[b]:
                        best[b] = g
                        best_index[b] = sl * nh + h


# ---------------------------------------------------------------------------- one filter step
@dataclass(frozen=True)
class Linearisation:
    """What the detectors need of one filter step."""

    e: np.ndarray
    """Whitened innovation (m,)."""
    W: np.ndarray
    """``L⁻¹ H`` (m, 5)."""
    A: np.ndarray
    """``I - K H`` with ``K = P Hᵀ R⁻¹`` (5, 5)."""


def measurement_jacobian(setup: FilterSetup, x: np.ndarray, u: np.ndarray, kinds: tuple[int, ...]) -> np.ndarray:
    """Jacobian (m, 5) of the channels ``kinds`` at state ``x`` (speed and yaw-rate rows: the model's AD
    Jacobian; position rows: unit vectors)."""
    if kinds[0] == SPEED and len(kinds) <= 2 and (len(kinds) == 1 or kinds[1] == YAW):
        return numpy_rates_jacobian(setup.model, x, u)[: len(kinds)]
    return measure_jacobian(setup.model, x[None, :], u, kinds)[0]


def linearise_step(setup: FilterSetup, x: np.ndarray, P: np.ndarray, y: np.ndarray, S: np.ndarray,
                   u: np.ndarray, used: tuple[int, ...] | None = None, H: np.ndarray | None = None
                   ) -> Linearisation | None:
    """The detectors' view of a filter step with posterior ``(x, P)``, innovation ``y`` and its covariance
    ``S`` over the channels the step used (``used``: their codes, when the caller knows them), predicted
    with wheel rates ``u`` (rad/s); ``None`` if the step carries no usable innovation (not a complete
    channel set — a channel dropped —, ``S`` not positive definite, non-finite). ``used`` keeps a step
    whose channel count matches a complete set by chance from being read as that set (a position fix
    while speed and gyro drop out has two channels, as speed + gyro has); ``H``: the step's measurement
    Jacobian when the caller has it (:func:`measurement_jacobian`)."""
    kinds = channel_kinds(setup, int(y.size))
    if kinds is None or (used is not None and tuple(used) != kinds):
        return None
    if H is None:
        H = measurement_jacobian(setup, x, u, kinds)
    m = len(kinds)
    e, W, A = np.empty(m), np.empty((m, 5)), np.empty((5, 5))
    ok = _linearise(np.asarray(P, float), np.asarray(y, float), np.asarray(S, float), H,
                    noise_variances(setup, kinds), e, W, A)
    return Linearisation(e=e, W=W, A=A) if ok else None


@njit(cache=True, error_model="numpy")
def _linearise(P: np.ndarray, y: np.ndarray, S: np.ndarray, H: np.ndarray, var: np.ndarray, e: np.ndarray,
               W: np.ndarray, A: np.ndarray) -> bool:
    """Compiled :func:`linearise_step`: lower Cholesky ``S = L Lᵀ``, ``e = L⁻¹ y``, ``W = L⁻¹ H``,
    ``A = I - P Hᵀ R⁻¹ H``; False if ``S`` is not positive definite or anything is non-finite."""
    m, d = H.shape
    L = np.zeros((m, m))
    for i in range(m):
        for j in range(i + 1):
            acc = S[i, j]
            for k in range(j):
                acc -= L[i, k] * L[j, k]
            if i == j:
                if not acc > 0.0 or not math.isfinite(acc):
                    return False
                L[i, i] = math.sqrt(acc)
            else:
                L[i, j] = acc / L[j, j]
    for i in range(m):
        acc = y[i]
        for k in range(i):
            acc -= L[i, k] * e[k]
        e[i] = acc / L[i, i]
        if not math.isfinite(e[i]):
            return False
        for c in range(d):
            acc = H[i, c]
            for k in range(i):
                acc -= L[i, k] * W[k, c]
            W[i, c] = acc / L[i, i]
    for i in range(d):
        for j in range(d):
            acc = 0.0
            for r in range(m):
                acc += _row_dot(P, i, H, r) / var[r] * H[r, j]
            A[i, j] = (1.0 if i == j else 0.0) - acc
    return True


def glr_window_steps(window: float, rate: float) -> int:
    """GLR window (filter steps) from ``decision.glr_window`` (s) at the filter ``rate`` (Hz)."""
    return max(1, int(round(window * rate)))
