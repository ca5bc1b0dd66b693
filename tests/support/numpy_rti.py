"""The numpy reference of the RTI's compiled kernels (:mod:`ftc_mj.control.kernels`): condensing, the
tracking cost, the multi-stage assembly and the certified working-set solve, in matrix form, as the package
computed them before they were compiled. The tests require the kernels to agree with it to round-off and
apply the certificate's refusal tests to both.

:class:`NumpyCertifiedQP`, :class:`NumpyElimination`, :class:`NumpyCondensedQP` and
:class:`NumpyMultiStageQP` are the package's classes with these methods in place of the kernels' calls, so
a test runs a compiled and a reference QP side by side; :func:`recorded_calls` records the steps they replay.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg.lapack

from ftc_mj.control.certified_qp import CertifiedQP, CertifiedResult
from ftc_mj.control.condensed_qp import CondensedQP
from ftc_mj.control.elimination import StateElimination
from ftc_mj.control.multistage_qp import PROXIMAL, MultiStageQP
from ftc_mj.control.spec import first_input_bounds, first_step_penalty


class NumpyCertifiedQP(CertifiedQP):
    """:class:`CertifiedQP` with the working-set solve and its certificate in numpy, and the dense Cholesky
    factor of ``H`` always (a caller's structured ``factor`` is ignored)."""

    def solve(self, H, g, A, lba, uba, lbx, ubx, guess=None, factor=None) -> CertifiedResult:
        """:meth:`CertifiedQP.solve` with ``L⁻¹`` of the dense Cholesky factor."""
        return super().solve(H, g, A, lba, uba, lbx, ubx, guess)

    def _try(self, Linv, H, g, A, lo, hi, eq, ws, path: str) -> CertifiedResult | None:
        """The reference of :meth:`CertifiedQP._try` (the certificate, its repairs and refusals) in numpy."""
        n = H.shape[0]
        ws = ws.copy()
        ws[n:][eq] = 1
        ineq_all = np.concatenate([np.ones(n, bool), ~eq])
        v = Linv @ g
        for _ in range(1 + self.max_repairs):
            sol = self._eqp(Linv, H, g, A, lo, hi, ws, v)
            if sol is None:
                return None
            u, lam_full = sol
            Au = A @ u
            r = np.concatenate([u, Au])
            if self._ws_residual(r, lo, hi, ws) > self.ws_tol:
                return None  # u is not on its working set: the refinement did not converge
            over, under = r - hi, lo - r
            viol = np.maximum(over, under)
            if viol.max(initial=0.0) > self.primal_tol:
                bad = viol > self.primal_tol
                if np.count_nonzero(bad) > self.max_repair_rows:
                    return None  # far from this working set: not worth repairing
                ws[bad] = np.where(over[bad] > 0, 1, -1)
                continue
            side = ws.astype(float)
            lam_scale = 1.0 + float(np.max(np.abs(lam_full)))
            wrong = np.where(ineq_all & (ws != 0), lam_full * side, 0.0)
            if wrong.min(initial=0.0) < -self.dual_tol * lam_scale:
                ws[int(np.argmin(wrong))] = 0
                continue
            lam_x, lam_a = lam_full[:n], lam_full[n:]
            if self._stationarity(H, g, A, u, lam_x, lam_a) > self.stat_tol:
                return None
            ws[n:][eq] = 0
            return CertifiedResult("optimal", path, u, lam_x, lam_a, ws)
        return None

    @staticmethod
    def _ws_residual(r: np.ndarray, lo: np.ndarray, hi: np.ndarray, ws: np.ndarray) -> float:
        """``max_W |r_i − b_i| / (1 + max_W |b_i|)`` over the working set (``r = [u; A u]``, ``b_i`` the
        bound the working set puts constraint ``i`` on); 0 for an empty working set."""
        idx = np.nonzero(ws)[0]
        if idx.size == 0:
            return 0.0
        b = np.where(ws[idx] > 0, hi[idx], lo[idx])
        return float(np.max(np.abs(r[idx] - b)) / (1.0 + np.max(np.abs(b))))

    @staticmethod
    def _stationarity(H: np.ndarray, g: np.ndarray, A: np.ndarray, u: np.ndarray, lam_x: np.ndarray,
                      lam_a: np.ndarray) -> float:
        """``max |H u + g + lam_x + Aᵀ lam_a|`` relative to ``1 + max(|H||u| + |g| + |lam_x| + |A|ᵀ|lam_a|)``,
        the size of the terms whose rounding it measures."""
        stat = H @ u + g + lam_x + A.T @ lam_a
        scale = np.abs(H) @ np.abs(u) + np.abs(g) + np.abs(lam_x) + np.abs(A).T @ np.abs(lam_a)
        return float(np.max(np.abs(stat)) / (1.0 + np.max(scale)))

    @staticmethod
    def _eqp(Linv: np.ndarray, H: np.ndarray, g: np.ndarray, A: np.ndarray, lo: np.ndarray, hi: np.ndarray,
             ws: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """``(u, λ over bounds and rows)`` of ``min ½uᵀHu + gᵀu`` with the working-set constraints as
        equalities; None if its rows are dependent.

        Range-space method: with ``H = L Lᵀ``, ``Y = L⁻¹ C_Wᵀ`` and ``v = L⁻¹ g``, the multipliers solve
        ``(YᵀY) λ = −(b_W + Yᵀv)`` and ``u = −L⁻ᵀ (v + Y λ)``. With ~100 active rows ``YᵀY`` has a
        condition number up to ~1e14, so up to two steps of iterative refinement on the KKT residual
        follow (they bring the working-set residual from ~1e-6 to ~1e-11).
        """
        n = H.shape[0]
        idx = np.nonzero(ws)[0]
        lam_full = np.zeros(lo.size)
        if idx.size == 0:
            return -(Linv.T @ v), lam_full
        b = np.where(ws[idx] > 0, hi[idx], lo[idx])
        bnd, row = idx[idx < n], idx[idx >= n] - n
        nb = bnd.size
        Ar = A[row]
        Y = np.empty((n, idx.size))
        Y[:, :nb] = Linv[:, bnd]
        Y[:, nb:] = Linv @ Ar.T
        Ls, info = scipy.linalg.lapack.dpotrf(Y.T @ Y, lower=1)
        if info != 0:
            return None
        lam = scipy.linalg.lapack.dpotrs(Ls, -(b + Y.T @ v), lower=1)[0]
        u = -(Linv.T @ (v + Y @ lam))
        b_scale = 1e-12 * (1.0 + float(np.max(np.abs(b))))
        for _ in range(2):  # refinement: solve the KKT system for its residual with the same factors
            r2 = b - np.concatenate([u[bnd], Ar @ u])
            if np.max(np.abs(r2)) <= b_scale:
                break
            r1 = -(g + H @ u + Ar.T @ lam[nb:])
            r1[bnd] -= lam[:nb]
            w = Linv @ r1
            dlam = scipy.linalg.lapack.dpotrs(Ls, Y.T @ w - r2, lower=1)[0]
            u = u + Linv.T @ (w - Y @ dlam)
            lam = lam + dlam
        if not (np.all(np.isfinite(u)) and np.all(np.isfinite(lam))):
            return None
        lam_full[idx] = lam
        return u, lam_full


class NumpyElimination(StateElimination):
    """:class:`StateElimination` with the pose's elimination in numpy."""

    def pose(self, Xg: np.ndarray, Ug: np.ndarray, radii: np.ndarray, x0: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(G (3, N, 2N), hc (3, N), E (3, 2N), e (3,))``: the pose ``X_s = G[s] u + hc[s]`` (x, y, psi)
        of the collocation linearised about ``(Xg (N,3), Ug (N,2))`` as a function of the wheel rates
        ``u = [omega_R(N), omega_L(N)]``, and the node-0 collocation rows ``E u = e``."""
        N, K, c0 = self.N, self.K, self.c0
        fx, A, B = self._lin(Xg.T, Ug.T, radii)
        fx = fx.reshape(3, N, order="F")
        A = A.reshape(3, 3, N, order="F")  # A[i, j, k] = d f_i / d x_j at node k
        B = B.reshape(3, 2, N, order="F")
        # affine model f ≈ A X + B U + c
        c = fx - np.einsum("ijk,kj->ik", A, Xg) - np.einsum("ijk,kj->ik", B, Ug)
        ax, ay = A[0, 2], A[1, 2]
        G = np.zeros((3, N, 2 * N))
        hc = np.empty((3, N))
        # psi
        G[2][:, 1:N] = K * B[2, 0, 1:]
        G[2][:, N + 1:] = K * B[2, 1, 1:]
        hc[2] = c0 * x0[2] + K @ c[2, 1:]
        for s, a in ((0, ax), (1, ay)):
            Gs = K @ (a[1:, None] * G[2][1:])
            Gs[:, 1:N] += K * B[s, 0, 1:]
            Gs[:, N + 1:] += K * B[s, 1, 1:]
            G[s] = Gs
            hc[s] = c0 * x0[s] + K @ (a[1:] * hc[2][1:] + c[s, 1:])
        # node-0 collocation rows: (2/T) D(0,:) @ X_s - (A X + B U + c)_0 = 0
        E = self.hD0 @ G  # (3, 2N)
        E[:, 0] -= B[:, 0, 0]
        E[:, N] -= B[:, 1, 0]
        e = c[:, 0] + A[:, :, 0] @ x0 - hc @ self.hD0
        return G, hc, E, e


class NumpyCondensedQP(CondensedQP):
    """:class:`CondensedQP` with the numpy elimination, cost and certified QP."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.elim.__class__ = NumpyElimination
        self._cqp = NumpyCertifiedQP()

    def build(self, Xg, Ug, radii, x0, ref, u_prev=None):
        """The reference of :meth:`CondensedQP.build`: the same outputs, computed in numpy."""
        col, N = self.col, self.col.N
        sp = col.spec
        G, hc, E, e = self.elim.pose(Xg, Ug, radii, x0)
        # cost
        W = col.W
        key = (float(radii[0]), float(radii[1]))
        if self._J_cache is None or self._J_cache[0] != key:
            self._J_cache = (key, self._J(radii)[0].reshape(2, 2, order="F").copy())
        J = self._J_cache[1]  # d[V, psidot]/du, constant for given radii
        Gf = G.reshape(3 * N, 2 * N)
        GW = Gf.T * self._qW3
        H = GW @ Gf
        g = GW @ (hc.ravel() - ref[:3].ravel())
        idx = np.arange(N)
        for k, q in ((0, sp.q_speed), (1, sp.q_yaw_rate)):
            a0, a1 = J[k, 0], J[k, 1]
            qW = q * W
            H[idx, idx] += qW * a0 * a0
            H[idx + N, idx + N] += qW * a1 * a1
            H[idx, idx + N] += qW * a0 * a1
            H[idx + N, idx] += qW * a0 * a1
            g[:N] -= qW * a0 * ref[3 + k]
            g[N:] -= qW * a1 * ref[3 + k]
        H = 2.0 * H + self.R_rate
        g = 2.0 * g
        c = first_step_penalty(sp, u_prev)
        if c > 0:  # c ‖U(t0) − u_prev‖² on inputs 0 (omega_R) and N (omega_L)
            assert u_prev is not None
            for i, ui in ((0, u_prev[0]), (N, u_prev[1])):
                H[i, i] += 2.0 * c
                g[i] -= 2.0 * c * ui
        return H, g, E, e, Gf, hc.ravel()


class NumpyMultiStageQP(MultiStageQP):
    """:class:`MultiStageQP` with the numpy assembly (and the numpy condensed QP and certified QP)."""

    def __init__(self, qp: CondensedQP, n_scen: int, k: int) -> None:
        super().__init__(qp, n_scen, k)
        self._cqp = NumpyCertifiedQP()

    def assemble(self, Xg, Ug, radii_s, x0, ref, weights, u_prev):
        """The reference of :meth:`MultiStageQP.assemble`: the same outputs, computed in numpy."""
        nz, qp = self.nz, self.qp
        H = np.zeros((nz, nz))
        g = np.zeros(nz)
        rows, lo, hi, Gs, hcs = [], [], [], [], []
        own = self.own
        for i in range(self.S):
            Hi, gi, E, e, G, hc = qp.build(Xg[i], Ug[i], radii_s[i], x0, ref, u_prev)
            Lv, ll, lu = qp.lateral_rows(Ug[i], radii_s[i])
            Ai, lbi, ubi = qp._rows(E, e, Lv, ll, lu, qp.longitudinal_rows())
            ix = self.idx[i]
            wi = 0.0 if np.isnan(weights[i]) else weights[i]
            if np.isnan(weights[i]):  # pruned
                Ai, lbi, ubi = np.zeros_like(Ai), -np.ones_like(lbi), np.ones_like(ubi)
            H[np.ix_(ix, ix)] += wi * Hi
            g[ix] += wi * gi
            # proximal term on the scenario's own inputs about the guess (vanishes at a fixed point)
            rho = PROXIMAL * float(np.mean(np.diag(Hi)[own])) * max(0.0, 1.0 - self.S * wi)
            io = ix[own]
            H[io, io] += rho
            g[io] -= rho * Ug[i].T.ravel()[own]
            Az = np.zeros((Ai.shape[0], nz))
            Az[:, ix] = Ai
            rows.append(Az)
            lo.append(lbi)
            hi.append(ubi)
            Gs.append(G)
            hcs.append(hc)
        om = np.full(nz, qp.omega_max)
        lbx, ubx = -om, om.copy()
        lbx[[0, self.k]], ubx[[0, self.k]] = first_input_bounds(qp.col.spec, u_prev)  # shared node-0 inputs
        return (H, g, np.vstack(rows), np.concatenate(lo), np.concatenate(hi), lbx, ubx,
                np.array(Gs), np.array(hcs))


def recorded_calls(obj, name: str, run) -> list[tuple]:
    """Copies of the arguments of every call of ``obj.name`` while ``run()`` runs."""
    calls: list[tuple] = []
    method, own = getattr(obj, name), name in vars(obj)  # an instance attribute (another spy) is put back

    def spy(*args):
        calls.append(tuple(np.copy(a) if isinstance(a, np.ndarray) else a for a in args))
        return method(*args)

    setattr(obj, name, spy)
    try:
        run()
    finally:
        if own:
            setattr(obj, name, method)
        else:
            delattr(obj, name)
    return calls
