"""Shared machinery of the FDI filters: configuration, measurement assembly, batched EKF/UKF maths.

This module is the numpy *reference* implementation; the filters step through the compiled kernels
of :mod:`._kernels` (the same maths, one call per step) unless built with ``backend="numpy"``, and the
tests require both to agree to round-off. :class:`FilterBuffers` holds a filter bank's state in the
flat arrays both backends read and write.

``predict``/``update`` work on a *batch* of ``M`` filters at once (state ``X`` of shape ``(M, 5)``,
covariance ``P`` of shape ``(M, 5, 5)``): an IMM is a batch of its member filters (all their sigma
points go through the kinematic model in one numpy call), a Monte-Carlo study a batch of runs.
``predict1``/``update1`` are the same formulas for one filter on 2-D arrays (fewer and cheaper numpy
calls; the single EKF/UKF use them). Both paths are checked against filterpy in the tests.

The maths is filterpy 2.0.0's, operation for operation, so that the tests can compare to round-off:

* UKF (``UnscentedKalmanFilter`` + ``JulierSigmaPoints``): sigma points ``x ± rows of U`` with
  ``UᵀU = (n+κ)P``; predict = unscented transform of the Euler step plus ``Q``; the update
  *regenerates* the sigma points from the prior ``(x⁻, P⁻)`` (filterpy 2.0 behaviour);
  ``S = Σ W (h-ẑ)(h-ẑ)ᵀ + R``, ``K = Pxz S⁻¹``, ``P⁺ = P⁻ - K S Kᵀ``.
* EKF (``ExtendedKalmanFilter`` with ``predict_x`` = Euler step and ``F`` = AD Jacobian at the
  posterior): ``P⁻ = F P Fᵀ + Q``; Joseph-form update ``P⁺ = (I-KH)P⁻(I-KH)ᵀ + K R Kᵀ``.

Jacobians come from CasADi's automatic differentiation of the single model definition, transcribed
once to numpy (:func:`ftc_mj.model.kinematics.casadi_to_numpy`), so no equation is typed twice.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..config import EstimatorConfig, RunConfig, SensorConfig, section
from ..model.kinematics import (
    KinematicModel,
    body_rates,
    forward_speed,
    numpy_rates_jacobian,
    numpy_step_jacobian,
)
from ._kernels import (
    C_BAD_NIS,
    C_DIV_STEPS,
    C_EKF,
    C_N,
    C_REJECTIONS,
    C_RESETS,
    EIG_FLOOR,
    LOG_2PI,
    N_COUNTERS,
    N_PRM,
    P_B,
    P_DIV_NIS,
    P_DT,
    P_GATE,
    P_INFLATION,
    P_KAPPA,
    P_MIN_RADIUS,
    P_R0,
    POS_X,
    POS_Y,
    SPEED,
    YAW,
    layout,
)
from .base import Measurement

BACKENDS = ("numba", "numpy")
DEFAULT_BACKEND = "numba"
"""Backend of filters built without ``backend=``: ``"numba"`` (compiled kernels) or ``"numpy"`` (reference)."""


def resolve_backend(backend: str | None) -> str:
    """``backend`` or the module default, checked."""
    b = DEFAULT_BACKEND if backend is None else backend
    if b not in BACKENDS:
        raise ValueError(f"unknown filter backend {b!r} (expected one of {BACKENDS})")
    return b


@dataclass(frozen=True)
class FilterSetup:
    """Resolved parameters (SI units) of one filter, from a :class:`RunConfig` or its own settings."""

    model: KinematicModel
    dt: float
    """Filter step (s)."""
    x0: np.ndarray
    """Initial state [x, y, psi, R_R, R_L] (m, m, rad, m, m)."""
    P0: np.ndarray
    Q: np.ndarray
    nominal_radius: float
    """Model's nominal wheel radius R0 (m)."""
    speed_sigma: float
    yaw_rate_sigma: float | None
    position_sigma: float | None
    kappa: float
    nis_gate: float
    divergence_nis: float
    divergence_steps: int
    reset_inflation: float
    min_radius: float

    @classmethod
    def from_config(cls, cfg: RunConfig) -> FilterSetup:
        """The filter of a run: ``cfg.estimator``, ``cfg.sensors``, the model's nominal wheel radius and
        half track, starting at ``cfg.plant.initial_pose``."""
        return cls.from_settings(cfg.estimator, cfg.sensors, wheel_radius=cfg.model_wheel_radius,
                                 half_track=cfg.model_half_track, initial_pose=cfg.plant.initial_pose)

    @classmethod
    def from_settings(cls, estimator: EstimatorConfig | Mapping[str, Any] | None = None,
                      sensors: SensorConfig | Mapping[str, Any] | None = None, *, wheel_radius: float = 2.0,
                      half_track: float = 1.0, initial_pose: Sequence[float] = (0.0, 0.0, 0.0)) -> FilterSetup:
        """A filter from its own settings, without a run config.

        Parameters
        ----------
        estimator, sensors
            The ``[estimator]`` and ``[sensors]`` sections (objects or plain tables, validated with
            their one-line errors; ``None`` = the paper's values: the paper's ``Q`` and ``P0``, speed
            σ 0.5 m/s, no gyro, no position fix).
        wheel_radius, half_track
            Nominal wheel radius ``R0`` and half track ``b`` of the kinematic model (m).
        initial_pose
            ``(x, y, psi)`` the estimate starts from (m, m, rad).
        """
        est = section(EstimatorConfig, estimator, "estimator")
        sen = section(SensorConfig, sensors, "sensors")
        dt = 1.0 / est.rate
        R0 = float(wheel_radius)
        radii = est.initial_radii if est.initial_radii is not None else (R0, R0)
        x0 = np.array([*initial_pose, radii[0], radii[1]], dtype=float)
        return cls(
            model=KinematicModel(b=float(half_track), dt=dt),
            dt=dt,
            x0=x0,
            P0=np.diag(np.square(np.asarray(est.p0_sigma, float))),
            Q=np.diag(np.square(np.asarray(est.q_rate, float) * dt)),
            nominal_radius=R0,
            speed_sigma=sen.speed_sigma,
            yaw_rate_sigma=sen.yaw_rate_sigma,
            position_sigma=sen.position_sigma,
            kappa=est.kappa,
            nis_gate=est.nis_gate,
            divergence_nis=est.divergence_nis,
            divergence_steps=max(1, int(round(est.divergence_dwell * est.rate))),
            reset_inflation=est.reset_inflation,
            min_radius=est.min_radius,
        )


# ---------------------------------------------------------------------------- measurements

@dataclass
class Assembled:
    """The usable measurement channels of one step."""

    z: np.ndarray
    """Measured values (m,) in the order speed, yaw rate, x, y (those present and finite)."""
    r: np.ndarray
    """Noise variances (m,)."""
    kinds: tuple[int, ...]
    """Channel codes (SPEED, YAW, POS_X, POS_Y) of the entries of ``z``."""
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


_SPEED_ONLY = (SPEED,)


def channels(setup: FilterSetup, meas: Measurement) -> tuple[list[float], list[float], tuple[int, ...], bool]:
    """The finite channels of ``meas`` that the configured sensor set provides: values (SI units), noise
    variances, channel codes (in the order speed, yaw rate, x, y), and whether a channel that should have
    been there was non-finite and dropped."""
    if setup.yaw_rate_sigma is None and setup.position_sigma is None:  # speed sensor only (the paper's set)
        v = meas.speed
        if v is not None and type(v) is float and math.isfinite(v):
            return [v], [setup.speed_sigma * setup.speed_sigma], _SPEED_ONLY, False
    z: list[float] = []
    r: list[float] = []
    kinds: list[int] = []
    dropped = False

    def add(value: float | None, sigma: float, kind: int) -> None:
        nonlocal dropped
        if value is None:
            return
        try:
            v = float(value)
        except (TypeError, ValueError):
            dropped = True
            return
        if not math.isfinite(v):
            dropped = True
            return
        z.append(v)
        r.append(sigma * sigma)
        kinds.append(kind)

    add(meas.speed, setup.speed_sigma, SPEED)
    if setup.yaw_rate_sigma is not None:
        add(meas.yaw_rate, setup.yaw_rate_sigma, YAW)
    if setup.position_sigma is not None and meas.position is not None:
        pos = np.asarray(meas.position, dtype=float).ravel()
        if pos.size != 2 or not np.all(np.isfinite(pos)):
            dropped = True
        else:
            add(pos[0], setup.position_sigma, POS_X)
            add(pos[1], setup.position_sigma, POS_Y)
    return z, r, tuple(kinds), dropped


def assemble(setup: FilterSetup, meas: Measurement) -> Assembled:
    """Collect the finite channels of ``meas`` that the configured sensor set provides."""
    z, r, kinds, dropped = channels(setup, meas)
    ra, Ra = _noise(r)
    return Assembled(np.asarray(z, float), ra, kinds, dropped, Ra)


def kernel_inputs(
    setup: FilterSetup, u: np.ndarray, meas: Measurement
) -> tuple[float, float, float, float, float, float, int, bool]:
    """Per-step arguments of a compiled step (:mod:`._kernels`) after its two buffers: wheel rates
    ``u0, u1`` (rad/s), the channel values ``z0..z3`` (first ``m`` used, zero padded), the channel
    bit mask and the dropped flag. Plain scalars: cheaper to pass to numba than small arrays."""
    u = np.asarray(u, dtype=float)
    u0, u1 = (u if u.shape == (2,) else u.reshape(2)).tolist()
    z, _, kinds, dropped = channels(setup, meas)
    z0, z1, z2, z3 = (*z, 0.0, 0.0, 0.0, 0.0)[:4]
    return u0, u1, z0, z1, z2, z3, kinds_mask(kinds), dropped


_MASKS: dict[tuple[int, ...], int] = {}


def kinds_mask(kinds: tuple[int, ...]) -> int:
    """Bit mask of channel codes (bit k = code k), the compiled kernels' form of ``Assembled.kinds``."""
    mask = _MASKS.get(kinds)
    if mask is None:
        mask = _MASKS[kinds] = sum(1 << k for k in kinds)
    return mask


def measure(model: KinematicModel, X: np.ndarray, u: np.ndarray, kinds: tuple[int, ...]) -> np.ndarray:
    """Predicted measurements (..., m) of states ``X`` (..., 5) for the channels ``kinds``."""
    if kinds == (SPEED,):
        return forward_speed(X[..., 3:4], X[..., 4:5], u[0], u[1])
    V, psidot = body_rates(X[..., 3], X[..., 4], u[0], u[1], model.b)
    cols = {SPEED: V, YAW: psidot, POS_X: X[..., 0], POS_Y: X[..., 1]}
    return np.stack([cols[k] for k in kinds], axis=-1)


def measure_jacobian(model: KinematicModel, X: np.ndarray, u: np.ndarray, kinds: tuple[int, ...]) -> np.ndarray:
    """Measurement Jacobian (M, m, 5) at states ``X`` (M, 5), from the AD rates Jacobian."""
    Hr = numpy_rates_jacobian(model, X, u)  # (M, 2, 5): rows d V/dx, d psidot/dx
    M = X.shape[0]
    H = np.zeros((M, len(kinds), 5))
    for row, k in enumerate(kinds):
        if k in (SPEED, YAW):
            H[:, row, :] = Hr[:, k, :]
        else:
            H[:, row, k - POS_X] = 1.0
    return H


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
        y = a.z - zp
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
        y = a.z - zp
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
        y = a.z - zp
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
        y = a.z - measure(self.model, x, u, kinds)
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


# ---------------------------------------------------------------------------- state storage
class FilterBuffers:
    """State, constants and per-step outputs of a bank of ``n`` filters in two flat arrays.

    ``buf`` (float64, offsets :func:`._kernels.layout`) and ``cnt`` (int64, indices ``C_*``) are what a
    compiled step reads and writes; the attributes are views of ``buf`` (see :func:`._kernels.layout`):
    ``X`` (n, 5), ``P`` (n, 5, 5), ``mu``, ``loglik`` (n,), ``x`` (5,), ``Pc`` (5, 5), ``y`` (4,), ``S`` (4, 4),
    ``ulast`` (2,), the constants ``Q``, ``P0``, ``x0``, ``rvar`` (noise variance by channel code), ``Pi``
    (n, n), ``pin_value``/``pin`` (n, 2), ``keep``/``reset_var`` (n, 5, 5), ``ramp`` (n,) and ``prm``.
    """

    def __init__(self, setup: FilterSetup, n: int, member: str) -> None:
        lay = layout(n)
        self.n = n
        self.buf = np.zeros(lay.size)
        self.cnt = np.zeros(N_COUNTERS, dtype=np.int64)

        def view(offset: int, *shape: int) -> np.ndarray:
            return self.buf[offset:offset + math.prod(shape)].reshape(shape)

        self.X, self.P = view(lay.X, n, 5), view(lay.P, n, 5, 5)
        self.mu, self.loglik = view(lay.mu, n), view(lay.loglik, n)
        self.x, self.Pc = view(lay.x, 5), view(lay.Pc, 5, 5)
        self.y, self.S, self.ulast = view(lay.y, 4), view(lay.S, 4, 4), view(lay.ulast, 2)
        self.Q, self.P0, self.x0 = view(lay.Q, 5, 5), view(lay.P0, 5, 5), view(lay.x0, 5)
        self.rvar, self.Pi = view(lay.rvar, 4), view(lay.Pi, n, n)
        self.pin_value, self.pin = view(lay.pin_value, n, 2), view(lay.pin, n, 2)
        self.keep, self.reset_var = view(lay.keep, n, 5, 5), view(lay.reset_var, n, 5, 5)
        self.ramp, self.prm = view(lay.ramp, n), view(lay.prm, N_PRM)
        # the innovation and its covariance over m channels, by m (views made once, not per step)
        self.y_of = [self.y[:m] for m in range(5)]
        self.S_of = [self.S[:m, :m] for m in range(5)]
        self.Q[:], self.P0[:], self.x0[:] = setup.Q, setup.P0, setup.x0
        # variances as assemble() computes them (sigma * sigma)
        for code, sigma in ((SPEED, setup.speed_sigma), (YAW, setup.yaw_rate_sigma),
                            (POS_X, setup.position_sigma), (POS_Y, setup.position_sigma)):
            self.rvar[code] = math.nan if sigma is None else sigma * sigma
        prm = self.prm
        prm[P_DT], prm[P_B], prm[P_KAPPA] = setup.dt, setup.model.b, setup.kappa
        prm[P_GATE], prm[P_DIV_NIS] = setup.nis_gate, setup.divergence_nis
        prm[P_INFLATION], prm[P_MIN_RADIUS], prm[P_R0] = setup.reset_inflation, setup.min_radius, setup.nominal_radius
        self.cnt[C_DIV_STEPS] = setup.divergence_steps
        self.cnt[C_EKF] = member == "ekf"
        self.cnt[C_N] = n


class Counter:
    """Attribute that is the integer ``self._st.cnt[index]`` (counted by the compiled steps)."""

    def __init__(self, index: int, doc: str = "") -> None:
        self.index = index
        self.__doc__ = doc

    def __get__(self, obj: object, objtype: type | None = None) -> int:
        return int(obj._st.cnt[self.index])  # type: ignore[union-attr]

    def __set__(self, obj: object, value: int) -> None:
        obj._st.cnt[self.index] = value  # type: ignore[attr-defined]


class BufferView:
    """Attribute that is the view ``self._st.<name>`` of a filter's buffers: reading gives the live
    array (it changes with every step), assigning copies the value into it (shape-checked)."""

    def __init__(self, name: str, doc: str = "") -> None:
        self.name = name
        self.__doc__ = doc

    def __get__(self, obj: object, objtype: type | None = None) -> np.ndarray:
        return getattr(obj._st, self.name)  # type: ignore[union-attr]

    def __set__(self, obj: object, value: np.ndarray) -> None:
        view = getattr(obj._st, self.name)  # type: ignore[attr-defined]
        view[...] = np.asarray(value, dtype=float).reshape(view.shape)


class HealthCounters:
    """``resets``/``rejections`` (and the internal NIS-dwell counter) kept in ``self._st.cnt``, where the
    compiled steps count them."""

    _st: FilterBuffers
    resets = Counter(C_RESETS, "Divergence resets so far.")
    rejections = Counter(C_REJECTIONS, "Steps whose measurement was rejected (non-finite channel, NIS above gate).")
    _bad_nis_steps = Counter(C_BAD_NIS, "Consecutive steps with NIS above the divergence level.")
