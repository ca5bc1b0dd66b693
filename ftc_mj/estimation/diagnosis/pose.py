"""The pose sensor's own faults: a displacement of its fixes (``bias``: it stays; ``jump``: it returns) and a
``dropout`` (no fix for longer than the sensor's rate allows).

A displaced fix is told from the robot's motion by dead reckoning: between two fixes the encoders say how far
the robot rolled (``R0`` times the mean wheel turn) and the fixes' headings — which a position fault leaves
alone — say along what (their quadratic fit over the window, so the heading noise does not accumulate). The
residual ``E_i`` = the fix minus the dead-reckoned track from the window's first fix is, on a healthy robot,
the track's similarity error (an offset, a scale — the rolling radius — and a rotation — the heading's
offset: four parameters) plus the fix noise. A displacement ``d`` from fix ``i0`` on adds the step
``d H(i − i0)``; a puncture or a skid from ``i0`` changes the scale and rotation from there (a kink), which
the alternative leaves free, so only an immediate displacement that stays is a step. The statistic is the
GLR of the step (two parameters, the fix's σ known): the drop of the residual sum of squares over
``2 σ²``, maximised over the recent candidate fixes (Willsky & Jones' window-limited GLR). The displacement's
estimate and onset are those of the step alone (the kink held at zero, maximised over the same candidates): with
few displaced fixes in the window a kink and a step together fit them with a step far off — a 2.8 m jump was
first estimated at −1.45 m, onset 0.3 s early, on dev draw 201 — while the step alone is the least-squares
displacement of the fixes after it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .history import History


@dataclass(frozen=True)
class Displacement:
    """A displacement of the fixes estimated by the step alone (module docstring): what a declaration says.

    Attributes:
        offset: ``(dx, dy)`` (m, world frame).
        sigma: σ of its length (m).
        axis_sigma: σ along world x and y (m).
        onset: time (s) of the first displaced fix.
        fix: that fix's index in the history.
    """

    offset: tuple[float, float]
    sigma: float
    axis_sigma: tuple[float, float]
    onset: float
    fix: int


@dataclass(frozen=True)
class PoseStep:
    """The most likely displacement of the fixes in a window.

    Attributes:
        stat: its GLR, the kink left free (log-likelihood ratio).
        offset: the displacement ``(dx, dy)`` (m, world frame) fitted with the kink.
        sigma: σ of the displacement's length (m).
        onset: time (s) of the first displaced fix.
        fix: that fix's index in the history.
    """

    stat: float
    rms: float
    """The RMS residual (m) of the window without a step (the track's model error with the fix noise)."""
    offset: tuple[float, float]
    sigma: float
    onset: float
    fix: int
    alone: Displacement | None = None
    """The displacement estimated by the step alone, which a declaration takes (``offset``, ``onset`` and ``fix``
    above are the kink-robust fit's, which decide whether the step is one)."""
    turn: float = 0.0
    """The GLR of a change of the encoders' yaw rate against the fixes' headings at the same fix (a tyre or a
    servo changed, not the pose sensor: a position fault leaves the heading alone)."""


def heading_kink(h: History, fixes: list[int], R0: float, b: float, i0: int, sigma: float) -> float:
    """The GLR of a change at fix ``i0`` of the rate at which the fixes' headings part from the encoders' yaw
    ``R0 (θ_R − θ_L) / (2 b)``: their difference regressed on a quadratic in time and a ramp from ``i0``, σ
    ``sigma`` (rad) per fix."""
    t = np.asarray([h.fix_t[i] for i in fixes])
    t = (t - t[0]) / max(float(t[-1] - t[0]), 1e-9)
    steps = [h.fix_steps[i] for i in fixes]
    yaw = np.asarray([R0 * (h.delta("th_R", steps[0], j) - h.delta("th_L", steps[0], j)) / (2.0 * b) for j in steps])
    r = np.asarray([h.fix_pose[i][2] for i in fixes]) - yaw
    X0 = np.column_stack([np.ones_like(t), t, t * t])
    X1 = np.column_stack([X0, np.clip(t - t[i0 - 1], 0.0, None)])
    return (_sse(X0, r) - _sse(X1, r)) / (2.0 * sigma**2)


def dead_reckoned(h: History, fixes: list[int], R0: float, b: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(n, 2)`` each: the track (m, world frame) rolled through the pose fixes of indices ``fixes`` (from 0 at
    the first) — each interval's encoder arc ``R0 (Δθ_R + Δθ_L) / 2`` along its mid heading, the encoders'
    heading ``R0 (θ_R − θ_L) / (2 b)`` (half track ``b``, m) put on the fixes' headings by their mean offset —
    and its first and second moments in time (each interval's step times ``τ`` and ``τ²``, τ the interval's mid
    time over the window's span): a scale and a heading error that grow linearly or quadratically over the
    window (unequal or changing radii) move the track along them."""
    t = np.asarray([h.fix_t[i] for i in fixes]) - h.fix_t[fixes[0]]
    steps = [h.fix_steps[i] for i in fixes]
    pairs = list(zip(steps[:-1], steps[1:], strict=True))
    turn = np.asarray([0.5 * (h.delta("th_R", i, j) + h.delta("th_L", i, j)) for i, j in pairs])
    yaw = np.concatenate([[0.0], np.cumsum([R0 * (h.delta("th_R", i, j) - h.delta("th_L", i, j)) / (2.0 * b)
                                            for i, j in pairs])])
    heading = yaw + float(np.mean(np.asarray([h.fix_pose[i][2] for i in fixes]) - yaw))
    mid = 0.5 * (heading[:-1] + heading[1:])
    arcs = R0 * turn
    tau = 0.5 * (t[:-1] + t[1:]) / max(float(t[-1]), 1e-9)
    out = []
    for weight in (1.0, tau, tau**2):
        track = np.zeros((t.size, 2))
        track[1:, 0] = np.cumsum(weight * arcs * np.cos(mid))
        track[1:, 1] = np.cumsum(weight * arcs * np.sin(mid))
        out.append(track)
    return out[0], out[1], out[2]


def _sse(X: np.ndarray, y: np.ndarray) -> float:
    """The residual sum of squares of the least-squares fit of ``y`` on the columns of ``X``."""
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    r = y - X @ coef
    return float(r @ r)


def step_glr(h: History, a: int, b: int, geometry: tuple[float, float], sigma: tuple[float, float],
             recent: float, min_before: int = 5, most: int = 40) -> PoseStep | None:
    """The GLR of a displacement of the fixes ``a … b`` (module docstring; at most ``most`` of them, every n-th
    with the last), and the displacement's estimate from the step alone, at each candidate fix ``i0`` at most
    ``recent`` (s) before the last one and at least ``min_before`` fixes after the first, with the fixes' σ
    ``sigma`` (m per axis, rad), for the robot's nominal radius and half track ``geometry`` (m); ``None`` without a
    candidate."""
    fixes = list(range(b, a - 1, -math.ceil((b - a + 1) / most)))[::-1]
    n = len(fixes)
    if n < min_before + 3:
        return None
    pos = np.asarray([h.fix_pose[i][:2] for i in fixes])
    D, D1, D2 = dead_reckoned(h, fixes, *geometry)
    E = pos - pos[0] - D
    y = np.concatenate([E[:, 0], E[:, 1]])
    zero, one = np.zeros(n), np.ones(n)
    base = [np.concatenate(c) for c in ((one, zero), (zero, one))]
    for M in (D, D1, D2):  # scale and heading errors, constant and growing over the window
        base += [np.concatenate((M[:, 0], M[:, 1])), np.concatenate((-M[:, 1], M[:, 0]))]
    B = np.column_stack(base)
    Q, _ = np.linalg.qr(B)
    y_perp = y - Q @ (Q.T @ y)  # the base projected out (Frisch–Waugh–Lovell: the rest is fitted on residuals)
    yy = float(y_perp @ y_perp)
    rms = math.sqrt(yy / max(2 * n - B.shape[1], 1))
    cand = np.asarray([i0 for i0 in range(max(min_before, 1), n)
                       if h.fix_t[b] - h.fix_t[fixes[i0]] <= recent + 1e-9], dtype=int)
    if cand.size == 0:
        return None
    stat, d, cov = step_statistics(D, cand, Q, y_perp)
    j = int(np.argmax(stat))  # the first of equal maxima, as a running ``>`` keeps it
    stat_j, i0 = float(stat[j]) / (2.0 * sigma[0] ** 2), int(cand[j])
    k, d_alone, cov_alone = step_alone(n, cand, Q, y_perp)
    alone = _displacement(h, fixes, k, d_alone, cov_alone * sigma[0] ** 2)
    return PoseStep(stat_j, rms, (float(d[j][0]), float(d[j][1])), _length_sigma(d[j], cov[j] * sigma[0] ** 2),
                    h.fix_t[fixes[i0]], fixes[i0], alone, heading_kink(h, fixes, *geometry, i0, sigma[1]))


def _length_sigma(d: np.ndarray, cov: np.ndarray) -> float:
    """σ (m) of the length of displacement ``d`` (m) of covariance ``cov`` (m²)."""
    u = d / max(float(np.hypot(*d)), 1e-12)
    return math.sqrt(max(float(u @ cov @ u), 0.0))


def _displacement(h: History, fixes: list[int], i0: int, d: np.ndarray, cov: np.ndarray) -> Displacement:
    """The :class:`Displacement` ``d`` (m) of covariance ``cov`` (m²) from window fix ``i0`` on."""
    axes = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return Displacement((float(d[0]), float(d[1])), _length_sigma(d, cov), (float(axes[0]), float(axes[1])),
                        h.fix_t[fixes[i0]], fixes[i0])


def step_alone(n: int, cand: np.ndarray, Q: np.ndarray, y_perp: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """The displacement of the fixes that best explains ``y_perp`` as a step alone (no kink) from one of the
    candidate fixes ``cand`` of a window of ``n``, the base ``Q`` projected out (:func:`step_statistics`): that fix,
    the step ``(dx, dy)`` (m) and its unscaled covariance (multiply by σ²)."""
    after = (np.arange(n)[None, :] >= cand[:, None]).astype(float)  # (m, n)
    zero = np.zeros_like(after)
    A = np.stack([np.concatenate((after, zero), axis=1), np.concatenate((zero, after), axis=1)], axis=2)
    A = A - Q @ (Q.T @ A)
    G = np.linalg.pinv(np.swapaxes(A, 1, 2) @ A + 1e-12 * np.eye(2))
    g = np.swapaxes(A, 1, 2) @ y_perp
    k = int(np.argmax(np.einsum("mi,mij,mj->m", g, G, g)))
    return int(cand[k]), G[k] @ g[k], G[k]


def step_statistics(D: np.ndarray, cand: np.ndarray, Q: np.ndarray, y_perp: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each candidate fix ``i0`` of ``cand`` at once: the drop of the residual sum of squares (m²) that a
    displacement from ``i0`` on explains beyond a change of scale and rotation there (a kink), its least-squares
    displacement ``(dx, dy)`` (m) and its unscaled covariance (multiply by σ²), all with the orthonormal base
    ``Q`` (the window's offset, scale and rotation) projected out of the regressors and of the residual
    ``y_perp`` (``(2n,)``: x then y). ``D``: the dead-reckoned track (``(n, 2)``, m)."""
    n = D.shape[0]
    after = (np.arange(n)[None, :] >= cand[:, None]).astype(float)  # (m, n)
    K = (D[None, :, :] - D[cand - 1][:, None, :]) * after[:, :, None]  # a change of scale and rotation from i0
    zero = np.zeros_like(after)
    A = np.stack([np.concatenate((K[..., 0], K[..., 1]), axis=1), np.concatenate((-K[..., 1], K[..., 0]), axis=1),
                  np.concatenate((after, zero), axis=1), np.concatenate((zero, after), axis=1)], axis=2)
    A = A - Q @ (Q.T @ A)
    G = np.swapaxes(A, 1, 2) @ A + 1e-12 * np.eye(4)
    g = np.swapaxes(A, 1, 2) @ y_perp
    Ginv = np.linalg.pinv(G)
    full = np.einsum("mi,mij,mj->m", g, Ginv, g)
    kink = np.einsum("mi,mij,mj->m", g[:, :2], np.linalg.pinv(G[:, :2, :2]), g[:, :2])
    return full - kink, np.einsum("mij,mj->mi", Ginv, g)[:, 2:], Ginv[:, 2:, 2:]


def fix_interval(h: History, last: int = 20) -> float | None:
    """The sensor's interval between fixes (s): the median of the last ``last`` ones (``None`` before two)."""
    if len(h.fix_t) < 2:
        return None
    return float(np.median(np.diff(h.fix_t[-last - 1:])))
