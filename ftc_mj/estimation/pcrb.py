"""The posterior Cramér–Rao bound (PCRB) of ``[x, y, psi, R_R, R_L]`` along a run's true trajectory.

For the model the filters assume, ``x_k = f(x_{k-1}, u_{k-1}) + w_k`` with ``w_k ~ N(0, Q)``,
``z_k = h(x_k, u_k) + v_k`` with ``v_k ~ N(0, R_k)`` and the prior ``x ~ N(x̄, P0)``, every estimator
``x̂_k`` of ``x_k`` from ``z_0 … z_k`` satisfies ``E[(x̂_k - x_k)(x̂_k - x_k)ᵀ] ⪰ J_k⁻¹``, where the
Bayesian information ``J_k`` follows the recursion of Tichavský, Muravchik & Nehorai (1998) for
additive Gaussian noise::

    J_k = D22 - D21 (J_{k-1} + D11)⁻¹ D12,
    D11 = Fᵀ Q⁻¹ F,   D12 = D21ᵀ = -Fᵀ Q⁻¹,   D22 = Q⁻¹ + Hᵀ R⁻¹ H,

with ``F = ∂f/∂x`` at ``x_{k-1}`` and ``H = ∂h/∂x`` at ``x_k`` (expectations over the trajectory,
evaluated here along the true one). By the matrix-inversion lemma this is
``J_k = (Q + F J_{k-1}⁻¹ Fᵀ)⁻¹ + Hᵀ R⁻¹ H`` — the Kalman filter's Riccati recursion in information
form — and it is computed in covariance form, ``B = J⁻¹``::

    P⁻ = F B_{k-1} Fᵀ + Q,    B_k = P⁻ - P⁻Hᵀ (H P⁻ Hᵀ + R)⁻¹ H P⁻,

which also holds for a singular ``Q`` (radii known to be constant). Evaluating the Jacobians on the
true trajectory is exact where they do not depend on the state: the speed and yaw-rate rows of
``H`` depend on the wheel rates only, and the radius rows of ``F`` are the identity, so with those
sensors the radius block of the bound is exact; pose fixes (position and heading) couple it to the pose
through ``F``'s dependence on ``psi`` and the radii.

The robot's Jacobians come from the one model definition (:mod:`ftc_mj.model.kinematics`, CasADi
automatic differentiation). The time convention mirrors the filters: the bound at trace row ``k``
follows ``k + 1`` predictions and updates, the prediction into row ``k`` linearised at the true state
and wheel rates of row ``k - 1`` (row 0 for the first), the update at those of row ``k``, so that
for a linear model the bound *is* the filter's covariance.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..lazy import lazy_module
from ..model.kinematics import KinematicModel, numpy_rates_jacobian, numpy_step_jacobian
from .observability import radius_directions
from .setup import FilterSetup

scipy = lazy_module("scipy")  # imported on first use (ftc_mj.lazy)

STATE_COLUMNS = ("x", "y", "psi", "R_R", "R_L")
PCRB_COLUMNS = ("R_R_pcrb_std", "R_L_pcrb_std", "radius_split_pcrb_std", "R_R_pcrb_const_std", "R_L_pcrb_const_std")
"""Trace columns of the bounds: σ (m) of each radius and of the radius split along the direction the
speed cannot observe (:func:`~ftc_mj.estimation.observability.radius_directions`) for the filters' own
random-walk model, and σ (m) of each radius for the model that made the data (``*_pcrb_const_std``:
radii constant between the truth's changes, each change a jump of known time, :func:`data_model_bound`)."""


def information_bound(
    F: np.ndarray, H: Sequence[np.ndarray], R: Sequence[np.ndarray], Q: np.ndarray, P0: np.ndarray
) -> np.ndarray:
    """The bound ``B_k = J_k⁻¹`` of every step of a linearised model (see the module docstring).

    Parameters
    ----------
    F : (n, d, d) array
        State-transition Jacobian of the prediction into step ``k``.
    H : sequence of n arrays (m_k, d)
        Measurement Jacobian at step ``k`` (``m_k = 0``: no measurement).
    R : sequence of n arrays (m_k, m_k)
        Measurement-noise covariance at step ``k`` (units of the measurement squared).
    Q : (d, d) array
        Process-noise covariance per step (may be singular).
    P0 : (d, d) array
        Prior covariance before the first prediction.

    Returns
    -------
    (n, d, d) array
        ``B_k``, a lower bound on the error covariance of any estimator of ``x_k``.
    """
    n, d = F.shape[0], F.shape[1]
    mmax = max((h.shape[0] for h in H), default=0)
    Hp = np.zeros((n, mmax, d))
    Rp = np.zeros((n, mmax, mmax))
    m = np.zeros(n, dtype=np.int64)
    for k in range(n):
        mk = H[k].shape[0]
        m[k] = mk
        Hp[k, :mk] = H[k]
        Rp[k, :mk, :mk] = R[k]
    out = np.empty((n, d, d))
    _riccati(np.ascontiguousarray(F, dtype=float), Hp, m, Rp, np.asarray(Q, float), np.asarray(P0, float), out)
    return out


def _riccati(F: np.ndarray, H: np.ndarray, m: np.ndarray, R: np.ndarray, Q: np.ndarray, P0: np.ndarray,
             out: np.ndarray) -> None:
    """Covariance-form recursion of :func:`information_bound` (``H``, ``R`` padded to the largest channel
    count, ``m[k]`` channels used at step ``k``), in numpy with LAPACK's ``dgesv`` for the gain.

    About 16 µs a step (a 40 s trace's two bounds, 8000 steps: ≈ 0.13 s). A numba version ran at 2.4 µs a
    step with bitwise the same bounds (the same BLAS and LAPACK calls) but cost a fresh install 5.7–9.6 s
    of compiling in its first run, most of it numba's code for ``np.linalg.solve``'s shape errors; the
    first run is the one a new user waits for.
    """
    B = P0.copy()
    FT, HT = F.transpose(0, 2, 1), H.transpose(0, 2, 1)
    for k, mk in enumerate(m.tolist()):
        Pm = F[k] @ B @ FT[k] + Q
        if mk > 0:
            PHt = Pm @ HT[k, :, :mk]
            S = H[k, :mk] @ PHt + R[k, :mk, :mk]
            _, _, gain_t, info = scipy.linalg.lapack.dgesv(S, PHt.T)  # S⁻¹ (P Hᵀ)ᵀ
            if info != 0:
                raise np.linalg.LinAlgError(f"PCRB step {k}: singular innovation covariance (dgesv info {info})")
            B = Pm - PHt @ gain_t
        else:
            B = Pm
        B = 0.5 * (B + B.T)
        out[k] = B


@dataclass(frozen=True)
class TraceLinearisation:
    """Jacobians and noise of the filters' model along a trace's true trajectory."""

    F: np.ndarray
    """(n, 5, 5) prediction Jacobians."""
    H: list[np.ndarray]
    """Per row, (m_k, 5) Jacobian of the channels measured at that row (speed, yaw rate, x, y)."""
    R: list[np.ndarray]
    """Per row, (m_k, m_k) noise covariance of those channels."""
    omega: np.ndarray
    """(n, 2) true wheel rates (rad/s)."""


def linearise_trace(setup: FilterSetup, trace: dict[str, np.ndarray]) -> TraceLinearisation:
    """Jacobians of the kinematic model at the true states and wheel rates of every row of ``trace``.

    A channel enters row ``k`` when the trace holds a finite measurement of it there: ``v_meas`` (speed),
    ``yaw_rate_meas`` (gyro), ``x_meas``/``y_meas`` (position fix) and, with a fix, its heading when ``setup``
    has a heading σ (the filters fuse it: :mod:`.measurements`). Noise levels are the configured sensor σ of
    ``setup``, the model is the filters' (its half track and step).
    """
    model: KinematicModel = setup.model
    X = np.column_stack([np.asarray(trace[c], float) for c in STATE_COLUMNS])
    U = np.column_stack([np.asarray(trace["omega_R"], float), np.asarray(trace["omega_L"], float)])
    n = X.shape[0]
    prev = np.maximum(np.arange(n) - 1, 0)
    F = numpy_step_jacobian(model, X[prev], U[prev], setup.dt)
    Hr = numpy_rates_jacobian(model, X, U)  # (n, 2, 5): rows dV/dx, dψ̇/dx
    rows = [Hr[:, 0]]
    present = [np.isfinite(np.asarray(trace["v_meas"], float))]
    sig = [setup.speed_sigma]
    if setup.yaw_rate_sigma is not None:
        rows.append(Hr[:, 1])
        present.append(np.isfinite(np.asarray(trace["yaw_rate_meas"], float)))
        sig.append(setup.yaw_rate_sigma)
    if setup.position_sigma is not None:
        fix = np.isfinite(np.asarray(trace["x_meas"], float)) & np.isfinite(np.asarray(trace["y_meas"], float))
        for i in (0, 1):
            rows.append(np.broadcast_to(np.eye(5)[i], (n, 5)))
            present.append(fix)
            sig.append(setup.position_sigma)
        if setup.heading_sigma is not None:  # the fix's heading, fused by the filters with the position
            rows.append(np.broadcast_to(np.eye(5)[2], (n, 5)))
            present.append(fix)
            sig.append(setup.heading_sigma)
    allrows = np.stack(rows, axis=1)  # (n, channels, 5)
    var = np.square(np.asarray(sig, float))
    mask = np.column_stack(present)
    H = [allrows[k, mask[k]] for k in range(n)]
    R = [np.diag(var[mask[k]]) for k in range(n)]
    return TraceLinearisation(F, H, R, U)


def trace_pcrb(
    setup: FilterSetup, trace: dict[str, np.ndarray], *, q_radius: float | None = None, start: int = 0,
    lin: TraceLinearisation | None = None,
) -> np.ndarray:
    """The bound (n - start, 5, 5) for rows ``start …`` of ``trace`` (see :func:`information_bound`).

    Parameters
    ----------
    setup, trace
        The run's filter (:func:`ftc_mj.wiring.estimation.setup_from_config`) and its trace (true
        states, wheel rates, measurements).
    q_radius : float, optional
        Radius process-noise σ per step (m); default: the filters' (``setup.Q``).
        ``0`` gives the bound for radii known to be constant (only the prior and the data inform them).
    start : int
        First row; the prior ``setup.P0`` applies before it, e.g. a fault onset.
    lin : TraceLinearisation, optional
        Precomputed :func:`linearise_trace` of the same trace.
    """
    lin = lin if lin is not None else linearise_trace(setup, trace)
    Q = setup.Q.copy()
    if q_radius is not None:
        Q[3, 3] = Q[4, 4] = q_radius * q_radius
    return information_bound(lin.F[start:], lin.H[start:], lin.R[start:], Q, setup.P0)


def data_model_bound(setup: FilterSetup, trace: dict[str, np.ndarray],
                     lin: TraceLinearisation | None = None) -> np.ndarray:
    """The bound (n, 5, 5) for the model that made the data: the radii constant except at the rows where
    the trace's true radii ``R_R``/``R_L`` change, where the changed wheel's radius jumps by an unknown
    amount at that known time (its information restarts from the prior ``P0``, uncorrelated with the
    rest). Between changes this is the bound with radius process noise 0 (:func:`trace_pcrb` with
    ``q_radius = 0``); the pose keeps the filters' process noise (it does not enter the speed and
    yaw-rate channels). A ramp changes the radius at every row and makes this the (loose) bound of a
    jump at every step."""
    lin = lin if lin is not None else linearise_trace(setup, trace)
    radii = np.column_stack([np.asarray(trace["R_R"], float), np.asarray(trace["R_L"], float)])
    jumped = np.zeros_like(radii, dtype=bool)
    jumped[1:] = np.abs(np.diff(radii, axis=0)) > 1e-9
    Q = setup.Q.copy()
    Q[3, 3] = Q[4, 4] = 0.0
    n = radii.shape[0]
    out = np.empty((n, 5, 5))
    prior, start = setup.P0, 0
    for s in [*np.flatnonzero(jumped.any(axis=1)), n]:
        if s > start:
            out[start:s] = information_bound(lin.F[start:s], lin.H[start:s], lin.R[start:s], Q, prior)
        if s < n:
            prior = out[s - 1].copy()
            for i in np.flatnonzero(jumped[s]) + 3:
                prior[i, :] = prior[:, i] = 0.0
                prior[i, i] = setup.P0[i, i]
            start = s
    return out


def pcrb_columns(setup: FilterSetup, trace: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """:data:`PCRB_COLUMNS` of a trace: the bound with the filters' own model (``Q``, ``P0``, sensor σ),
    and the radius σ of the data's model (:func:`data_model_bound`).

    The split σ is taken along the direction set by the true wheel rates of each row.
    """
    lin = linearise_trace(setup, trace)
    B = trace_pcrb(setup, trace, lin=lin)
    C = data_model_bound(setup, trace, lin)
    split = np.array([radius_directions(B[k], lin.omega[k]).split_std for k in range(B.shape[0])])
    return {
        "R_R_pcrb_std": np.sqrt(np.maximum(B[:, 3, 3], 0.0)),
        "R_L_pcrb_std": np.sqrt(np.maximum(B[:, 4, 4], 0.0)),
        "radius_split_pcrb_std": split,
        "R_R_pcrb_const_std": np.sqrt(np.maximum(C[:, 3, 3], 0.0)),
        "R_L_pcrb_const_std": np.sqrt(np.maximum(C[:, 4, 4], 0.0)),
    }
