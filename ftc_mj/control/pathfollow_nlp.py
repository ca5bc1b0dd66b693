"""The full path-following NLP for IPOPT (the seed and re-seed solves of the path-following NMPC)."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..lazy import lazy_module
from .pathfollow_path import parameter_count, path_kind, path_parameters, symbolic_path
from .pathfollow_spec import SLACK_MAX, PathFollowingSpec, RadiusInterval, lateral_sides
from .reference import Path
from .solver_cache import ipopt_solver
from .solvers import ipopt_options, warm_started_solve
from .transcription import Collocation

ca = lazy_module("casadi")


def nlp_structure(spec: PathFollowingSpec, path: Path, robust: bool = False) -> tuple:
    """What the graph of the path-following NLP of ``spec`` on ``path`` is built from: the spec without the
    numbers that are parameters or bounds of the NLP (desired speed, progress-speed bound, actuation-rate weight,
    braking trade — only whether it is zero —, lateral and longitudinal bounds — only whether there is one —,
    yaw compliance and the servos' limits, which the NLP does not read), the path's kind (a path without
    parameters: the path itself) and ``robust``. Two problems of equal structure share one IPOPT solver."""
    pr = spec.problem
    lat = None if pr.max_lateral_accel is None else 0.0
    lon = None if pr.max_longitudinal_accel is None else 0.0
    bare = dataclasses.replace(spec, problem=dataclasses.replace(pr, max_lateral_accel=lat, max_longitudinal_accel=lon,
                                                                 rate_penalty=0.0),
                               desired_speed=0.0, max_progress_speed=0.0, yaw_compliance=0.0,
                               braking_trade=float(spec.braking_trade != 0), servo_lateral_accel=None,
                               servo_longitudinal_accel=None)
    return bare, path_kind(path) or path, bool(robust)


class PathNLP:
    """The full NLP for IPOPT (built once on an SX graph).

    ``w = [x(N), y(N), psi(N), s(N), omega_R(N), omega_L(N), v(N), σ]`` (the model's wheel rates),
    parameters ``p = [x0, y0, psi0, s0, R_R, R_L, V_applied, V_des, β, r, path…]``: the initial state, the radii,
    the speed of the applied command, the desired speed (m/s), the braking trade, the actuation-rate weight ``r``
    (``rate_penalty``, s³) and the path's numbers
    (:mod:`~ftc_mj.control.pathfollow_path`), so one solver serves every draw of a path kind
    (:func:`nlp_structure`); the lateral and longitudinal bounds and the progress-speed bound are bounds of the rows
    and variables
    (:meth:`set_problem`). Constraint rows as :class:`PathQP`'s, exact instead of linearised: collocation
    (4N), initial state (4), wheel-rate rates (2N), traction (4N + 4, or 2N), longitudinal acceleration (N)
    and the speed at ``t0`` relative to ``V_applied`` (1).

    ``robust`` (the degraded mode): N more variables ``τ`` after ``σ``, 4 more parameters after ``V_applied``
    (the interval's corners ``[hi_R, lo_L, lo_R, hi_L]``, m) and the 2N interval rows of :class:`PathQP`
    (exact), placed after the traction rows.
    """

    def __init__(self, col: Collocation, spec: PathFollowingSpec, path: Path, max_iter: int,
                 cold_time_budget: float | None, time_budget: float | None, robust: bool = False) -> None:
        self.col, self.robust = col, bool(robust)
        self.structure = nlp_structure(spec, path, robust)
        N = col.N
        n_tau = N if robust else 0
        self._i_draw = 7 + (4 if robust else 0)  # index of V_des in p
        w = ca.SX.sym("w", 7 * N + 1 + n_tau)
        p = ca.SX.sym("p", self._i_draw + 3 + parameter_count(path))
        J, g = self._graph(spec, symbolic_path(path, p[self._i_draw + 3:]), w, p)
        self._lbx = np.concatenate([-np.inf * np.ones(6 * N), np.zeros(N + 1 + n_tau)])
        self._ubx = np.concatenate([np.inf * np.ones(6 * N), np.zeros(N), SLACK_MAX * np.ones(1 + n_tau)])
        opts = ipopt_options(max_iter, cold_time_budget, time_budget)
        name = "pf_nmpc_robust" if robust else "pf_nmpc"
        self._problem = (name, {"x": w, "p": p, "f": J, "g": ca.vertcat(*g)}, opts)
        self._nlpsol: ca.Function | None = None
        self.corner_slack = 0.0
        """Largest τ_j (m/s²) of the last robust solve (0 without the interval rows)."""
        self.size = (w.numel(), self._lbg.size)
        self.set_problem(spec, path)
        self.reset()

    def _graph(self, spec: PathFollowingSpec, path: Path, w: ca.SX, p: ca.SX) -> tuple[ca.SX, list]:
        """The cost and the constraint rows on the (symbolic) ``path``; sets the rows' bounds that do not change
        with the draw (:attr:`_lbg`, :attr:`_ubg`) and the places of those that do (:attr:`_rows`)."""
        col, N, h, pr = self.col, self.col.N, self.col.h, spec.problem
        X = ca.reshape(w[: 4 * N], N, 4).T  # 4 x N
        U = ca.reshape(w[4 * N: 7 * N], N, 3).T  # 3 x N
        sig = w[7 * N]
        radii, V_des, beta = p[4:6], p[self._i_draw], p[self._i_draw + 1]
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
                      + spec.q_progress * (U[2, :].T - V_des) ** 2)
        dU = ca.mtimes(U, D.T) / h  # 3 x N, d/dt
        J += p[self._i_draw + 2] * ca.sum2(Wq * ca.sum1(dU[:2, :] ** 2))  # the actuation-rate weight
        J += spec.progress_rate_penalty * ca.sum2(Wq * dU[2, :] ** 2)
        J += spec.slack_penalty * sig + sig**2
        Vp = rates(Xfull, U[:2, :])  # 2 x N
        rate = pr.omega_rate_max * h
        g = [ca.vec(colloc), X[:, 0] - p[:4], ca.vec((dU[:2, :] * h).T)]
        lbg = [np.zeros(4 * N + 4), -rate * np.ones(2 * N)]
        ubg = [np.zeros(4 * N + 4), rate * np.ones(2 * N)]
        self._lat0, lat_rows = (0, 0), []
        if pr.max_lateral_accel is not None:  # ±a ± β dV/dt − σ ≤ A
            a = (Vp[0, :] * Vp[1, :]).T
            ax = dU[0, :].T * 0.5 * radii[0] + dU[1, :].T * 0.5 * radii[1]
            for sl, so in lateral_sides(spec):
                g.append(sl * a + so * beta * ax - sig)
            for sl, so in lateral_sides(spec, True):  # at t0: the speed change from the applied command's (p[6])
                g.append(sl * a[0] + so * beta * (Vp[0, 0] - p[6]) / spec.sample_time - sig)
            self._lat0 = (sum(int(x.numel()) for x in g) - len(lateral_sides(spec, True)),
                          len(lateral_sides(spec, True)))
            lat_rows = self._open_rows(g, lbg, ubg)
            if self.robust:
                J += self._interval_rows(g, spec, w[7 * N + 1:], p[7:11], U[:2, :], rates)
                lat_rows += self._open_rows(g, lbg, ubg)
        if pr.max_longitudinal_accel is not None:
            g.append(dU[0, :].T * 0.5 * radii[0] + dU[1, :].T * 0.5 * radii[1])
            g.append(Vp[0, 0])  # speed at t0, within a_max T_s of the applied command's (bounds per solve)
            start = sum(len(b) for b in lbg)
            self._lon_rows = np.arange(start, start + N)
            lbg += [-pr.max_longitudinal_accel * np.ones(N), [-np.inf]]
            ubg += [pr.max_longitudinal_accel * np.ones(N), [np.inf]]
        self._lbg, self._ubg = np.concatenate(lbg), np.concatenate(ubg)
        self._rows = np.concatenate(lat_rows).astype(int) if lat_rows else np.zeros(0, int)
        return J, g

    @staticmethod
    def _open_rows(g: list, lbg: list, ubg: list) -> list[np.ndarray]:
        """Bounds ``(−∞, 0]`` for the rows of ``g`` not yet bounded (the lateral bound is set per draw by
        :meth:`set_problem`); returns their indices."""
        start = sum(len(b) for b in lbg)
        n = sum(int(x.numel()) for x in g) - start
        lbg.append(-np.inf * np.ones(n))
        ubg.append(np.zeros(n))
        return [np.arange(start, start + n)]

    def set_problem(self, spec: PathFollowingSpec, path: Path) -> None:
        """Solve the problem of ``spec`` on ``path`` from now on: same :func:`nlp_structure` as the built one
        (``ValueError`` otherwise), its numbers as parameters and bounds."""
        if nlp_structure(spec, path, self.robust) != self.structure:
            raise ValueError("the path-following NLP was built for a problem of another structure")
        self.spec, self.path = spec, path
        pp = path_parameters(path)
        self._draw = np.concatenate([[spec.desired_speed, spec.braking_trade, spec.problem.rate_penalty],
                                     [] if pp is None else pp])
        N = self.col.N
        self._ubx[6 * N:7 * N] = spec.max_progress_speed
        if self._rows.size:
            self._ubg[self._rows] = spec.problem.max_lateral_accel
        if spec.problem.max_longitudinal_accel is not None:
            self._lbg[self._lon_rows] = -spec.problem.max_longitudinal_accel
            self._ubg[self._lon_rows] = spec.problem.max_longitudinal_accel

    def _interval_rows(self, g: list, spec: PathFollowingSpec, tau: ca.SX, corners: ca.SX, Uw: ca.SX,
                       rates: ca.Function) -> ca.SX:
        """Append the interval rows ``±a(corner)_j − τ_j`` (``≤ A``; upper corner ``corners[0:2]``, lower
        ``corners[2:4]``) to ``g``; returns their slack cost ``Σ_j W_j (slack_penalty τ_j + τ_j²)``."""
        N = self.col.N
        for k, sign in ((0, 1.0), (2, -1.0)):
            Vp = rates(ca.vertcat(ca.DM.zeros(3, N), ca.repmat(corners[k:k + 2], 1, N)), Uw)
            g.append(sign * (Vp[0, :] * Vp[1, :]).T - tau)
        return ca.mtimes(ca.DM(self.col.W).T, spec.slack_penalty * tau + tau**2)

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
        p = np.concatenate([p, self._draw])
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

