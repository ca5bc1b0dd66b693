"""The real-time-iteration QP of the path-following problem: Gauss–Newton, states eliminated, dense."""

from __future__ import annotations

import casadi as ca
import numpy as np

from .certified_qp import CertifiedQP
from .elimination import StateElimination, lateral_accel_linearisation
from .pathfollow_spec import SLACK_MAX, PathFollowingSpec, lateral_sides
from .reference import Path, path_errors
from .solvers import BufferedFunction, default_qp_options
from .transcription import Collocation

ROW_FAR = 1.0e6
"""Finite stand-in (m/s²) for the open side of a one-sided row in the certified QP path."""


class PathQP:
    """One real-time iteration: the Gauss–Newton QP of the path-following problem about a guess.

    Rows of ``A u`` (in this order): the 4 node-0 collocation equalities (x, y, psi, s), the 2N
    wheel-rate rate rows ``|D omega| ≤ omega_rate_max T/2``, the 4N linearised traction
    rows ``s_lat a + s_lon β dV/dt − σ ≤ A`` (:func:`lateral_sides`; 2N rows when ``β = 0``) and, with
    ``β > 0``, the same four at ``t0`` with ``dV/dt = (V(t0) − V_applied)/T_s``, the N longitudinal rows
    ``|J_V D omega / h| ≤ max_longitudinal_accel`` and one row ``|V(t0) − V(u_applied)| ≤
    max_longitudinal_accel T_s``. Bounds: the model's wheel rates (:func:`wheel_bounds`), progress speed,
    slack. ``path_counts`` counts how each QP was
    decided (``guess``/``ipm``/``farkas`` by the certified path, ``plugin``).
    """

    def __init__(self, col: Collocation, spec: PathFollowingSpec, path: Path, qpsol: str = "daqp",
                 qp_options: dict | None = None, certified: bool | None = None) -> None:
        self.col, self.spec, self.path = col, spec, path
        N, h, pr = col.N, col.h, spec.problem
        self.n = n = 3 * N + 1
        self.elim = StateElimination(col)
        self._J = BufferedFunction(col.rates_jac)
        self._J_cache: tuple[tuple[float, float], np.ndarray] | None = None
        W = col.W
        Dh = col.D / h
        # constant Hessian and gradient: wheel-rate rates, progress speed and its rate, slack
        H0 = np.zeros((n, n))
        R = 2.0 * pr.rate_penalty * (Dh.T * W) @ Dh
        H0[:N, :N] += R
        H0[N:2 * N, N:2 * N] += R
        H0[2 * N:3 * N, 2 * N:3 * N] += 2.0 * spec.progress_rate_penalty * (Dh.T * W) @ Dh
        H0[2 * N:3 * N, 2 * N:3 * N] += np.diag(2.0 * spec.q_progress * W)
        H0[-1, -1] = 2.0
        g0 = np.zeros(n)
        g0[2 * N:3 * N] = -2.0 * spec.q_progress * W * spec.desired_speed
        g0[-1] = spec.slack_penalty
        self.H0, self.g0 = H0, g0
        self._sqW = np.sqrt(np.concatenate([spec.q_contour * W, spec.q_lag * W, spec.q_heading * W]))
        self.rate_lim = pr.omega_rate_max * h
        self.lbx = np.concatenate([np.zeros(3 * N), [0.0]])  # wheel-rate parts set per QP (wheel_bounds)
        self.ubx = np.concatenate([np.zeros(2 * N), spec.max_progress_speed * np.ones(N), [SLACK_MAX]])
        self.n_lat = (len(lateral_sides(spec)) * N + len(lateral_sides(spec, True))
                      if pr.max_lateral_accel is not None else 0)
        self.n_lon = N + 1 if pr.max_longitudinal_accel is not None else 0
        self.m = 4 + 2 * N + self.n_lat + self.n_lon
        self.certified = (qpsol == "daqp") if certified is None else bool(certified)
        self._cqp = CertifiedQP()
        opts = default_qp_options(qpsol)
        opts.update(qp_options or {})
        Hs, gs, As = ca.MX.sym("H", n, n), ca.MX.sym("g", n), ca.MX.sym("A", self.m, n)
        bl, bu, xl, xu, u0 = (ca.MX.sym(k, d) for k, d in (("lba", self.m), ("uba", self.m), ("lbx", n),
                                                            ("ubx", n), ("x0", n)))
        conic = ca.conic("pf_qp", qpsol, {"h": ca.Sparsity.dense(n, n), "a": ca.Sparsity.dense(self.m, n)}, opts)
        r = conic(h=Hs, g=gs, a=As, lba=bl, uba=bu, lbx=xl, ubx=xu, x0=u0)
        self._plugin = BufferedFunction(ca.Function("pf_rti_qp", [Hs, gs, As, bl, bu, xl, xu, u0],
                                                    [r["x"], r["cost"]]))
        self.path_counts: dict[str, int] = {}
        self.reset()

    def reset(self) -> None:
        """Forget the active-set guess (a reused solver then behaves like a new one)."""
        self._ws: np.ndarray | None = None

    def jacobian(self, radii: np.ndarray) -> np.ndarray:
        """``d[V, psidot]/d[omega_R, omega_L]`` (2, 2) for the radii (cached per radii)."""
        key = (float(radii[0]), float(radii[1]))
        if self._J_cache is None or self._J_cache[0] != key:
            self._J_cache = (key, self._J(radii)[0].reshape(2, 2, order="F").copy())
        return self._J_cache[1]

    def build(self, Xg: np.ndarray, Ug: np.ndarray, radii: np.ndarray, x0: np.ndarray,
              bounds: tuple[np.ndarray, np.ndarray], V_applied: float | None) -> tuple[np.ndarray, ...]:
        """QP data about the guess ``(Xg (N,4), Ug (N,3))``: ``(H, g, A, lba, uba, lbx, ubx, G, hc)`` with
        the cost ``½ uᵀHu + gᵀu``, rows ``lba ≤ A u ≤ uba``, bounds ``lbx ≤ u ≤ ubx`` and the states
        ``X = G u + hc`` (4N: x, y, psi, s stacked). ``bounds``: the model's wheel-rate bounds
        (:func:`wheel_bounds`); ``V_applied`` (m/s): the speed of the applied command (None: none yet)."""
        col, sp, N, n = self.col, self.spec, self.col.N, self.n
        pr = sp.problem
        Gp, hp, E, e = self.elim.pose(Xg[:, :3], Ug[:, :2], radii, x0[:3])
        Gs, hs, Es, es = self.elim.integrator(float(x0[3]))
        G = np.zeros((4 * N, n))
        G[:3 * N, :2 * N] = Gp.reshape(3 * N, 2 * N)
        G[3 * N:, 2 * N:3 * N] = Gs
        hc = np.concatenate([hp.ravel(), hs])
        # Gauss-Newton residuals e_c, e_l, psi - theta linearised in (x, y, psi, s) at the guess
        pg = self.path.geometry(Xg[:, 3])
        ec, el = path_errors(self.path, Xg[:, 0], Xg[:, 1], Xg[:, 3])
        c, s, k = np.cos(pg.heading), np.sin(pg.heading), pg.curvature
        grads = ((-s, c, 0.0 * k, -k * el), (c, s, 0.0 * k, k * ec - 1.0), (0.0 * k, 0.0 * k, 1.0 + 0.0 * k, -k))
        r0 = (ec, el, Xg[:, 2] - pg.heading)
        M = np.empty((3 * N, n))
        m = np.empty(3 * N)
        Xs = [G[i * N:(i + 1) * N] for i in range(4)]
        dh = [hc[i * N:(i + 1) * N] - Xg[:, i] for i in range(4)]
        for j, (gr, r) in enumerate(zip(grads, r0, strict=True)):
            M[j * N:(j + 1) * N] = sum(gi[:, None] * Xi for gi, Xi in zip(gr, Xs, strict=True))
            m[j * N:(j + 1) * N] = r + sum(gi * di for gi, di in zip(gr, dh, strict=True))
        Mw = M * self._sqW[:, None]
        H = 2.0 * (Mw.T @ Mw) + self.H0
        g = 2.0 * (Mw.T @ (m * self._sqW)) + self.g0
        # rows
        A = np.zeros((self.m, n))
        lba, uba = np.empty(self.m), np.empty(self.m)
        A[:3, :2 * N] = E
        A[3, 2 * N:3 * N] = Es
        lba[:4] = uba[:4] = np.concatenate([e, [es]])
        i = 4
        A[i:i + N, :N] = col.D
        A[i + N:i + 2 * N, N:2 * N] = col.D
        lba[i:i + 2 * N], uba[i:i + 2 * N] = -self.rate_lim, self.rate_lim
        i += 2 * N
        J = self.jacobian(radii)
        Dh = col.D / col.h
        Lo = np.hstack([J[0, 0] * Dh, J[0, 1] * Dh])  # dV/dt at the nodes (N, 2N)
        if self.n_lat:
            gR, gL, lin0 = lateral_accel_linearisation(Ug[:, :2], J)
            j = np.arange(N)
            sides = lateral_sides(sp)
            for q, (sl, so) in enumerate(sides):  # sl a + so β dV/dt − σ ≤ A, a linearised
                rows = i + q * N + j
                A[rows, :2 * N] = (so * sp.braking_trade) * Lo
                A[rows, j] += sl * gR
                A[rows, N + j] += sl * gL
                A[rows, -1] = -1.0
                lba[rows], uba[rows] = -np.inf, pr.max_lateral_accel - sl * lin0
            for q, (sl, so) in enumerate(lateral_sides(sp, True)):  # at t0, dV/dt from the applied command
                row = i + len(sides) * N + q
                c = so * sp.braking_trade / sp.sample_time
                A[row, [0, N]] = sl * np.array([gR[0], gL[0]]) + c * J[0]
                A[row, -1] = -1.0
                lba[row] = -np.inf
                uba[row] = np.inf if V_applied is None else pr.max_lateral_accel - sl * lin0[0] + c * V_applied
            i += self.n_lat
        if self.n_lon:
            amax = pr.max_longitudinal_accel
            A[i:i + N, :2 * N] = Lo
            lba[i:i + N], uba[i:i + N] = -amax, amax
            # speed at t0 within a_max T_s of the speed of the applied command (open without one)
            A[i + N, 0], A[i + N, N] = J[0, 0], J[0, 1]
            V_app = 0.0 if V_applied is None else V_applied
            dv = np.inf if V_applied is None else amax * sp.sample_time
            lba[i + N], uba[i + N] = V_app - dv, V_app + dv
        lbx, ubx = self.lbx.copy(), self.ubx.copy()
        lbx[:2 * N], ubx[:2 * N] = bounds
        return H, g, A, lba, uba, lbx, ubx, G, hc

    def solve_qp(self, H: np.ndarray, g: np.ndarray, A: np.ndarray, lba: np.ndarray, uba: np.ndarray,
                 lbx: np.ndarray, ubx: np.ndarray, u0: np.ndarray) -> tuple[bool, str, np.ndarray | None]:
        """The certified active-set path first (when enabled), the CasADi plugin for what it leaves
        unresolved. The one-sided lateral rows carry an infinite bound; the certified path gets it as
        ``±ROW_FAR`` (finite, never active: |a| ≤ omega_max² R² / b ≪ ROW_FAR). Returns ``(ok, status, u)``."""
        if self.certified:
            res = self._cqp.solve(H, g, A, np.maximum(lba, -ROW_FAR), np.minimum(uba, ROW_FAR), lbx, ubx,
                                  self._ws)
            if res.status == "optimal":
                self.path_counts[res.path] = self.path_counts.get(res.path, 0) + 1
                self._ws = res.working_set
                return True, "optimal (certified active set)", res.u
            if res.status == "infeasible":
                self.path_counts["farkas"] = self.path_counts.get("farkas", 0) + 1
                self._ws = None
                return False, "infeasible (Farkas certificate)", None
        self._ws = None
        self.path_counts["plugin"] = self.path_counts.get("plugin", 0) + 1
        u = self._plugin(H, g, A, lba, uba, lbx, ubx, np.clip(u0, lbx, ubx))[0].copy()
        st = self._plugin.stats()
        ok = self._plugin.ret == 0 and bool(st.get("success", True)) and bool(np.all(np.isfinite(u)))
        return ok, str(st.get("return_status", "ok" if ok else "qp failed")), u if ok else None

    def solve(self, Xg: np.ndarray, Ug: np.ndarray, radii: np.ndarray, x0: np.ndarray,
              bounds: tuple[np.ndarray, np.ndarray], V_applied: float | None
              ) -> tuple[bool, str, np.ndarray | None, np.ndarray | None, float]:
        """Build (:meth:`build`) and solve the QP. Returns ``(ok, status, X (N,4), U (N,3), σ)``; the solution
        is checked independently against the rows and bounds (solvers differ in what they call success)."""
        N = self.col.N
        H, g, A, lba, uba, lbx, ubx, G, hc = self.build(Xg, Ug, radii, x0, bounds, V_applied)
        u0 = np.concatenate([Ug.T.ravel(), [0.0]])
        ok, status, u = self.solve_qp(H, g, A, lba, uba, lbx, ubx, u0)
        if ok:
            assert u is not None
            Au = A @ u
            tol = 1e-5 * (1.0 + np.abs(lba[:4]).max())
            ok = bool(np.abs(Au[:4] - lba[:4]).max() < tol
                      and np.all(Au[4:] >= lba[4:] - 1e-6 * (1 + np.abs(np.nan_to_num(lba[4:], neginf=0.0))))
                      and np.all(Au[4:] <= uba[4:] + 1e-6 * (1 + np.abs(np.nan_to_num(uba[4:], posinf=0.0))))
                      and np.all(u >= lbx - 1e-6 * (1 + np.abs(lbx))) and np.all(u <= ubx + 1e-6 * (1 + np.abs(ubx))))
            if not ok:
                status = f"{status}; solution violates its constraints"
        if not ok:
            self._ws = None
            return False, status, None, None, float("nan")
        assert u is not None
        u = np.clip(u, lbx, ubx)
        X = (G @ u + hc).reshape(4, N).T
        return True, status, X, u[:3 * N].reshape(3, N).T, float(u[-1])
