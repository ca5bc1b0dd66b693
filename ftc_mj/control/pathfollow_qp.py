"""The real-time-iteration QP of the path-following problem: Gauss–Newton, states eliminated, dense."""

from __future__ import annotations

import numpy as np

from ..lazy import lazy_module
from .certified_qp import CertifiedQP
from .elimination import StateElimination, lateral_accel_linearisation
from .pathfollow_nlp import nlp_structure
from .pathfollow_spec import SLACK_MAX, PathFollowingSpec, RadiusInterval, lateral_sides
from .reference import Path, path_errors
from .solvers import BufferedFunction, default_qp_options
from .transcription import Collocation

ca = lazy_module("casadi")

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

    ``robust`` (the degraded mode, :class:`~ftc_mj.control.pathfollow_spec.RadiusInterval`): N more variables,
    the per-node slacks ``τ_j ≥ 0`` (m/s²) of the interval's rows, and 2N more rows at the end,
    ``a(hi_R, lo_L)_j − τ_j ≤ A`` and ``−a(lo_R, hi_L)_j − τ_j ≤ A`` (the robot's ``V psidot`` at the
    interval's two extreme corners, linearised like the model's rows), with the cost
    ``Σ_j W_j (slack_penalty τ_j + τ_j²)``. Per-node slacks (an exact L1 penalty) instead of the single σ:
    where the command in force violates the interval's bound, σ would be set by ``t0`` and leave the rest
    of the plan free up to that violation, whereas each ``τ_j`` is paid for, so the plan slows down as
    fast as the other rows allow until the bound holds at every radius of the interval.
    """

    def __init__(self, col: Collocation, spec: PathFollowingSpec, path: Path, qpsol: str = "daqp",
                 qp_options: dict | None = None, certified: bool | None = None, robust: bool = False) -> None:
        self.col, self.spec, self.path = col, spec, path
        N, h, pr = col.N, col.h, spec.problem
        if robust and pr.max_lateral_accel is None:
            raise ValueError("the degraded mode's interval rows need a lateral-acceleration bound")
        self.robust = bool(robust)
        self.i_sig = 3 * N  # index of σ; the robust slacks τ follow it
        self.n = n = 3 * N + 1 + (N if robust else 0)
        self.elim = StateElimination(col)
        self._J = BufferedFunction(col.rates_jac)
        self._J_cache: tuple[tuple[float, float], np.ndarray] | None = None
        W = col.W
        Dh = col.D / h
        # constant Hessian and gradient: wheel-rate rates, progress speed and its rate, slack
        H0 = np.zeros((n, n))
        self._rate_form = (Dh.T * W, Dh)  # the actuation-rate cost's factors; its weight is set per draw
        H0[2 * N:3 * N, 2 * N:3 * N] += 2.0 * spec.progress_rate_penalty * (Dh.T * W) @ Dh
        H0[2 * N:3 * N, 2 * N:3 * N] += np.diag(2.0 * spec.q_progress * W)
        H0[self.i_sig, self.i_sig] = 2.0
        g0 = np.zeros(n)  # the progress-speed part set per draw (set_problem)
        g0[self.i_sig] = spec.slack_penalty
        if robust:
            H0[3 * N + 1:, 3 * N + 1:] = np.diag(2.0 * W)
            g0[3 * N + 1:] = spec.slack_penalty * W
        self.H0, self.g0 = H0, g0
        self._sqW = np.sqrt(np.concatenate([spec.q_contour * W, spec.q_lag * W, spec.q_heading * W]))
        self.rate_lim = pr.omega_rate_max * h
        self.lbx = np.zeros(n)  # wheel-rate parts set per QP (wheel_bounds)
        self.ubx = np.concatenate([np.zeros(3 * N), SLACK_MAX * np.ones(n - 3 * N)])  # wheel rates per QP
        self.n_lat = (len(lateral_sides(spec)) * N + len(lateral_sides(spec, True))
                      if pr.max_lateral_accel is not None else 0)
        self.n_lon = N + 1 if pr.max_longitudinal_accel is not None else 0
        self.n_rob = 2 * N if robust else 0
        self.m = 4 + 2 * N + self.n_lat + self.n_lon + self.n_rob
        self.corner_slack = 0.0
        """Largest τ_j (m/s²) of the last robust QP solved (0 without the interval rows)."""
        self.certified = (qpsol == "daqp") if certified is None else bool(certified)
        self._cqp = CertifiedQP()
        opts = default_qp_options(qpsol)
        opts.update(qp_options or {})
        Hs, gs, As = ca.MX.sym("H", n, n), ca.MX.sym("g", n), ca.MX.sym("A", self.m, n)
        bl, bu, xl, xu, u0 = (ca.MX.sym(k, d) for k, d in (("lba", self.m), ("uba", self.m), ("lbx", n),
                                                            ("ubx", n), ("x0", n)))
        conic = ca.conic("pf_qp", qpsol, {"h": ca.Sparsity.dense(n, n), "a": ca.Sparsity.dense(self.m, n)}, opts)
        r = conic(h=Hs, g=gs, a=As, lba=bl, uba=bu, lbx=xl, ubx=xu, x0=u0)
        outs = [r["x"], r["cost"]] + ([r["lam_a"]] if robust else [])
        self._plugin = BufferedFunction(ca.Function("pf_rti_qp", [Hs, gs, As, bl, bu, xl, xu, u0], outs))
        self.path_counts: dict[str, int] = {}
        self._structure = nlp_structure(spec, path, robust)
        self.set_problem(spec, path)
        self.reset()

    def set_problem(self, spec: PathFollowingSpec, path: Path) -> None:
        """Build the QPs of ``spec`` on ``path`` from now on (a new draw): the same structure as the built one
        (:func:`~ftc_mj.control.pathfollow_nlp.nlp_structure`; ``ValueError`` otherwise), its desired speed,
        progress-speed bound and actuation-rate weight; the lateral bound and the braking trade are read at every
        build."""
        if nlp_structure(spec, path, self.robust) != self._structure:
            raise ValueError("the path-following QP was built for a problem of another structure")
        self.spec, self.path = spec, path
        N = self.col.N
        self.g0[2 * N:3 * N] = -2.0 * spec.q_progress * self.col.W * spec.desired_speed
        self.ubx[2 * N:3 * N] = spec.max_progress_speed
        R = 2.0 * spec.problem.rate_penalty * self._rate_form[0] @ self._rate_form[1]
        self.H0[:N, :N] = R
        self.H0[N:2 * N, N:2 * N] = R

    def reset(self) -> None:
        """Forget the active-set guess and the last robust QP's multipliers (a reused solver then behaves like a
        new one)."""
        self._ws: np.ndarray | None = None
        self._lam_rows: np.ndarray | None = None  # multipliers (m,) of the rows of the last robust QP

    def jacobian(self, radii: np.ndarray) -> np.ndarray:
        """``d[V, psidot]/d[omega_R, omega_L]`` (2, 2) for the radii (cached per radii)."""
        key = (float(radii[0]), float(radii[1]))
        if self._J_cache is None or self._J_cache[0] != key:
            self._J_cache = (key, self._J(radii)[0].reshape(2, 2, order="F").copy())
        return self._J_cache[1]

    def build(self, Xg: np.ndarray, Ug: np.ndarray, radii: np.ndarray, x0: np.ndarray,
              bounds: tuple[np.ndarray, np.ndarray], V_applied: float | None,
              interval: RadiusInterval | None = None) -> tuple[np.ndarray, ...]:
        """QP data about the guess ``(Xg (N,4), Ug (N,3))``: ``(H, g, A, lba, uba, lbx, ubx, G, hc)`` with
        the cost ``½ uᵀHu + gᵀu``, rows ``lba ≤ A u ≤ uba``, bounds ``lbx ≤ u ≤ ubx`` and the states
        ``X = G u + hc`` (4N: x, y, psi, s stacked). ``bounds``: the model's wheel-rate bounds
        (:func:`wheel_bounds`); ``V_applied`` (m/s): the speed of the applied command (None: none yet);
        ``interval``: the radius interval of the degraded mode (required by, and only used by, a robust QP)."""
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
        ec, el = path_errors(self.path, Xg[:, 0], Xg[:, 1], Xg[:, 3], pg)
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
                A[rows, self.i_sig] = -1.0
                lba[rows], uba[rows] = -np.inf, pr.max_lateral_accel - sl * lin0
            for q, (sl, so) in enumerate(lateral_sides(sp, True)):  # at t0, dV/dt from the applied command
                row = i + len(sides) * N + q
                c = so * sp.braking_trade / sp.sample_time
                A[row, [0, N]] = sl * np.array([gR[0], gL[0]]) + c * J[0]
                A[row, self.i_sig] = -1.0
                lba[row] = -np.inf
                uba[row] = np.inf if V_applied is None else pr.max_lateral_accel - sl * lin0[0] + c * V_applied
            i += self.n_lat
        if self.n_lon:
            self._longitudinal_rows(A, lba, uba, i, Lo, J, V_applied)
            i += self.n_lon
        if self.robust:
            if interval is None:
                raise ValueError("a robust path-following QP needs the radius interval")
            self._interval_rows(A, lba, uba, i, Ug, interval)
            self._lateral_curvature(H, g, Ug, radii, interval)
        lbx, ubx = self.lbx.copy(), self.ubx.copy()
        lbx[:2 * N], ubx[:2 * N] = bounds
        return H, g, A, lba, uba, lbx, ubx, G, hc

    def _longitudinal_rows(self, A: np.ndarray, lba: np.ndarray, uba: np.ndarray, i: int, Lo: np.ndarray,
                           J: np.ndarray, V_applied: float | None) -> None:
        """Rows ``i … i + N`` (in place): ``|dV/dt| ≤ max_longitudinal_accel`` at the nodes (``Lo`` (N, 2N) maps the
        wheel rates to dV/dt) and the speed at t0 within ``max_longitudinal_accel T_s`` of the applied command's
        (open without one); ``J`` is ``d[V, psidot]/d[omega_R, omega_L]``."""
        N, amax = self.col.N, self.spec.problem.max_longitudinal_accel
        A[i:i + N, :2 * N] = Lo
        lba[i:i + N], uba[i:i + N] = -amax, amax
        A[i + N, 0], A[i + N, N] = J[0, 0], J[0, 1]
        V_app = 0.0 if V_applied is None else V_applied
        dv = np.inf if V_applied is None else amax * self.spec.sample_time
        lba[i + N], uba[i + N] = V_app - dv, V_app + dv

    def _interval_rows(self, A: np.ndarray, lba: np.ndarray, uba: np.ndarray, i: int, Ug: np.ndarray,
                       interval: RadiusInterval) -> None:
        """Rows ``i … i + 2N`` (in place): the robot's lateral acceleration at the interval's corner of largest
        ``a`` bounded above and at its corner of smallest ``a`` bounded below, each with its node's slack
        ``τ_j``, linearised about the guess's wheel rates ``Ug`` (N, 2) (rad/s)."""
        N, A_max = self.col.N, self.spec.problem.max_lateral_accel
        j = np.arange(N)
        for q, (corner, sign) in enumerate(zip(interval.corners(), (1.0, -1.0), strict=True)):
            gR, gL, lin0 = lateral_accel_linearisation(Ug[:, :2], self.jacobian(corner))
            rows = i + q * N + j
            A[rows, j] = sign * gR
            A[rows, N + j] = sign * gL
            A[rows, 3 * N + 1 + j] = -1.0
            lba[rows], uba[rows] = -np.inf, A_max - sign * lin0

    def _lateral_curvature(self, H: np.ndarray, g: np.ndarray, Ug: np.ndarray, radii: np.ndarray,
                           interval: RadiusInterval) -> None:
        """Add (in place) the convex part of the curvature of the rows that bound the lateral acceleration, the
        model's (at ``radii``, m) and the interval's (at its corners), weighted by their multipliers of the previous
        QP, about the guess's wheel rates ``Ug`` (N, 2) (rad/s). A row ``±a(R_R, R_L)`` has the diagonal Hessian
        ``±(R_R², −R_L²)/(2b)`` in (omega_R, omega_L) (the braking term is linear), and its positive entry becomes
        the term ``½ c (omega − omega_g)²`` of the QP. Gauss–Newton alone leaves out this curvature; with
        multipliers of the order of the slack penalty its RTI iterates then cycle from one side of the interval
        row to the other instead of converging (measured on the test's braking plan).

        The model's rows count as well: where the radii are a corner of the interval (an interval with the
        estimate at one end) a node's model row and interval row are one row with two slacks (σ and τ_j), the
        active set holds both, and only the sum of their multipliers is determined. How a QP solver splits it
        is decided by round-off; weighted by the interval rows' share alone, that split set the next QP's
        Hessian, and the closed loop amplified the round-off (the same loop braked to a stop and reversed, or
        did not, by the order of a sum). The sum sets it now."""
        if self._lam_rows is None:
            return
        N, b = self.col.N, self.spec.problem.half_track
        lam = np.maximum(self._lam_rows, 0.0)
        up, lo = interval.corners()
        rob = self.m - self.n_rob
        cR = lam[rob:rob + N] * up[0] ** 2 / (2.0 * b)  # upper corner (row +a): + R_R² on omega_R
        cL = lam[rob + N:rob + 2 * N] * lo[1] ** 2 / (2.0 * b)  # lower corner (row −a): + R_L² on omega_L
        i = 4 + 2 * N  # the model's lateral rows
        sides = lateral_sides(self.spec)
        for q, (sl, _) in enumerate((*sides, *lateral_sides(self.spec, True))):
            nodes = slice(0, N) if q < len(sides) else slice(0, 1)  # the rows at t0 are node 0's
            lq = lam[i + q * N:i + (q + 1) * N] if q < len(sides) else lam[i + len(sides) * N + q - len(sides)]
            if sl > 0:
                cR[nodes] += lq * radii[0] ** 2 / (2.0 * b)
            else:
                cL[nodes] += lq * radii[1] ** 2 / (2.0 * b)
        j = np.arange(N)
        H[j, j] += cR
        H[N + j, N + j] += cL
        g[:N] -= cR * Ug[:, 0]
        g[N:2 * N] -= cL * Ug[:, 1]

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
                self._lam_a = res.lam_a
                return True, "optimal (certified active set)", res.u
            if res.status == "infeasible":
                self.path_counts["farkas"] = self.path_counts.get("farkas", 0) + 1
                self._ws = None
                return False, "infeasible (Farkas certificate)", None
        self._ws = None
        self.path_counts["plugin"] = self.path_counts.get("plugin", 0) + 1
        out = self._plugin(H, g, A, lba, uba, lbx, ubx, np.clip(u0, lbx, ubx))
        u = out[0].copy()
        self._lam_a = out[2].ravel().copy() if self.robust else None
        st = self._plugin.stats()
        ok = self._plugin.ret == 0 and bool(st.get("success", True)) and bool(np.all(np.isfinite(u)))
        return ok, str(st.get("return_status", "ok" if ok else "qp failed")), u if ok else None

    def solve(self, Xg: np.ndarray, Ug: np.ndarray, radii: np.ndarray, x0: np.ndarray,
              bounds: tuple[np.ndarray, np.ndarray], V_applied: float | None,
              interval: RadiusInterval | None = None
              ) -> tuple[bool, str, np.ndarray | None, np.ndarray | None, float]:
        """Build (:meth:`build`) and solve the QP. Returns ``(ok, status, X (N,4), U (N,3), σ)``; the solution
        is checked independently against the rows and bounds (solvers differ in what they call success)."""
        N = self.col.N
        H, g, A, lba, uba, lbx, ubx, G, hc = self.build(Xg, Ug, radii, x0, bounds, V_applied, interval)
        u0 = np.concatenate([Ug.T.ravel(), np.zeros(self.n - 3 * N)])
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
            self._lam_rows = None
            return False, status, None, None, float("nan")
        assert u is not None
        if self.robust and self._lam_a is not None:
            self._lam_rows = np.asarray(self._lam_a, float).ravel().copy()
        u = np.clip(u, lbx, ubx)
        X = (G @ u + hc).reshape(4, N).T
        self.corner_slack = float(u[3 * N + 1:].max()) if self.robust else 0.0
        return True, status, X, u[:3 * N].reshape(3, N).T, float(u[self.i_sig])
