"""The numpy reference implementation of the FDI filters: the maths the compiled kernels of
:mod:`ftc_mj.estimation.kernels` must reproduce (to round-off), in matrix form.

``UKFCore``/``EKFCore`` ``predict``/``update`` work on a *batch* of ``M`` filters at once (state ``X`` of
shape ``(M, 5)``, covariance ``P`` of shape ``(M, 5, 5)``): an IMM is a batch of its member filters, a
Monte-Carlo test a batch of runs. ``predict1``/``update1`` are the same formulas for one filter on
2-D arrays. Both are checked against filterpy 2.0.0 in the tests, operation for operation:

* UKF (``UnscentedKalmanFilter`` + ``JulierSigmaPoints``): sigma points ``x ± rows of U`` with
  ``UᵀU = (n+κ)P``; predict = unscented transform of the Euler step plus ``Q``; the update
  *regenerates* the sigma points from the prior ``(x⁻, P⁻)`` (filterpy 2.0 behaviour);
  ``S = Σ W (h-ẑ)(h-ẑ)ᵀ + R``, ``K = Pxz S⁻¹``, ``P⁺ = P⁻ - K S Kᵀ``.
* EKF (``ExtendedKalmanFilter`` with ``predict_x`` = Euler step and ``F`` = AD Jacobian at the
  posterior): ``P⁻ = F P Fᵀ + Q``; Joseph-form update ``P⁺ = (I-KH)P⁻(I-KH)ᵀ + K R Kᵀ``.

:class:`NumpyEKF`, :class:`NumpyUKF` and :class:`NumpyIMM` are the package's filters with the step
done by this numpy code and the numpy health layer (gating, symmetrising, repair, resets) on the same
buffers, so a test steps a compiled and a reference filter side by side.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ftc_mj.estimation.base import FilterOutput, Measurement
from ftc_mj.estimation.ekf import EKF
from ftc_mj.estimation.imm import IMM
from ftc_mj.estimation.kernels.layout import (
    C_HYP,
    C_POSE_STREAK,
    C_STEPS,
    EIG_FLOOR,
    HEADING,
    LOG_2PI,
    MU_FLOOR,
    P_RAMP_STEP,
    POS_X,
    POS_Y,
    SPEED,
    YAW,
)
from ftc_mj.estimation.measurements import channels, measure_jacobian
from ftc_mj.estimation.setup import FilterSetup
from ftc_mj.estimation.single import SingleFilter
from ftc_mj.estimation.ukf import UKF
from ftc_mj.model.kinematics import KinematicModel, body_rates, forward_speed, numpy_rates_jacobian, numpy_step_jacobian

# ---------------------------------------------------------------------------- measurements

@dataclass
class Assembled:
    """The usable measurement channels of one step."""

    z: np.ndarray
    """Measured values (m,) in the order speed, yaw rate, x, y, heading (those present and finite)."""
    r: np.ndarray
    """Noise variances (m,)."""
    kinds: tuple[int, ...]
    """Channel codes (SPEED, YAW, POS_X, POS_Y, HEADING) of the entries of ``z``."""
    dropped: bool
    """A channel that should have been there was non-finite and was dropped."""
    R: np.ndarray | None = None
    """``diag(r)`` (m, m)."""


_NOISE: dict[tuple[float, ...], tuple[np.ndarray, np.ndarray]] = {}
"""Read-only ``(r, diag(r))`` arrays by variances (a run has one or two channel sets: built once, not per step)."""


def _noise(r: list[float]) -> tuple[np.ndarray, np.ndarray]:
    key = tuple(r)
    hit = _NOISE.get(key)
    if hit is None:
        ra = np.asarray(r, float)
        Ra = np.diag(ra)
        ra.flags.writeable = False
        Ra.flags.writeable = False
        hit = (ra, Ra)
        if len(_NOISE) < 64:
            _NOISE[key] = hit
    return hit


def assemble(setup: FilterSetup, meas: Measurement) -> Assembled:
    """Collect the finite channels of ``meas`` that the configured sensor set provides."""
    z, r, kinds, dropped = channels(setup, meas)
    ra, Ra = _noise(r)
    return Assembled(np.asarray(z, float), ra, kinds, dropped, Ra)


def measure(model: KinematicModel, X: np.ndarray, u: np.ndarray, kinds: tuple[int, ...]) -> np.ndarray:
    """Predicted measurements (..., m) of states ``X`` (..., 5) for the channels ``kinds``."""
    if kinds == (SPEED,):
        return forward_speed(X[..., 3:4], X[..., 4:5], u[0], u[1])
    V, psidot = body_rates(X[..., 3], X[..., 4], u[0], u[1], model.b)
    cols = {SPEED: V, YAW: psidot, POS_X: X[..., 0], POS_Y: X[..., 1], HEADING: X[..., 2]}
    return np.stack([cols[k] for k in kinds], axis=-1)


def innovation(a: Assembled, zp: np.ndarray) -> np.ndarray:
    """``z - zp`` over the last axis, a heading's wrapped to [-π, π)."""
    y = a.z - zp
    if HEADING in a.kinds:
        i = a.kinds.index(HEADING)
        y[..., i] = y[..., i] - 2.0 * np.pi * np.floor((y[..., i] + np.pi) / (2.0 * np.pi))
    return y


def pose_gate(f: SingleFilter | IMM, X: np.ndarray, P: np.ndarray, w: np.ndarray, a: Assembled
              ) -> tuple[Assembled, bool]:
    """The χ² gate on the fix's x, y in ``a`` against the mixture (weights ``w``) of the predicted members ``X``
    (M, 5), ``P`` (M, 5, 5), with the covariance of a streak's first
    fix during a streak of rejections (begun at step ``cnt[C_POSE_STREAK] - 1``; 0: none):
    ``(a without x, y, True)`` when the position is rejected."""
    if POS_X not in a.kinds or math.isinf(f.setup.pose_gate_quantile):
        return a, False
    idx = [a.kinds.index(POS_X), a.kinds.index(POS_Y)]
    cnt, gateP = f._st.cnt, f._st.gateP
    xm = w @ X[:, :2]
    if cnt[C_POSE_STREAK] == 0:
        d = X[:, :2] - xm
        gateP[:2, :2] = np.einsum("j,jab->ab", w, P[:, :2, :2]) + (d.T * w) @ d
    y = a.z[idx] - xm
    nis = float(y @ np.linalg.solve(gateP[:2, :2] + np.diag(a.r[idx]), y))
    if nis <= f.setup.pose_gate_quantile:
        cnt[C_POSE_STREAK] = 0
        return a, False
    step = int(cnt[C_STEPS])
    if cnt[C_POSE_STREAK] and step + 1 - cnt[C_POSE_STREAK] >= f.setup.pose_gate_steps:
        cnt[C_POSE_STREAK] = 0  # the streak's end: the fix is fused
        return a, False
    if not cnt[C_POSE_STREAK]:
        cnt[C_POSE_STREAK] = step + 1
    f.pose_rejections += 1
    rest = [i for i in range(len(a.kinds)) if i not in idx]
    r = a.r[rest]
    return Assembled(a.z[rest], r, tuple(a.kinds[i] for i in rest), a.dropped, np.diag(r)), True


# ---------------------------------------------------------------------------- numerics
def symmetrise(P: np.ndarray) -> np.ndarray:
    """``(P + Pᵀ)/2`` over the last two axes."""
    return 0.5 * (P + P.swapaxes(-1, -2))


def eig_floor(P: np.ndarray, floor: float = EIG_FLOOR) -> np.ndarray:
    """Nearest symmetric matrix with eigenvalues ≥ ``floor`` (non-finite entries → identity·floor)."""
    P = np.where(np.isfinite(P), P, 0.0)
    w, V = np.linalg.eigh(symmetrise(P))
    w = np.maximum(w, floor)
    return symmetrise((V * w[..., None, :]) @ V.swapaxes(-1, -2))


def gaussian_terms(y: np.ndarray, S: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For innovations ``y`` (M, m) and covariances ``S`` (M, m, m): ``(S⁻¹, NIS, log-likelihood)``."""
    m = y.shape[-1]
    if m == 1:
        s = S[:, 0, 0]
        SI = (1.0 / s)[:, None, None]
        nis = y[:, 0] * y[:, 0] / s
        logdet = np.log(s)
    else:
        SI = np.linalg.inv(S)
        nis = np.einsum("mi,mij,mj->m", y, SI, y)
        logdet = np.linalg.slogdet(S)[1]
    ll = -0.5 * (nis + logdet + m * LOG_2PI)
    return SI, nis, ll


def chol(A: np.ndarray) -> np.ndarray:
    """Lower Cholesky factors of ``A`` (..., n, n); a matrix that is not positive definite gives NaNs
    (checked by the caller) instead of an exception.

    One batched :func:`numpy.linalg.cholesky` call (LAPACK ``potrf``); only when it refuses the batch
    are the matrices factored one by one, so that the positive definite ones keep their factor and
    the others become NaN.
    """
    try:
        return np.linalg.cholesky(A)
    except np.linalg.LinAlgError:
        pass
    flat = A.reshape(-1, *A.shape[-2:])
    L = np.full(flat.shape, np.nan)
    for i, Ai in enumerate(flat):
        try:
            L[i] = np.linalg.cholesky(Ai)
        except np.linalg.LinAlgError:
            continue
    return L.reshape(A.shape)


# ---------------------------------------------------------------------------- batched filter maths
@dataclass
class UpdateResult:
    """A computed (not yet accepted) measurement update of a batch of filters."""

    X: np.ndarray
    P: np.ndarray
    y: np.ndarray
    """Innovations (M, m)."""
    zp: np.ndarray
    """Predicted measurements (M, m)."""
    S: np.ndarray
    nis: np.ndarray
    loglik: np.ndarray


class UKFCore:
    """Batched unscented Kalman filter maths with Julier sigma points (filterpy 2.0.0 semantics)."""

    def __init__(self, setup: FilterSetup) -> None:
        self.setup = setup
        self.model = setup.model
        n = 5
        self.n = n
        self.c = n + setup.kappa
        W = np.full(2 * n + 1, 0.5 / self.c)
        W[0] = setup.kappa / self.c
        self.W = W

    def sigma_points(self, X: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Sigma points (M, 11, 5) of ``(X, P)`` and the (possibly repaired) ``P``."""
        L = chol(self.c * P)
        if not math.isfinite(L[..., -1, -1].sum()) and math.isfinite(float(P.sum())):
            P = eig_floor(P)  # finite but not PD: repair; non-finite: NaNs propagate → reset
            L = chol(self.c * P)
        U = L.swapaxes(-1, -2)  # rows of U (UᵀU = (n+κ)P), as filterpy's scipy upper Cholesky
        Xc = X[:, None, :]
        return np.concatenate((Xc, Xc + U, Xc - U), axis=1), P

    def predict(self, X: np.ndarray, P: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Unscented transform of the Euler step plus ``Q``."""
        sig, _ = self.sigma_points(X, P)
        sf = self.model.step_batch(sig, u)
        Xp = self.W @ sf
        d = sf - Xp[:, None, :]
        Pp = (d.swapaxes(1, 2) * self.W) @ d + self.setup.Q
        return Xp, Pp

    def update(self, X: np.ndarray, P: np.ndarray, u: np.ndarray, a: Assembled) -> UpdateResult:
        """Measurement update from sigma points regenerated at the prior (filterpy 2.0)."""
        sig, P = self.sigma_points(X, P)
        sh = measure(self.model, sig, u, a.kinds)  # (M, 11, m)
        zp = self.W @ sh
        dz = sh - zp[:, None, :]
        dzT_W = dz.swapaxes(1, 2) * self.W
        S = dzT_W @ dz + a.R
        Pxz = ((sig - X[:, None, :]).swapaxes(1, 2) * self.W) @ dz
        y = innovation(a, zp)
        SI, nis, ll = gaussian_terms(y, S)
        K = Pxz @ SI
        Xn = X + (K @ y[:, :, None])[:, :, 0]
        Pn = P - K @ (S @ K.swapaxes(1, 2))
        return UpdateResult(Xn, Pn, y, zp, S, nis, ll)

    # ---------------------------------------------------------------- one filter (2-D arrays)
    def predict1(self, x: np.ndarray, P: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`predict` for one filter, ``x`` (5,), ``P`` (5, 5): same maths, fewer numpy calls."""
        sig, _ = self.sigma_points1(x, P)
        sf = self.model.step_batch(sig, u)
        W = self.W
        xp = W.dot(sf)
        d = sf - xp
        return xp, (d.T * W).dot(d) + self.setup.Q

    def sigma_points1(self, x: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Sigma points (11, 5) of one filter and the (possibly repaired) ``P``."""
        L = chol(self.c * P)
        if not math.isfinite(L[-1, -1]) and math.isfinite(float(P.sum())):
            P = eig_floor(P)
            L = chol(self.c * P)
        U = L.T
        return np.concatenate((x[None, :], x + U, x - U)), P

    def update1(
        self, x: np.ndarray, P: np.ndarray, u: np.ndarray, a: Assembled
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
        """:meth:`update` for one filter: ``(x⁺, P⁺, y, S, NIS)``."""
        sig, P = self.sigma_points1(x, P)
        sh = measure(self.model, sig, u, a.kinds)  # (11, m)
        W = self.W
        zp = W.dot(sh)
        dz = sh - zp
        S = (dz.T * W).dot(dz) + a.R
        Pxz = ((sig - x).T * W).dot(dz)
        y = innovation(a, zp)
        if y.shape[0] == 1:
            s = S[0, 0]
            K = Pxz / s
            nis = float(y[0] * y[0] / s)
        else:
            SI = np.linalg.inv(S)
            K = Pxz.dot(SI)
            nis = float(y.dot(SI).dot(y))
        return x + K.dot(y), P - K.dot(S).dot(K.T), y, S, nis


class EKFCore:
    """Batched extended Kalman filter maths (filterpy 2.0.0 semantics, Joseph-form update)."""

    def __init__(self, setup: FilterSetup) -> None:
        self.setup = setup
        self.model = setup.model
        self.eye = np.eye(5)

    def predict(self, X: np.ndarray, P: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``F`` (AD Jacobian at the posterior), Euler step, ``P⁻ = F P Fᵀ + Q``."""
        F = numpy_step_jacobian(self.model, X, u, self.setup.dt)
        Xp = self.model.step_batch(X, u)
        Pp = F @ P @ F.swapaxes(1, 2) + self.setup.Q
        return Xp, Pp

    def update(self, X: np.ndarray, P: np.ndarray, u: np.ndarray, a: Assembled) -> UpdateResult:
        """Linearised update at the prior, Joseph form."""
        H = measure_jacobian(self.model, X, u, a.kinds)
        HT = H.swapaxes(1, 2)
        PHT = P @ HT
        R = a.R
        S = H @ PHT + R
        zp = measure(self.model, X, u, a.kinds)
        y = innovation(a, zp)
        SI, nis, ll = gaussian_terms(y, S)
        K = PHT @ SI
        Xn = X + (K @ y[:, :, None])[:, :, 0]
        I_KH = self.eye - K @ H
        Pn = I_KH @ P @ I_KH.swapaxes(1, 2) + K @ R @ K.swapaxes(1, 2)
        return UpdateResult(Xn, Pn, y, zp, S, nis, ll)

    # ---------------------------------------------------------------- one filter (2-D arrays)
    def predict1(self, x: np.ndarray, P: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`predict` for one filter, ``x`` (5,), ``P`` (5, 5)."""
        F = numpy_step_jacobian(self.model, x, u, self.setup.dt)
        return self.model.step_batch(x, u), F.dot(P).dot(F.T) + self.setup.Q

    def update1(
        self, x: np.ndarray, P: np.ndarray, u: np.ndarray, a: Assembled
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
        """:meth:`update` for one filter: ``(x⁺, P⁺, y, S, NIS)``."""
        kinds = a.kinds
        if kinds == (SPEED,) or kinds == (SPEED, YAW):
            H = numpy_rates_jacobian(self.model, x, u)[: len(kinds)]
        else:
            H = measure_jacobian(self.model, x[None, :], u, kinds)[0]
        PHT = P.dot(H.T)
        R = a.R
        S = H.dot(PHT) + R
        y = innovation(a, measure(self.model, x, u, kinds))
        SI = 1.0 / S if len(kinds) == 1 else np.linalg.inv(S)
        K = PHT.dot(SI)
        I_KH = self.eye - K.dot(H)
        Pn = I_KH.dot(P).dot(I_KH.T) + K.dot(R).dot(K.T)
        return x + K.dot(y), Pn, y, S, float(y.dot(SI).dot(y))


def make_core(setup: FilterSetup, member: str) -> UKFCore | EKFCore:
    """``member`` is ``"ukf"`` or ``"ekf"``."""
    if member == "ukf":
        return UKFCore(setup)
    if member == "ekf":
        return EKFCore(setup)
    raise ValueError(f"unknown filter member kind {member!r}")


def healthy(X: np.ndarray, P: np.ndarray) -> bool:
    """Finite state and covariance with a positive diagonal (cheap test, every step)."""
    return math.isfinite(float(X.sum()) + float(P.sum())) and float(P.diagonal(0, -2, -1).min()) > 0.0


# ---------------------------------------------------------------------------- filters with the numpy step
def nis_dwell(f: SingleFilter | IMM, nis: float) -> bool:
    """Count ``f``'s steps with NIS above the divergence level; True once they last ``divergence_dwell``."""
    if math.isfinite(nis) and nis > f.setup.divergence_nis:
        f._bad_nis_steps += 1
    elif math.isfinite(nis):
        f._bad_nis_steps = 0
    return f._bad_nis_steps >= f.setup.divergence_steps


_EMPTY_Y = np.zeros(0)
_EMPTY_S = np.zeros((0, 0))


class _NumpySingle(SingleFilter):
    """A single filter whose step is the numpy reference (same buffers, same health rules)."""

    def __init__(self, setup: FilterSetup) -> None:
        super().__init__(setup)
        self.core: UKFCore | EKFCore = make_core(setup, self.member)
        self._u_last = np.zeros(2)
        # the UKF's next Cholesky repairs a non-PD covariance itself; the EKF checks every step
        self._check_pd = isinstance(self.core, EKFCore)

    def _inputs(self, u: np.ndarray) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        if u.shape != (2,):
            u = u.reshape(2)
        if math.isfinite(u[0] + u[1]):
            self._u_last = u
            return u
        return self._u_last

    def step(self, u: np.ndarray, z: Measurement) -> FilterOutput:
        return self._step_numpy(u, z)

    def _step_numpy(self, u: np.ndarray, z: Measurement) -> FilterOutput:
        u = self._inputs(u)
        x_prev = self._x.copy()
        core = self.core
        x, P = core.predict1(x_prev, self._P, u)
        a, pose_rejected = pose_gate(self, x[None, :], P[None, :, :], np.ones(1), assemble(self.setup, z))
        rejected = a.dropped
        nis = sp_innov = sp_std = math.nan
        if a.z.size:
            xn, Pn, y, S, nis = core.update1(x, P, u, a)
            if a.kinds[0] == SPEED:
                sp_innov, sp_std = float(y[0]), math.sqrt(max(float(S[0, 0]), 0.0))
            if nis <= self.setup.nis_gate:  # False for NaN
                x, P = xn, Pn
            else:
                rejected = True
        else:
            y, S = _EMPTY_Y, _EMPTY_S
        P = 0.5 * (P + P.T)
        reset = self._check_divergence(x, P, nis)
        if reset:
            x, P = self._reset_state(x_prev)
        elif self._check_pd and math.isnan(chol(P)[-1, -1]):
            P = eig_floor(P)
        self._x[:], self._P[:] = x, P
        if rejected:
            self.rejections += 1
        self.t_steps += 1
        return FilterOutput(
            x=x.copy(), P=P.copy(), innovation=y, S=S, nis=nis,
            speed_innovation=sp_innov, speed_innovation_std=sp_std, rejected=rejected, reset=reset,
            pose_rejected=pose_rejected,
        )

    def _check_divergence(self, X: np.ndarray, P: np.ndarray, nis: float) -> bool:
        return True if not healthy(X, P) else nis_dwell(self, nis)

    def _reset_state(self, x_prev: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        self.resets += 1
        self._bad_nis_steps = 0
        x = x_prev.copy() if np.all(np.isfinite(x_prev)) else self.setup.x0.copy()
        R0 = self.setup.nominal_radius
        x[3:5] = np.clip(x[3:5], self.setup.min_radius, 10.0 * R0)
        return x, self.setup.reset_inflation * self.setup.P0.copy()


class NumpyEKF(_NumpySingle, EKF):
    """:class:`~ftc_mj.estimation.EKF` stepped by the numpy reference."""


class NumpyUKF(_NumpySingle, UKF):
    """:class:`~ftc_mj.estimation.UKF` stepped by the numpy reference."""


class NumpyIMM(IMM):
    """:class:`~ftc_mj.estimation.IMM` stepped by the numpy reference (same buffers and constants)."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        self.core: UKFCore | EKFCore = make_core(self.setup, self.member)
        st = self._st
        self._hyp = bool(st.cnt[C_HYP])
        self._pin = st.pin != 0.0
        self._pin_value = st.pin_value
        self._keep, self._reset_var = st.keep, st.reset_var
        self._ramp = st.ramp != 0.0
        self._ramp_step = float(st.prm[P_RAMP_STEP])
        self._u_last = np.zeros(2)

    def step(self, u: np.ndarray, z: Measurement) -> FilterOutput:
        return self._step_numpy(u, z)

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
        a, pose_rejected = pose_gate(self, Xp, Pp, cbar, assemble(self.setup, z))
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
            y = innovation(a, zbar)
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
        self._st.cnt[C_STEPS] += 1
        return FilterOutput(
            x=self.x.copy(), P=self.P_comb.copy(), innovation=np.array(y, float), S=np.array(S, float),
            nis=nis, speed_innovation=sp_innov, speed_innovation_std=sp_std,
            mode_probs=self.mu.copy(), hypotheses=self.hypotheses, model_x=self.X.copy(), rejected=rejected,
            reset=reset, pose_rejected=pose_rejected,
        )

    def _check_divergence(self, X: np.ndarray, P: np.ndarray, nis: float) -> bool:
        return True if not math.isfinite(float(X.sum()) + float(P.sum())) else nis_dwell(self, nis)

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
