"""The full path-following NLP for IPOPT (the seed and re-seed solves of the path-following NMPC)."""

from __future__ import annotations

import numpy as np

from ..lazy import lazy_module
from .pathfollow_spec import SLACK_MAX, PathFollowingSpec, RadiusInterval, lateral_sides
from .reference import Path
from .solver_cache import ipopt_solver
from .solvers import ipopt_options, warm_started_solve
from .transcription import Collocation

ca = lazy_module("casadi")


class PathNLP:
    """The full NLP for IPOPT (built once on an SX graph).

    ``w = [x(N), y(N), psi(N), s(N), omega_R(N), omega_L(N), v(N), σ]`` (the model's wheel rates),
    parameters ``p = [x0, y0, psi0, s0, R_R, R_L, V_applied]``. Constraint rows as :class:`PathQP`'s, exact
    instead of linearised: collocation (4N), initial state (4), wheel-rate rates (2N), traction (4N + 4, or
    2N), longitudinal acceleration (N) and the speed at ``t0`` relative to ``V_applied`` (1).

    ``robust`` (the degraded mode): N more variables ``τ`` after ``σ``, 4 more parameters (the interval's
    corners ``[hi_R, lo_L, lo_R, hi_L]``, m) and the 2N interval rows of :class:`PathQP` (exact), placed
    after the traction rows.
    """

    def __init__(self, col: Collocation, spec: PathFollowingSpec, path: Path, max_iter: int,
                 cold_time_budget: float | None, time_budget: float | None, robust: bool = False) -> None:
        self.col, self.spec, self.robust = col, spec, bool(robust)
        N, h, pr = col.N, col.h, spec.problem
        n_tau = N if robust else 0
        w = ca.SX.sym("w", 7 * N + 1 + n_tau)
        p = ca.SX.sym("p", 7 + (4 if robust else 0))
        X = ca.reshape(w[: 4 * N], N, 4).T  # 4 x N
        U = ca.reshape(w[4 * N: 7 * N], N, 3).T  # 3 x N
        sig = w[7 * N]
        radii = p[4:6]
        D = ca.DM(col.D)
        Wq = ca.DM(col.W).T
        f = col.model.casadi_derivative().map(N)
        rates = col.model.casadi_rates().map(N)
        Xfull = ca.vertcat(X[:3, :], ca.repmat(radii, 1, N))
        colloc = ca.vertcat((ca.mtimes(X[:3, :], D.T) / h - f(Xfull, U[:2, :])[:3, :]),
                            ca.mtimes(X[3, :], D.T) / h - U[2, :]).T  # N x 4
        g_path = path.geometry(X[3, :].T, ca)
        dx, dy = X[0, :].T - g_path.x, X[1, :].T - g_path.y
        c, s = ca.cos(g_path.heading), ca.sin(g_path.heading)
        ec, el = -s * dx + c * dy, c * dx + s * dy
        eh = X[2, :].T - g_path.heading
        J = ca.mtimes(Wq, spec.q_contour * ec**2 + spec.q_lag * el**2 + spec.q_heading * eh**2
                      + spec.q_progress * (U[2, :].T - spec.desired_speed) ** 2)
        dU = ca.mtimes(U, D.T) / h  # 3 x N, d/dt
        J += pr.rate_penalty * ca.sum2(Wq * ca.sum1(dU[:2, :] ** 2))
        J += spec.progress_rate_penalty * ca.sum2(Wq * dU[2, :] ** 2)
        J += spec.slack_penalty * sig + sig**2
        Vp = rates(Xfull, U[:2, :])  # 2 x N
        rate = pr.omega_rate_max * h
        g = [ca.vec(colloc), X[:, 0] - p[:4], ca.vec((dU[:2, :] * h).T)]
        lbg = [np.zeros(4 * N + 4), -rate * np.ones(2 * N)]
        ubg = [np.zeros(4 * N + 4), rate * np.ones(2 * N)]
        if pr.max_lateral_accel is not None:  # ±a ± β dV/dt − σ ≤ A
            a = (Vp[0, :] * Vp[1, :]).T
            ax = dU[0, :].T * 0.5 * radii[0] + dU[1, :].T * 0.5 * radii[1]
            for sl, so in lateral_sides(spec):
                g.append(sl * a + so * spec.braking_trade * ax - sig)
                lbg.append(-np.inf * np.ones(N))
                ubg.append(pr.max_lateral_accel * np.ones(N))
            self._lat0 = sum(int(x.numel()) for x in g), len(lateral_sides(spec, True))
            for sl, so in lateral_sides(spec, True):  # at t0: the speed change from the applied command's (p[6])
                g.append(sl * a[0] + so * spec.braking_trade * (Vp[0, 0] - p[6]) / spec.sample_time - sig)
                lbg.append([-np.inf])
                ubg.append([pr.max_lateral_accel])
            if robust:
                J += self._interval_rows(g, lbg, ubg, w[7 * N + 1:], p[7:], U[:2, :], rates)
        if pr.max_longitudinal_accel is not None:
            g.append(dU[0, :].T * 0.5 * radii[0] + dU[1, :].T * 0.5 * radii[1])
            g.append(Vp[0, 0])  # speed at t0, within a_max T_s of the applied command's (bounds per solve)
            lbg += [-pr.max_longitudinal_accel * np.ones(N), [-np.inf]]
            ubg += [pr.max_longitudinal_accel * np.ones(N), [np.inf]]
        self._lbg, self._ubg = np.concatenate(lbg), np.concatenate(ubg)
        if pr.max_lateral_accel is None:
            self._lat0 = (0, 0)
        self._lbx = np.concatenate([-np.inf * np.ones(6 * N), np.zeros(N + 1 + n_tau)])
        self._ubx = np.concatenate([np.inf * np.ones(6 * N), spec.max_progress_speed * np.ones(N),
                                    SLACK_MAX * np.ones(1 + n_tau)])
        opts = ipopt_options(max_iter, cold_time_budget, time_budget)
        name = "pf_nmpc_robust" if robust else "pf_nmpc"
        self._problem = (name, {"x": w, "p": p, "f": J, "g": ca.vertcat(*g)}, opts)
        self._nlpsol: ca.Function | None = None
        self.corner_slack = 0.0
        """Largest τ_j (m/s²) of the last robust solve (0 without the interval rows)."""
        self.size = (w.numel(), self._lbg.size)
        self.reset()

    def _interval_rows(self, g: list, lbg: list, ubg: list, tau: ca.SX, corners: ca.SX, Uw: ca.SX,
                       rates: ca.Function) -> ca.SX:
        """Append the interval rows ``±a(corner)_j − τ_j ≤ A`` (upper corner ``corners[0:2]``, lower
        ``corners[2:4]``) to ``g, lbg, ubg``; returns their slack cost ``Σ_j W_j (slack_penalty τ_j + τ_j²)``."""
        N, A = self.col.N, self.spec.problem.max_lateral_accel
        for k, sign in ((0, 1.0), (2, -1.0)):
            Vp = rates(ca.vertcat(ca.DM.zeros(3, N), ca.repmat(corners[k:k + 2], 1, N)), Uw)
            g.append(sign * (Vp[0, :] * Vp[1, :]).T - tau)
            lbg.append(-np.inf * np.ones(N))
            ubg.append(A * np.ones(N))
        return ca.mtimes(ca.DM(self.col.W).T, self.spec.slack_penalty * tau + tau**2)

    @property
    def solver(self) -> ca.Function:
        """The IPOPT ``nlpsol``, built (or loaded from the solver cache) on the first solve: an RTI controller
        needs it only to seed and re-seed, and the degraded mode's NLP often never."""
        if self._nlpsol is None:
            self._nlpsol = ipopt_solver(*self._problem)
        return self._nlpsol

    def reset(self) -> None:
        """Forget the dual warm start."""
        self._lam: tuple[np.ndarray, np.ndarray] | None = None

    def solve(self, x0: np.ndarray, radii: np.ndarray, bounds: tuple[np.ndarray, np.ndarray],
              V_applied: float | None, Xg: np.ndarray, Ug: np.ndarray, interval: RadiusInterval | None = None
              ) -> tuple[bool, str, int, np.ndarray | None, np.ndarray | None, float]:
        """``(ok, status, iterations, X (N,4), U (N,3), σ)`` from the guess ``(Xg, Ug)``; ``bounds`` are the
        model's wheel-rate bounds (:func:`wheel_bounds`), ``V_applied`` (m/s) the speed of the applied command,
        ``interval`` the degraded mode's radius interval (required by, and only used by, a robust NLP)."""
        N = self.col.N
        lbx, ubx = self._lbx.copy(), self._ubx.copy()
        lbx[4 * N:6 * N], ubx[4 * N:6 * N] = bounds
        wg = np.clip(np.concatenate([Xg.T.ravel(), Ug.T.ravel(), np.zeros(lbx.size - 6 * N - N)]), lbx, ubx)
        p = np.concatenate([x0, radii, [V_applied or 0.0]])
        if self.robust:
            if interval is None:
                raise ValueError("a robust path-following NLP needs the radius interval")
            p = np.concatenate([p, *interval.corners()])
        lbg, ubg = self._lbg.copy(), self._ubg.copy()
        amax = self.spec.problem.max_longitudinal_accel
        if amax is not None and V_applied is not None:
            lbg[-1], ubg[-1] = V_applied - amax * self.spec.sample_time, V_applied + amax * self.spec.sample_time
        if V_applied is None:  # no applied command yet: the t0 rows of the braking trade-off are open
            i0, n0 = self._lat0
            ubg[i0:i0 + n0] = np.inf
        args = {"x0": wg, "p": p, "lbx": lbx, "ubx": ubx, "lbg": lbg, "ubg": ubg}
        ok, status, it, wv, self._lam = warm_started_solve(self.solver, args, self._lam)
        if not ok:
            return False, status, it, None, None, float("nan")
        self.corner_slack = float(wv[7 * N + 1:].max()) if self.robust else 0.0
        return (True, status, it, wv[: 4 * N].reshape(4, N).T, wv[4 * N: 7 * N].reshape(3, N).T,
                float(wv[7 * N]))

