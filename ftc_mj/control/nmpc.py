"""Pseudospectral (LGL) NMPC of the paper, built once with CasADi, solved per sample.

Problem: see :mod:`ftc_mj.control.transcription`. Solver options:

* ``ipopt`` — the full NLP (``nlpsol`` on an SX graph, parameter vector
  ``p = [pose(3), radii(2), x_ref(N), y_ref(N), psi_ref(N), V_ref(N), psidot_ref(N), u_prev(2),
  c_step]`` with ``c_step`` the first-step penalty weight; the first-step bound is a per-solve bound
  on ``U(t0)``),
  warm-started from the previous solution shifted by barycentric Lagrange interpolation
  (``warm_start_init_point`` with the previous multipliers).
* ``rti-daqp`` / ``rti-qpoases`` / ``rti-osqp`` — real-time iteration: one Gauss–Newton SQP step
  per sample, linearised about the shifted previous plan; the cost is exactly quadratic, so the
  GN Hessian is exact for the cost and positive definite. States are eliminated exactly
  (:class:`~ftc_mj.control.condensed_qp.CondensedQP`), leaving a dense 2N-input QP for the named
  CasADi QP plugin (for ``daqp``: first an exact, certified active-set solve, see
  :mod:`~ftc_mj.control.certified_qp`; the plugin only for QPs that stay unresolved). The first
  solve (and a re-seed after two consecutive failures) is an IPOPT solve.

The first command of the plan (node 0, at ``t0``) is applied under zero-order hold. Every plan's
first input is bounded relative to the command in force on the plant (``u_applied``):
``|U(t0) − u_applied| ≤ omega_rate_max T_s`` (``ProblemSpec.rate_bound_from_applied``; the IPOPT NLP
as bounds on ``U(t0)``, the RTI QP as its box). A failed or over-budget solve, a solver error
(CasADi/IPOPT/QP plugin error, linear-algebra failure), or a non-finite pose/radii never raises: the
controller falls back to the previous plan shifted to the current time (or, with no plan yet, the
reference feed-forward), moved so that its first input meets the same bound
(:meth:`~ftc_mj.control.transcription.Collocation.project_first`, as is the warm start), counts it in
``failures`` and says why in ``status``. Any other exception (a ``TypeError``, a shape bug, a
non-finite ``u_applied``) propagates and fails the run. Outputs always meet the input bounds and the
first-step bound.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from ..fields import PosFloat, ranged_int
from ..lazy import lazy_module
from .base import ControlOutput
from .condensed_qp import CondensedQP
from .mpc import SOLVERS
from .solver_cache import ipopt_solver
from .solvers import ipopt_options, warm_started_solve
from .spec import MPCSettings, ProblemSpec, first_step_penalty
from .tracking import PlanController

ca = lazy_module("casadi")


class NMPCSettings(MPCSettings):
    """Settings of the LGL pseudospectral NMPC (``controller.kind = "nmpc"``, paper §3): the MPC settings and
    its NLP solver's."""

    kind: Literal["nmpc"] = "nmpc"
    """The tracking NMPC (a registered controller, :data:`ftc_mj.registry.controllers`)."""
    solver: Literal["ipopt", "rti-daqp", "rti-qpoases", "rti-osqp"] = "rti-daqp"
    """NMPC solver. ``ipopt``: full NLP solve each sample (warm-started). ``rti-<qp>``: real-time
    iteration — one Gauss–Newton SQP step per sample on the state-condensed QP, solved by the named
    CasADi QP plugin (daqp measured fastest, osqp slowest on this dense QP); the first solve, and a
    re-seed after repeated failures, is done by IPOPT."""
    cold_time_budget: PosFloat | None = None
    """Wall-time budget (s) of a cold (first or re-seeding) solve; ``None`` = not enforced."""
    max_iter: ranged_int(0, 10_000) = 30
    """Iteration limit of the NLP solver (IPOPT); 0 forces a failure (used in tests). 30 is above what
    every successful solve of the paper's runs needed and bounds the time lost on a failing re-seed
    (docs/config-defaults.md)."""


class NMPC(PlanController):
    """Pseudospectral NMPC (paper §3). ``solve(t, pose, radii)`` is called at the control rate.

    Parameters: ``spec`` (problem numbers), ``reference`` (has ``at(t)``), ``solver`` (one of
    :data:`SOLVERS`), ``max_iter`` (IPOPT iteration limit; 0 forces every solve to fail),
    ``time_budget`` (s, wall time of a warm solve), ``cold_time_budget`` (s, of an IPOPT seed solve),
    ``nominal_radii`` (m, used before any valid radii have been seen).
    """

    def __init__(
        self,
        spec: ProblemSpec,
        reference,
        solver: str = "rti-daqp",
        max_iter: int = 30,
        time_budget: float | None = 0.1,
        nominal_radii: tuple[float, float] = (2.0, 2.0),
        cold_time_budget: float | None = 2.0,
        qp_options: dict | None = None,
    ) -> None:
        if solver not in SOLVERS:
            raise ValueError(f"unknown NMPC solver {solver!r}; expected one of {SOLVERS}")
        super().__init__(spec, reference, nominal_radii, time_budget, cold_time_budget)
        self.solver_name = solver
        self.max_iter = int(max_iter)
        self._build_nlp()
        self._qp = CondensedQP(self.col, solver.split("-", 1)[1], qp_options) if solver != "ipopt" else None

    # ------------------------------------------------------------------------------------------
    def _build_nlp(self) -> None:
        col, sp, N = self.col, self.spec, self.col.N
        w = ca.SX.sym("w", 5 * N)
        p = ca.SX.sym("p", 5 + 5 * N + 3)
        X = ca.reshape(w[: 3 * N], N, 3).T  # 3 x N
        U = ca.reshape(w[3 * N:], N, 2).T  # 2 x N
        ref = ca.reshape(p[5:5 + 5 * N], N, 5).T  # 5 x N
        u_prev, c_step = p[5 + 5 * N:7 + 5 * N], p[7 + 5 * N]
        J, g, self._lbg, self._ubg = col.nlp_terms(X, U, p[:3], p[3:5], ref, u_prev, c_step)
        self._lbx = np.concatenate([-np.inf * np.ones(3 * N), -sp.omega_max * np.ones(2 * N)])
        self._ubx = -self._lbx
        self._ubx[: 3 * N] = np.inf
        self._nlp = ipopt_solver("nmpc", {"x": w, "p": p, "f": J, "g": g}, self._ipopt_options())
        self.nlp_size = (w.numel(), g.numel())

    def _ipopt_options(self) -> dict:
        """IPOPT options of every NLP of this controller (quiet, warm start, the wall-time budget)."""
        return ipopt_options(self.max_iter, self.cold_time_budget, self.time_budget)

    # ------------------------------------------------------------------------------------------
    def _ipopt(self, x0, radii, ref, Xg, Ug):
        N = self.col.N
        wg = np.concatenate([Xg.T.ravel(), Ug.T.ravel()])
        u_prev = np.zeros(2) if self._u_prev is None else self._u_prev
        pv = np.concatenate([x0, radii, ref.ravel(), u_prev, [first_step_penalty(self.spec, self._u_prev)]])
        lbx, ubx = self._lbx.copy(), self._ubx.copy()
        first = [3 * N, 4 * N]  # omega_R, omega_L at t0
        lbx[first], ubx[first] = self._box
        args = {"x0": wg, "p": pv, "lbx": lbx, "ubx": ubx, "lbg": self._lbg, "ubg": self._ubg}
        ok, status, it, wv, self._lam = warm_started_solve(self._nlp, args, self._lam)
        if not ok:
            return False, status, it, None, None
        return True, status, it, wv[: 3 * N].reshape(3, N).T, wv[3 * N:].reshape(2, N).T

    def _rti_step(self, Xg: np.ndarray, Ug: np.ndarray, radii: np.ndarray, x0: np.ndarray, ref: np.ndarray
                  ) -> tuple[bool, str, np.ndarray | None, np.ndarray | None]:
        """One real-time iteration about the guess: ``(ok, status, X, U)``."""
        assert self._qp is not None
        return self._qp.solve(Xg, Ug, radii, x0, ref, Ug.T.ravel(), self._u_prev)

    def _solve(self, t: float, pose: np.ndarray, radii: np.ndarray, t_start: float) -> ControlOutput:
        prep = self._prepare(t, pose, radii, t_start)
        if isinstance(prep, ControlOutput):
            return prep
        r, ref, x0 = prep
        Xg, Ug = self._guess(t, x0, ref, r)
        if self.max_iter == 0:
            return self._fallback(t, "max_iter=0", t_start, r)
        step = None if self._qp is None else (lambda: self._rti_step(Xg, Ug, r, x0, ref))
        ok, status, it, plan, budget = self._iterate(lambda: self._ipopt(x0, r, ref, Xg, Ug), step)
        if not ok:
            return self._fallback(t, status, t_start, r, it)
        X, U = plan
        return self._accept(t, X, U, status, it, t_start, budget, r)
