"""The real-time-iteration QP of the tracking problem: linearised, states eliminated, dense in the inputs."""

from __future__ import annotations

import contextlib
from collections import Counter
from collections.abc import Iterator

import numpy as np

from ..lazy import lazy_module
from .certified_qp import CertifiedQP
from .elimination import StateElimination, lateral_accel_linearisation
from .kernels import tracking_cost
from .solvers import BufferedFunction, default_qp_options
from .spec import first_input_bounds, first_step_penalty
from .transcription import Collocation

ca = lazy_module("casadi")


class CondensedQP:
    """Linearise the collocation about a guess, eliminate the states, solve the dense input QP.

    ``qpsol`` is any CasADi conic plugin (``daqp``, ``qpoases``, ``osqp``, ``piqp``, ...). The QP
    solver is wrapped in an MX Function together with the constant rate-constraint rows and called
    through :class:`BufferedFunction` (no per-element conversions).

    With ``certified`` (the default for ``daqp``) the QP is first solved by
    :class:`~ftc_mj.control.certified_qp.CertifiedQP`: the previous sample's active set, else the one
    read off an interior-point solve, is solved exactly and accepted with a KKT certificate (or the
    QP is declared infeasible with a Farkas certificate); only an unresolved QP goes to the CasADi
    plugin. The result equals the plugin's within the solvers' tolerances; the saturated loops, where
    DAQP needs hundreds of active-set iterations, get much cheaper. ``path_counts`` counts how each
    QP was decided (``guess``, ``ipm``, ``farkas``, ``plugin``).

    Constraint rows (``A u`` in the order of ``lam_a``): the 3 node-0 collocation equalities, the 2N
    rate rows, then the optional N lateral- and N longitudinal-acceleration rows. :meth:`_rows` assembles them densely
    for the certified path; a new block of rows goes there and into the plugin's ``A`` alike. The box
    ``lbx ≤ u ≤ ubx`` is an input of both paths (:meth:`input_bounds`): ``±omega_max``, tightened on the
    two first inputs by the bound from the input in force (:func:`first_input_bounds`).
    """

    def __init__(self, col: Collocation, qpsol: str = "daqp", qp_options: dict | None = None,
                 certified: bool | None = None) -> None:
        self.col = col
        N, h, D = col.N, col.h, col.D
        n = 2 * N
        self.nu = n
        self.elim = StateElimination(col)
        Dblk = np.zeros((n, n))
        Dblk[:N, :N] = D
        Dblk[N:, N:] = D
        self.Dblk = Dblk
        sp = col.spec
        # rate penalty: (T/2) Σ w ‖(1/h) D u‖² -> u' (Dblk' diag(W) Dblk)/h² u
        Wd = np.concatenate([col.W, col.W])
        self.R_rate = 2.0 * sp.rate_penalty * (Dblk.T * Wd) @ Dblk / h**2
        self._qW3 = sp.q_pose * np.tile(col.W, 3)  # pose-error weights of the stacked states (x, y, psi)
        self._q = np.array([sp.q_speed, sp.q_yaw_rate], dtype=float)  # speed and yaw-rate error weights
        self._no_prev = np.zeros(2)  # u_prev's place when there is none (the first-step penalty is then 0)
        self.qpsol = qpsol
        opts = default_qp_options(qpsol)
        opts.update(qp_options or {})
        self.a_lat = sp.max_lateral_accel
        self.a_lon = sp.max_longitudinal_accel
        n_lat = N if self.a_lat is not None else 0
        n_lon = N if self.a_lon is not None else 0
        nA = 3 + n + n_lat + n_lon
        a_pattern = np.zeros((nA, n), dtype=bool)
        a_pattern[:3] = True
        a_pattern[3:3 + n] = Dblk != 0
        idx = np.arange(n_lat)
        a_pattern[3 + n + idx, idx] = True
        a_pattern[3 + n + idx, N + idx] = True
        a_pattern[3 + n + n_lat:] = True
        rows, cols = np.nonzero(a_pattern)
        a_sp = ca.Sparsity.triplet(nA, n, rows.tolist(), cols.tolist())
        self.solver = ca.conic("qp", qpsol, {"h": ca.Sparsity.dense(n, n), "a": a_sp}, opts)
        rate = sp.omega_rate_max * h
        Hs, gs = ca.MX.sym("H", n, n), ca.MX.sym("g", n)
        Es, es = ca.MX.sym("E", 3, n), ca.MX.sym("e", 3)
        xs, lxs, las = ca.MX.sym("x0", n), ca.MX.sym("lam_x0", n), ca.MX.sym("lam_a0", nA)
        # lateral-acceleration rows: row j holds d(V psidot)_j/d[omega_R,j, omega_L,j] (nonzeros Lv),
        # bounds [ll, lu] from the linearisation
        Lv, ll, lu = ca.MX.sym("Lv", 2 * n_lat), ca.MX.sym("ll", n_lat), ca.MX.sym("lu", n_lat)
        lat_sp = ca.Sparsity.triplet(n_lat, n, np.concatenate([idx, idx]).tolist(),
                                     np.concatenate([idx, N + idx]).tolist())
        # longitudinal-acceleration rows dV/dt = J_V (D/h) u (dense N x 2N, values depend on the radii)
        Lo = ca.MX.sym("Lo", n_lon, n)
        lbxs, ubxs = ca.MX.sym("lbx", n), ca.MX.sym("ubx", n)
        A = ca.vertcat(Es, ca.DM(Dblk), ca.MX(lat_sp, Lv), Lo)
        lon_b = (self.a_lon or 0.0) * np.ones(n_lon)
        r = self.solver(
            h=Hs, g=gs, a=A, lba=ca.vertcat(es, -rate * np.ones(n), ll, -lon_b),
            uba=ca.vertcat(es, rate * np.ones(n), lu, lon_b),
            lbx=lbxs, ubx=ubxs, x0=xs, lam_x0=lxs, lam_a0=las,
        )
        self._qpfun = BufferedFunction(
            ca.Function("rti_qp", [Hs, gs, Es, es, Lv, ll, lu, Lo, lbxs, ubxs, xs, lxs, las],
                        [r["x"], r["lam_x"], r["lam_a"], r["cost"]])
        )
        self._J = BufferedFunction(col.rates_jac)
        self._J_cache: tuple[tuple[float, float], np.ndarray] | None = None
        self.omega_max = sp.omega_max
        self.rate_lim = rate
        self._lam_x = np.zeros(n)
        self._lam_a = np.zeros(nA)
        self.certified = (qpsol == "daqp") if certified is None else bool(certified)
        self._cqp = CertifiedQP()
        self._ws: np.ndarray | None = None  # working set of the last certified solution (the next guess)
        self.path_counts: Counter[str] = Counter()

    def reset(self) -> None:
        """Forget the dual warm start and the active-set guess (a reused solver then behaves exactly
        like a new one)."""
        self._lam_x[:] = 0.0
        self._lam_a[:] = 0.0
        self._ws = None

    # ----------------------------------------------------------------------------------------
    def build(self, Xg: np.ndarray, Ug: np.ndarray, radii: np.ndarray, x0: np.ndarray, ref: np.ndarray,
              u_prev: np.ndarray | None = None):
        """QP data for the linearisation about (Xg (N,3), Ug (N,2)).

        ``ref`` is (5, N): x, y, psi, V, psidot references at the nodes; ``u_prev`` (rad/s, (2,) or
        ``None``) the input in force before ``t0``, for the first-step rate penalty. Returns
        ``(H, g, E, e, G, hc)``: cost ``½ uᵀHu + gᵀu``, node-0 collocation rows ``E u = e``, and the
        states ``X = G u + hc`` (3N, stacked x, y, psi).
        """
        col, N = self.col, self.col.N
        sp = col.spec
        G, hc, E, e = self.elim.pose(Xg, Ug, radii, x0)
        key = (float(radii[0]), float(radii[1]))
        if self._J_cache is None or self._J_cache[0] != key:
            self._J_cache = (key, self._J(radii)[0].reshape(2, 2, order="F").copy())
        J = self._J_cache[1]  # d[V, psidot]/du, constant for given radii
        n = 2 * N
        H, g = np.empty((n, n)), np.empty(n)
        up = self._no_prev if u_prev is None else np.ascontiguousarray(u_prev, dtype=float)
        tracking_cost(G, hc, np.ascontiguousarray(ref, dtype=float), col.W, self._qW3, J, self._q, self.R_rate,
                      float(first_step_penalty(sp, u_prev)), up, H, g)
        Gf = G.reshape(3 * N, n)
        return H, g, E, e, Gf, hc.ravel()

    def input_bounds(self, u_prev: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """Box ``lbx ≤ u ≤ ubx`` (rad/s, (2N,)): ``±omega_max``, with the first inputs (``u[0]`` =
        omega_R, ``u[N]`` = omega_L at ``t0``) tightened to :func:`first_input_bounds` of ``u_prev``."""
        lo, hi = first_input_bounds(self.col.spec, u_prev)
        lbx = np.full(self.nu, -self.omega_max)
        ubx = np.full(self.nu, self.omega_max)
        lbx[[0, self.col.N]] = lo
        ubx[[0, self.col.N]] = hi
        return lbx, ubx

    def lateral_rows(self, Ug: np.ndarray, radii: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Linearised bound ``ll ≤ L u ≤ lu`` of ``|V psidot| ≤ max_lateral_accel`` about ``Ug`` (N,2).
        Returns the nonzeros of ``L`` (column-major: all d/d omega_R, then all d/d omega_L) and the
        bounds; empty arrays without a bound."""
        if self.a_lat is None:
            return np.zeros(0), np.zeros(0), np.zeros(0)
        J = self._J_cache[1] if self._J_cache is not None else self._J(radii)[0].reshape(2, 2, order="F")
        gR, gL, lin0 = lateral_accel_linearisation(Ug, J)
        return np.concatenate([gR, gL]), -self.a_lat - lin0, self.a_lat - lin0

    def longitudinal_rows(self) -> np.ndarray:
        """Rows (N, 2N) of ``dV/dt`` at the nodes in the inputs for the current radii (empty without a bound):
        ``V = J_V u`` node by node, so ``dV/dt = J_V (D/h) u``."""
        if self.a_lon is None:
            return np.zeros((0, self.nu))
        J = self._J_cache[1]
        Dh = self.col.D / self.col.h
        return np.hstack([J[0, 0] * Dh, J[0, 1] * Dh])

    @contextlib.contextmanager
    def recording(self) -> Iterator[list[list[np.ndarray]]]:
        """Record the data ``[H, g, E, e, Lv, ll, lu, Lo, lbx, ubx]`` of every QP solved inside the block
        (for tests and benchmarks that replay them through both solve paths: ``solve_qp(*q, u0)``)."""
        rec: list[list[np.ndarray]] = []
        build, lateral, longitudinal, box = self.build, self.lateral_rows, self.longitudinal_rows, self.input_bounds

        def build_rec(*a):
            out = build(*a)
            rec.append([np.copy(x) for x in out[:4]])
            return out

        def lateral_rec(*a):
            out = lateral(*a)
            rec[-1].extend(np.copy(x) for x in out)
            return out

        def longitudinal_rec():
            out = longitudinal()
            rec[-1].append(np.copy(out))
            return out

        def box_rec(*a):
            out = box(*a)
            rec[-1].extend(np.copy(x) for x in out)
            return out

        self.build, self.lateral_rows, self.longitudinal_rows = build_rec, lateral_rec, longitudinal_rec
        self.input_bounds = box_rec
        try:
            yield rec
        finally:
            del self.build, self.lateral_rows, self.longitudinal_rows, self.input_bounds

    def _rows(self, E: np.ndarray, e: np.ndarray, Lv: np.ndarray, ll: np.ndarray, lu: np.ndarray,
              Lo: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Dense constraint rows ``lba ≤ A u ≤ uba`` (same rows and order as the plugin's ``A``):
        node-0 collocation equalities, rate rows ``|D u| ≤ rate`` (rad/s per unit tau), lateral rows,
        longitudinal rows."""
        N, n = self.col.N, self.nu
        n_lat = ll.size
        n_lon = Lo.shape[0]
        A = np.empty((3 + n + n_lat + n_lon, n))
        A[:3] = E
        A[3:3 + n] = self.Dblk
        if n_lat:
            Lat = A[3 + n:]
            Lat[:] = 0.0
            j = np.arange(n_lat)
            Lat[j, j] = Lv[:N]
            Lat[j, N + j] = Lv[N:]
        if n_lon:
            A[3 + n + n_lat:] = Lo
        r = np.full(n, self.rate_lim)
        lon = np.full(n_lon, self.a_lon or 0.0)
        return A, np.concatenate([e, -r, ll, -lon]), np.concatenate([e, r, lu, lon])

    def _solve_certified(self, H: np.ndarray, g: np.ndarray, E: np.ndarray, e: np.ndarray, Lv: np.ndarray,
                         ll: np.ndarray, lu: np.ndarray, Lo: np.ndarray, lbx: np.ndarray, ubx: np.ndarray
                         ) -> tuple[str, np.ndarray | None, np.ndarray | None, np.ndarray | None]:
        """The certified path: ``(verdict, u, lam_x, lam_a)`` with verdict ``optimal``/``infeasible``/
        ``unresolved``."""
        A, lba, uba = self._rows(E, e, Lv, ll, lu, Lo)
        res = self._cqp.solve(H, g, A, lba, uba, lbx, ubx, self._ws)
        if res.status == "unresolved":
            return "unresolved", None, None, None
        self.path_counts[res.path] += 1
        self._ws = res.working_set
        return res.status, res.u, res.lam_x, res.lam_a

    def solve_qp(self, H: np.ndarray, g: np.ndarray, E: np.ndarray, e: np.ndarray, Lv: np.ndarray, ll: np.ndarray,
                 lu: np.ndarray, Lo: np.ndarray, lbx: np.ndarray, ubx: np.ndarray, u0: np.ndarray
                 ) -> tuple[bool, dict, np.ndarray, np.ndarray | None, np.ndarray | None]:
        """Solve one built QP (the data :meth:`build`, :meth:`lateral_rows`, :meth:`longitudinal_rows`
        and :meth:`input_bounds` return): the certified path first when enabled, the CasADi plugin
        (primal guess ``u0``) for what it leaves unresolved. Returns ``(ok, stats, u, lam_x, lam_a)``;
        ``ok`` is the solver's verdict, before :meth:`solve`'s independent feasibility check."""
        if self.certified:
            verdict, u, lam_x, lam_a = self._solve_certified(H, g, E, e, Lv, ll, lu, Lo, lbx, ubx)
            if verdict == "infeasible":
                return False, {"success": False, "return_status": "infeasible (Farkas certificate)"}, \
                    np.full(self.nu, np.nan), None, None
            if verdict == "optimal":
                assert u is not None
                return True, {"success": True, "return_status": "optimal (certified active set)"}, u, lam_x, lam_a
        u, lam_x, lam_a, _ = self._qpfun(H, g, E, e, Lv, ll, lu, Lo, lbx, ubx, u0, self._lam_x, self._lam_a)
        st = self._qpfun.stats()
        ok = self._qpfun.ret == 0 and bool(st.get("success", True)) and bool(np.all(np.isfinite(u)))
        self.path_counts["plugin"] += 1
        self._ws = None
        return ok, st, u, lam_x, lam_a

    def solve(self, Xg, Ug, radii, x0, ref, u_init: np.ndarray | None = None, u_prev: np.ndarray | None = None):
        """Build and solve the QP; ``u_prev`` (rad/s, (2,)) is the input in force before ``t0`` (``None``:
        no first-step bound or penalty). Returns ``(ok, status, X (N,3), U (N,2))``."""
        N = self.col.N
        H, g, E, e, G, hc = self.build(Xg, Ug, radii, x0, ref, u_prev)
        Lv, ll, lu = self.lateral_rows(Ug, radii)
        Lo = self.longitudinal_rows()
        lbx, ubx = self.input_bounds(u_prev)
        if u_init is None:
            u_init = Ug.T.ravel()
        u0 = np.clip(u_init, lbx, ubx)
        ok, st, u, lam_x, lam_a = self.solve_qp(H, g, E, e, Lv, ll, lu, Lo, lbx, ubx, u0)
        if ok:  # independent feasibility check (solvers differ in what they call success)
            tol = 1e-5 * (1.0 + np.abs(e).max())
            box_tol = 1e-6 * (1.0 + self.omega_max)
            ok = (np.abs(E @ u - e).max() < tol and np.abs(self.Dblk @ u).max() < self.rate_lim * (1 + 1e-6) + 1e-6
                  and bool(np.all(u >= lbx - box_tol) and np.all(u <= ubx + box_tol)))
            if ok and Lv.size:
                lat = Lv[:N] * u[:N] + Lv[N:] * u[N:]
                ok = bool(np.all(lat >= ll - 1e-6 * (1 + np.abs(ll))) and np.all(lat <= lu + 1e-6 * (1 + np.abs(lu))))
            if ok and Lo.size:
                ok = bool(np.abs(Lo @ u).max() <= self.a_lon * (1 + 1e-6) + 1e-6)
        if not ok:
            self._lam_x[:] = 0.0
            self._lam_a[:] = 0.0
            self._ws = None
            return False, str(st.get("return_status", "qp failed")), None, None
        self._lam_x[:] = lam_x
        self._lam_a[:] = lam_a
        u = np.clip(u, lbx, ubx)
        X = (G @ u + hc).reshape(3, N).T
        return True, str(st.get("unified_return_status", st.get("return_status", "ok"))), X, u.reshape(2, N).T

