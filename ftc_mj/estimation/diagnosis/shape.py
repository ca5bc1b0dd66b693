"""A sensor fault's shape: a bias (a step in the reading) or a drift (a ramp), told apart by a generalised
likelihood ratio on the *integrated* residual (Basseville & Nikiforov §7.2: the GLR of two change
signatures, each maximised over its onset).

The residual is a sensor's reading integrated over time minus what the pose fixes say it integrates to (the
gyro's integral minus the fixed heading, in rad; the speed's integral minus the arc rolled between the
fixes, in m), sampled at the fixes. A healthy sensor leaves it at a constant plus noise; from a fault's onset
``t0`` a bias ``b`` adds the ramp ``b (t − t0)⁺`` and a drift ``a`` adds the parabola ``a ((t − t0)⁺)² / 2``
— so the drift's size is its growth rate ``a`` (per s), the bias's its offset ``b``.

Its noise has two parts: the fix's own (white, variance ``r`` per fix) and the sensor's noise integrated (a
random walk of ``q`` per second), so the covariance of two samples ``i, j`` is ``r δ_ij + q min(τ_i, τ_j)``
(``τ`` the time since the first sample). The fit is generalised least squares: whitened by the Cholesky
factor of that covariance, each signature's size (and the constant) is a linear regression at each
candidate onset. The noise's scale is left free (profile likelihood: a model floor the settings do not know
only scales it), so the log-likelihood ratio of drift against bias is ``n/2 log(SSE_bias / SSE_drift)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ShapeFit:
    """The shape of a sensor fault (module docstring).

    Attributes:
        mode: ``bias`` or ``drift`` (the larger likelihood, the drift's reduced by the caller's margin).
        size: the bias's offset or the drift's rate (the sensor's unit; per s for a drift).
        sigma: the size's standard deviation (same unit).
        onset: the chosen model's onset (s).
        latest: the later of the two models' onsets (s): a decision needs data after both.
        llr: the log-likelihood ratio of drift against bias (nats; positive: the drift fits better).
    """

    mode: str
    size: float
    sigma: float
    onset: float
    latest: float
    llr: float


def _signature(mode: str, t: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """``(samples, starts)``: the integrated signature of ``mode`` at each candidate onset."""
    x = np.clip(t[:, None] - starts[None, :], 0.0, None)
    return x if mode == "bias" else 0.5 * x * x


def shape_fit(t: np.ndarray, e: np.ndarray, r: float, q: float, starts: np.ndarray,
              margin: float = 0.0) -> ShapeFit | None:
    """The bias and the drift fitted to the integrated residual ``e`` (sensor unit · s) at times ``t`` (s)
    with white variance ``r`` per sample and random-walk variance ``q`` per second, over the candidate onsets
    ``starts`` (s); the drift is chosen when its log-likelihood ratio over the bias exceeds ``margin`` (nats).
    ``None`` with fewer than six samples or no onset that leaves samples on both sides."""
    if t.size < 6 or starts.size == 0:
        return None
    from scipy.linalg import solve_triangular  # here: a run that never fits a shape does not import SciPy's LAPACK

    tau = t - t[0]
    cov = r * np.eye(t.size) + q * np.minimum.outer(tau, tau) + 1e-12 * np.eye(t.size)
    L = np.linalg.cholesky(cov)
    one = solve_triangular(L, np.ones(t.size), lower=True)
    y = solve_triangular(L, e - e.mean(), lower=True)
    y = y - one * (one @ y) / (one @ one)  # the constant projected out
    fits = {}
    for mode in ("bias", "drift"):
        H = solve_triangular(L, _signature(mode, t, starts), lower=True)
        H = H - np.outer(one, (one @ H) / (one @ one))
        shh = np.einsum("ij,ij->j", H, H)
        she = y @ H
        ok = shh > 1e-12
        b = np.where(ok, she / np.where(ok, shh, 1.0), 0.0)
        sse = np.where(ok, float(y @ y) - b * she, np.inf)
        i = int(np.argmin(sse))
        if not ok[i]:
            return None
        sigma = math.sqrt(max(float(sse[i]), 0.0) / max(t.size - 3, 1) / float(shh[i]))
        fits[mode] = (max(float(sse[i]), 1e-300), float(b[i]), sigma, float(starts[i]))
    llr = 0.5 * t.size * math.log(fits["bias"][0] / fits["drift"][0])
    mode = "drift" if llr > margin else "bias"
    _, size, sigma, onset = fits[mode]
    return ShapeFit(mode, size, sigma, onset, max(fits["bias"][3], fits["drift"][3]), llr)
