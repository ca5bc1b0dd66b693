"""The RTI QP of the multi-stage robust NMPC: the scenarios' condensed QPs coupled by shared inputs
(:mod:`ftc_mj.control.robust`)."""

from __future__ import annotations

from collections import Counter

import numpy as np

from ..lazy import lazy_module
from .certified_qp import CertifiedQP
from .condensed_qp import CondensedQP
from .kernels import add_scenario, arrow_inverse_factor
from .solvers import BufferedFunction
from .spec import first_input_bounds

ca = lazy_module("casadi")

PROXIMAL = 1e-3
"""Weight of the proximal term on each scenario's own inputs in the RTI QP, relative to the mean diagonal
of that scenario's cost Hessian in them."""


def stage_indices(n_scen: int, N: int, k: int) -> np.ndarray:
    """Index (S, 2N) into ``z = [u_shared; v_1; …; v_S]`` of each scenario's stacked inputs
    ``[omega_R(N), omega_L(N)]``: nodes ``j < k`` map to the shared block ``u_shared = [omega_R(k),
    omega_L(k)]``, the others to the scenario's own block ``v_i = [omega_R(N−k), omega_L(N−k)]``."""
    nv = 2 * (N - k)
    idx = np.empty((n_scen, 2 * N), dtype=int)
    j = np.arange(N)
    for i in range(n_scen):
        for c in range(2):
            own = 2 * k + i * nv + c * (N - k) + (j - k)
            idx[i, c * N:(c + 1) * N] = np.where(j < k, c * k + j, own)
    return idx


class MultiStageQP:
    """The RTI QP of the multi-stage problem: the scenarios' condensed QPs coupled by shared inputs.

    ``qp`` builds each scenario's QP in its own inputs ``u_i = z[idx_i]`` (2N,); this class sums the
    weighted costs over ``z`` (:func:`stage_indices`), stacks every scenario's constraint rows, bounds
    the shared first input relative to the input in force
    (:func:`~ftc_mj.control.spec.first_input_bounds`, as bounds on ``z``) and solves the dense QP:
    the certified active-set path first, DAQP for what it leaves unresolved. ``path_counts`` counts how
    each QP was decided. The certified path works on the Hessian's structured factor
    (:func:`~ftc_mj.control.kernels.arrow_inverse_factor`: the scenarios' own blocks are coupled only through
    the shared inputs, so the factor has no fill), not on a dense Cholesky factor.
    """

    def __init__(self, qp: CondensedQP, n_scen: int, k: int) -> None:
        self.qp = qp
        N = qp.col.N
        self.N, self.S, self.k = N, n_scen, k
        self.idx = stage_indices(n_scen, N, k)
        self.own = np.concatenate([np.arange(k, N), N + np.arange(k, N)])  # a scenario's own inputs in u_i
        self.nz = 2 * k + n_scen * 2 * (N - k)
        m_i = 3 + 2 * N + (N if qp.a_lat is not None else 0) + (N if qp.a_lon is not None else 0)
        self.m = n_scen * m_i
        self._cqp = CertifiedQP()
        self._ws: np.ndarray | None = None
        H, g, A = ca.MX.sym("H", self.nz, self.nz), ca.MX.sym("g", self.nz), ca.MX.sym("A", self.m, self.nz)
        lba, uba = ca.MX.sym("lba", self.m), ca.MX.sym("uba", self.m)
        lbx, ubx, x0 = ca.MX.sym("lbx", self.nz), ca.MX.sym("ubx", self.nz), ca.MX.sym("x0", self.nz)
        solver = ca.conic("msqp", "daqp", {"h": ca.Sparsity.dense(self.nz, self.nz),
                                           "a": ca.Sparsity.dense(self.m, self.nz)},
                          {"error_on_fail": False, "print_problem": False})
        r = solver(h=H, g=g, a=A, lba=lba, uba=uba, lbx=lbx, ubx=ubx, x0=x0)
        self._plugin = BufferedFunction(ca.Function("msqp_fn", [H, g, A, lba, uba, lbx, ubx, x0], [r["x"]]))
        self.path_counts: Counter[str] = Counter()

    def reset(self) -> None:
        """Forget the active-set guess (a reset QP behaves like a new one)."""
        self._ws = None
        self.qp.reset()

    def assemble(self, Xg: np.ndarray, Ug: np.ndarray, radii_s: np.ndarray, x0: np.ndarray, ref: np.ndarray,
                 weights: np.ndarray, u_prev: np.ndarray | None):
        """QP data ``(H, g, A, lba, uba, lbx, ubx, G, hc)`` about the scenario guesses ``Xg`` (S, N, 3),
        ``Ug`` (S, N, 2) with scenario radii ``radii_s`` (S, 2) (m) and weights (S,) summing to 1; a
        scenario of weight NaN is pruned (its rows become ``0 ≤ 0 · z`` within ±1, so the row count stays
        fixed). ``u_prev`` (rad/s, (2,) or ``None``) is the input in force before ``t0`` (first-step bound
        and penalty). ``G`` (S, 3N, 2N) and ``hc`` (S, 3N) give each scenario's states
        ``X_i = G_i u_i + hc_i``."""
        nz, qp = self.nz, self.qp
        H, g, A = np.zeros((nz, nz)), np.zeros(nz), np.zeros((self.m, nz))
        lo, hi, Gs, hcs = np.empty(self.m), np.empty(self.m), [], []
        own, r0 = self.own, 0
        for i in range(self.S):
            Hi, gi, E, e, G, hc = qp.build(Xg[i], Ug[i], radii_s[i], x0, ref, u_prev)
            Lv, ll, lu = qp.lateral_rows(Ug[i], radii_s[i])
            Ai, lbi, ubi = qp._rows(E, e, Lv, ll, lu, qp.longitudinal_rows())
            ix = self.idx[i]
            wi = 0.0 if np.isnan(weights[i]) else float(weights[i])
            if np.isnan(weights[i]):  # pruned
                Ai, lbi, ubi = np.zeros_like(Ai), -np.ones_like(lbi), np.ones_like(ubi)
            # proximal term on the scenario's own inputs about the guess (vanishes at a fixed point)
            rho = PROXIMAL * float(np.mean(np.diag(Hi)[own])) * max(0.0, 1.0 - self.S * wi)
            add_scenario(H, g, A, r0, Hi, gi, Ai, ix, ix[own], wi, rho, np.ascontiguousarray(Ug[i].T.ravel()[own]))
            lo[r0:r0 + lbi.size], hi[r0:r0 + ubi.size] = lbi, ubi
            r0 += lbi.size
            Gs.append(G)
            hcs.append(hc)
        om = np.full(nz, qp.omega_max)
        lbx, ubx = -om, om.copy()
        lbx[[0, self.k]], ubx[[0, self.k]] = first_input_bounds(qp.col.spec, u_prev)  # shared node-0 inputs
        return H, g, A, lo, hi, lbx, ubx, np.array(Gs), np.array(hcs)

    def solve(self, Xg: np.ndarray, Ug: np.ndarray, radii_s: np.ndarray, x0: np.ndarray, ref: np.ndarray,
              weights: np.ndarray, u_prev: np.ndarray | None
              ) -> tuple[bool, str, np.ndarray | None, np.ndarray | None]:
        """One RTI step: ``(ok, status, X (S, N, 3), U (S, N, 2))``; the inputs of the first ``k``
        nodes are the same array values in every scenario."""
        H, g, A, lba, uba, lbx, ubx, G, hc = self.assemble(Xg, Ug, radii_s, x0, ref, weights, u_prev)
        F = np.empty_like(H)
        if not arrow_inverse_factor(H, 2 * self.k, 2 * (self.N - self.k), F):
            F[0, 0] = np.nan  # not positive definite: the certified path declines
        res = self._cqp.solve(H, g, A, lba, uba, lbx, ubx, self._ws, factor=F)
        if res.status == "optimal":
            self.path_counts[res.path] += 1
            self._ws, z, status = res.working_set, res.u, "optimal (certified active set)"
        elif res.status == "infeasible":
            self.path_counts[res.path] += 1
            self._ws = None
            return False, "infeasible (Farkas certificate)", None, None
        else:
            self.path_counts["plugin"] += 1
            self._ws = None
            z = self._plugin(H, g, A, lba, uba, lbx, ubx, np.clip(self.stack(Ug), lbx, ubx))[0].copy()
            status = f"daqp ({res.path})"
        if not self.feasible(z, A, lba, uba, lbx, ubx):
            self._ws = None
            return False, f"qp failed: {status}", None, None
        z = np.clip(z, lbx, ubx)
        U = np.stack([z[ix].reshape(2, self.N).T for ix in self.idx])
        X = np.stack([(G[i] @ z[ix] + hc[i]).reshape(3, self.N).T for i, ix in enumerate(self.idx)])
        return True, status, X, U

    def stack(self, Ug: np.ndarray) -> np.ndarray:
        """``z`` from scenario inputs (S, N, 2); the shared block is taken from the first scenario."""
        z = np.empty(self.nz)
        for i in range(self.S - 1, -1, -1):
            z[self.idx[i]] = Ug[i].T.ravel()
        return z

    @staticmethod
    def feasible(z: np.ndarray, A: np.ndarray, lba: np.ndarray, uba: np.ndarray, lbx: np.ndarray,
                 ubx: np.ndarray, tol: float = 1e-6) -> bool:
        """``z`` finite and within every bound and row up to ``tol (1 + |bound|)`` (solvers differ in
        what they call success, so the result is checked independently)."""
        if not np.all(np.isfinite(z)):
            return False
        Az = A @ z
        return bool(np.all(z >= lbx - tol * (1 + np.abs(lbx))) and np.all(z <= ubx + tol * (1 + np.abs(ubx)))
                    and np.all(Az >= lba - tol * (1 + np.abs(lba))) and np.all(Az <= uba + tol * (1 + np.abs(uba))))
