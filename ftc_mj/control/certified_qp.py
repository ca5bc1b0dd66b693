"""Exact solution of a small dense strictly convex QP from a predicted active set, with a KKT certificate.

Problem (``n`` variables, ``m`` general rows; a row with ``lba == uba`` is an equality)::

    minimise ½ uᵀHu + gᵀu   subject to   lbx ≤ u ≤ ubx,   lba ≤ A u ≤ uba

Why: the RTI QP of the NMPC (:class:`~ftc_mj.control.condensed_qp.CondensedQP`, n = 100) is solved by
DAQP, a dual active-set method. When the loop saturates the wheels, ~100 constraints are active and
the active set changes wholesale from one sample to the next, so DAQP needs hundreds of iterations
(docs/control.md), while an interior-point method needs about a dozen whatever the active set is.
This class therefore

1. tries the caller's guess of the active set (e.g. the previous sample's; right in a run that
   tracks, where only the equality rows are active),
2. else runs the interior-point solver PIQP (dense backend) and reads the active set off its
   solution (slack below ``active_tol``),

and in both cases solves the equality-constrained QP on that working set *exactly* (range-space
method on a factor of H: its Cholesky factor, or one the caller knows from H's structure) and accepts the
result only if it passes a KKT certificate, all four parts (the solve, its repairs and the certificate are
one compiled call, :func:`~ftc_mj.control.kernels.certify`):

* complementarity: every constraint of the working set holds with equality, within ``ws_tol``
  relative to its bound (an exact solve lands there to ~1e-12; a refinement that did not converge
  leaves ~1e-6, with multipliers that are then wrong along the ill-conditioned directions). With the
  multipliers of inactive constraints zero by construction, this bounds the complementarity gap
  ``Σ |λ_i| |slack_i| ≤ ‖λ‖₁ ws_tol (1 + max |b_W|)``;
* primal feasibility: every bound and row holds within ``primal_tol`` (the absolute primal
  tolerance DAQP uses, 1e-6);
* dual feasibility: every inequality multiplier has the right sign (within ``dual_tol`` relative);
* stationarity: ``|H u + g + lam_x + Aᵀ lam_a|`` is below ``stat_tol`` times the size of the terms
  that were summed, ``1 + max(|H||u| + |g| + |lam_x| + |A|ᵀ|lam_a|)`` (the scale of their rounding:
  with multipliers ~1e3 on rows with entries ~600, ``Aᵀλ`` alone is ~1e5 component by component).

A strictly convex QP has one KKT point, so a certified result is the solution DAQP would return, up
to the two solvers' tolerances. A problem PIQP calls primal infeasible is reported
infeasible only with a Farkas certificate showing that every ``u`` violates some constraint by more
than ``10 primal_tol`` (so DAQP could not have found a feasible point either). Anything else is
``"unresolved"`` and the caller must use its reference solver.

Multipliers follow DAQP's convention: ``H u + g + lam_x + Aᵀ lam_a = 0``, positive at an upper
bound, negative at a lower bound. A working set is an int8 array over ``[bounds (n); rows (m)]``:
+1 upper bound active, −1 lower bound active, 0 inactive (equality rows are always in it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..lazy import lazy_module
from .kernels import certify

scipy = lazy_module("scipy")  # imported on first use (ftc_mj.lazy)

try:  # optional at import time: without PIQP only the guessed working set can be certified
    import piqp
except ImportError:  # pragma: no cover - piqp is a declared dependency
    piqp = None


@dataclass
class CertifiedResult:
    """Outcome of :meth:`CertifiedQP.solve`.

    ``status``: ``"optimal"``, ``"infeasible"`` or ``"unresolved"`` (use the reference solver).
    ``path``: how it was decided — ``"guess"``, ``"ipm"`` (active set read off PIQP's solution),
    ``"farkas"`` (infeasibility certificate) or a reason for ``"unresolved"``.
    ``u`` (n,), ``lam_x`` (n,), ``lam_a`` (m,) and ``working_set`` (n + m,) are set when optimal.
    ``ipm_iterations``: PIQP iterations spent (0 if the guess was certified).
    """

    status: str
    path: str
    u: np.ndarray | None = None
    lam_x: np.ndarray | None = None
    lam_a: np.ndarray | None = None
    working_set: np.ndarray | None = None
    ipm_iterations: int = 0


class CertifiedQP:
    """Solve ``min ½uᵀHu + gᵀu, lbx ≤ u ≤ ubx, lba ≤ Au ≤ uba`` (H positive definite) exactly.

    Parameters: ``primal_tol`` (absolute constraint violation accepted, in the units of the rows;
    DAQP's default), ``dual_tol`` (wrong-sign multiplier accepted, relative to the largest
    multiplier), ``ws_tol`` (working-set residual accepted, relative to ``1 + max |b_W|``),
    ``stat_tol`` (stationarity residual accepted, relative to the rounding scale of its terms; on the
    saturated-loop QPs of the tests the working-set residuals are ≤ 1e-12 and the stationarity ≤ 5e-16
    of those scales, so both leave three orders of margin or more), ``active_tol`` (a constraint
    whose PIQP slack is below ``active_tol (1 + |bound|)`` is taken as active), ``ipm_eps`` (PIQP's
    absolute residual and duality-gap tolerance), ``max_repairs`` (working-set repairs per
    candidate, see :meth:`_try`), ``max_repair_rows`` (a candidate that violates more constraints
    than this is abandoned instead of repaired).
    The solver keeps no state between calls: the result is a function of the arguments.
    """

    def __init__(self, primal_tol: float = 1e-6, dual_tol: float = 1e-9, active_tol: float = 1e-6,
                 ipm_eps: float = 1e-8, max_repairs: int = 3, max_repair_rows: int = 4, ws_tol: float = 1e-9,
                 stat_tol: float = 1e-10) -> None:
        self.primal_tol = float(primal_tol)
        self.ws_tol = float(ws_tol)
        self.stat_tol = float(stat_tol)
        self.max_repairs = int(max_repairs)
        self.max_repair_rows = int(max_repair_rows)
        self.dual_tol = float(dual_tol)
        self.active_tol = float(active_tol)
        self.ipm_eps = float(ipm_eps)

    # ------------------------------------------------------------------------------------------
    def solve(self, H: np.ndarray, g: np.ndarray, A: np.ndarray, lba: np.ndarray, uba: np.ndarray,
              lbx: np.ndarray, ubx: np.ndarray, guess: np.ndarray | None = None,
              factor: np.ndarray | None = None) -> CertifiedResult:
        """Certified solution of the QP; ``guess`` is a working set (n + m,) to try first. ``factor``: a
        caller that knows the structure of ``H`` may hand ``F⁻¹`` (n, n) of a factor ``H = F Fᵀ`` (e.g.
        :func:`~ftc_mj.control.kernels.arrow_inverse_factor`; NaN for an ``H`` that is not positive
        definite); else ``L⁻¹`` of the Cholesky factor is computed here (LAPACK ``potrf``, ``trtri``)."""
        n, m = H.shape[0], A.shape[0]
        if factor is None:
            L, info = scipy.linalg.lapack.dpotrf(H, lower=1, clean=1)
            if info != 0:
                return CertifiedResult("unresolved", "H not positive definite")
            Linv = np.ascontiguousarray(scipy.linalg.lapack.dtrtri(L, lower=1)[0])  # explicit L⁻¹: every
            # working-set solve reuses it
        elif not np.isfinite(factor[0, 0]):
            return CertifiedResult("unresolved", "H not positive definite")
        else:
            Linv = factor
        eq = lba == uba
        lo = np.concatenate([lbx, lba])
        hi = np.concatenate([ubx, uba])
        if guess is not None and guess.shape == (n + m,):
            res = self._try(Linv, H, g, A, lo, hi, eq, guess, "guess")
            if res is not None:
                return res
        if piqp is None:
            return CertifiedResult("unresolved", "piqp not installed")
        s = piqp.DenseSolver()
        st = s.settings
        st.eps_abs, st.eps_rel = self.ipm_eps, 0.0
        st.eps_duality_gap_abs, st.eps_duality_gap_rel = self.ipm_eps, 0.0
        st.preconditioner_iter = 0  # fewer iterations on these problems, same verdicts (docs/control.md)
        st.num_threads = 1
        Ae, Ai = A[eq], A[~eq]
        s.setup(np.asfortranarray(H), g,
                np.asfortranarray(Ae) if Ae.shape[0] else None, lba[eq] if Ae.shape[0] else None,
                np.asfortranarray(Ai) if Ai.shape[0] else None,
                lba[~eq] if Ai.shape[0] else None, uba[~eq] if Ai.shape[0] else None, lbx, ubx)
        status = s.solve()
        r = s.result
        it = int(r.info.iter)
        if status == piqp.PIQP_SOLVED:
            ws = np.zeros(n + m, dtype=np.int8)
            tol = self.active_tol
            ws[:n] = (r.s_bu < tol * (1 + np.abs(ubx))).astype(np.int8) - (r.s_bl < tol * (1 + np.abs(lbx)))
            iq = np.nonzero(~eq)[0]
            if iq.size:
                ws[n + iq] = ((r.s_u < tol * (1 + np.abs(uba[iq]))).astype(np.int8)
                              - (r.s_l < tol * (1 + np.abs(lba[iq]))))
            res = self._try(Linv, H, g, A, lo, hi, eq, ws, "ipm")
            if res is None:  # second reading: complementarity (multiplier larger than slack)
                ws[:n] = (r.z_bu > r.s_bu).astype(np.int8) - (r.z_bl > r.s_bl)
                if iq.size:
                    ws[n + iq] = (r.z_u > r.s_u).astype(np.int8) - (r.z_l > r.s_l)
                res = self._try(Linv, H, g, A, lo, hi, eq, ws, "ipm")
            if res is not None:
                res.ipm_iterations = it
                return res
            return CertifiedResult("unresolved", "ipm active set not certified", ipm_iterations=it)
        if status == piqp.PIQP_PRIMAL_INFEASIBLE and self._farkas(r, A, eq, lba, uba, lbx, ubx):
            return CertifiedResult("infeasible", "farkas", ipm_iterations=it)
        return CertifiedResult("unresolved", f"ipm status {status}", ipm_iterations=it)

    # ------------------------------------------------------------------------------------------
    def _try(self, Linv: np.ndarray, H: np.ndarray, g: np.ndarray, A: np.ndarray, lo: np.ndarray,
             hi: np.ndarray, eq: np.ndarray, ws: np.ndarray, path: str) -> CertifiedResult | None:
        """Solve the equality-constrained QP on working set ``ws`` and certify it; None if not optimal.

        The certificate (module docstring) in this order: working-set residual (complementarity;
        refused), primal feasibility and multiplier signs (repaired), stationarity (refused). A working
        set that fails a repairable part is repaired up to ``max_repairs`` times (add every violated
        constraint, else drop the multiplier of worst sign) — an active set predicted from an
        interior-point solution may miss a weakly active constraint; the repaired set must pass the same
        certificate. One compiled call (:func:`~ftc_mj.control.kernels.certify`).
        """
        n, m = H.shape[0], A.shape[0]
        work = np.array(ws, dtype=np.int8)
        u, lam = np.empty(n), np.empty(n + m)
        tol = np.array([self.primal_tol, self.dual_tol, self.ws_tol, self.stat_tol])
        c = np.ascontiguousarray
        if not certify(c(Linv, dtype=float), c(H, dtype=float), c(g, dtype=float), c(A, dtype=float),
                       c(lo, dtype=float), c(hi, dtype=float), c(eq, dtype=np.bool_), tol, self.max_repairs,
                       self.max_repair_rows, work, u, lam):
            return None
        return CertifiedResult("optimal", path, u, lam[:n], lam[n:], work)

    def _farkas(self, r, A: np.ndarray, eq: np.ndarray, lba: np.ndarray, uba: np.ndarray, lbx: np.ndarray,
                ubx: np.ndarray) -> bool:
        """True if PIQP's infeasibility multipliers prove that every ``u`` violates a constraint by
        more than ``10 primal_tol``.

        For nonnegative multipliers ``z`` of the inequalities (each side) and free ``y`` of the
        equalities, any ``u`` satisfies ``Σ z·violation ≥ cᵀu − β`` with ``c`` the combination of the
        rows and ``β`` that of the bounds; with the box finite, ``cᵀu ≥ Σ min(c lbx, c ubx) − ‖c‖₁ δ``
        for a ``u`` outside the box by at most ``δ``. So the largest violation (box included) is at
        least ``(min_box cᵀu − β) / (Σ|y| + Σ z + ‖c‖₁)``.
        """
        if not (np.all(np.isfinite(lbx)) and np.all(np.isfinite(ubx))):
            return False
        m = A.shape[0]
        y = np.zeros(m)
        zu = np.zeros(m)
        zl = np.zeros(m)
        y[eq] = r.y
        zu[~eq] = np.maximum(r.z_u, 0.0)
        zl[~eq] = np.maximum(r.z_l, 0.0)
        zbu, zbl = np.maximum(r.z_bu, 0.0), np.maximum(r.z_bl, 0.0)
        c = A.T @ (y + zu - zl) + zbu - zbl
        with np.errstate(invalid="ignore"):
            beta = (float(lba[eq] @ y[eq]) + float(np.sum(np.where(zu > 0, uba, 0.0) * zu))
                    - float(np.sum(np.where(zl > 0, lba, 0.0) * zl)) + float(ubx @ zbu) - float(lbx @ zbl))
        cmin = float(np.sum(np.minimum(c * lbx, c * ubx)))
        total = float(np.sum(np.abs(y)) + zu.sum() + zl.sum() + zbu.sum() + zbl.sum() + np.abs(c).sum())
        if not np.isfinite(beta) or total <= 0.0:
            return False
        return (cmin - beta) / total > 10.0 * self.primal_tol
