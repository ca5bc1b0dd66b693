"""Pseudospectral (LGL) NMPC of the paper, built once with CasADi, solved per sample.

Problem: see :mod:`ftc_mj.control.collocation`. Solver options:

* ``ipopt`` — the full NLP (``nlpsol`` on an SX graph, parameter vector
  ``p = [pose(3), radii(2), x_ref(N), y_ref(N), psi_ref(N), V_ref(N), psidot_ref(N), u_prev(2),
  c_step]`` with ``c_step`` the first-step penalty weight; the first-step bound is a per-solve bound
  on ``U(t0)``),
  warm-started from the previous solution shifted by barycentric Lagrange interpolation
  (``warm_start_init_point`` with the previous multipliers).
* ``rti-daqp`` / ``rti-qpoases`` / ``rti-osqp`` — real-time iteration: one Gauss–Newton SQP step
  per sample, linearised about the shifted previous plan; the cost is exactly quadratic, so the
  GN Hessian is exact for the cost and positive definite. States are eliminated exactly
  (:class:`~ftc_mj.control.collocation.CondensedQP`), leaving a dense 2N-input QP for the named
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
(:meth:`~ftc_mj.control.collocation.Collocation.project_first`, as is the warm start), counts it in
``failures`` and says why in ``status``. Any other exception (a ``TypeError``, a shape bug, a
non-finite ``u_applied``) propagates and fails the run. Outputs always meet the input bounds and the
first-step bound.
"""

from __future__ import annotations

import os
import time
import traceback

import casadi as ca
import numpy as np

from ..model.kinematics import inverse_rates
from .base import ControlOutput
from .collocation import (
    Collocation,
    CondensedQP,
    ProblemSpec,
    first_input_bounds,
    first_step_penalty,
    limit_blas_threads,
    reference_at_nodes,
    sanitize_pose,
    sanitize_radii,
    warm_started_solve,
)

SOLVERS = ("ipopt", "rti-daqp", "rti-qpoases", "rti-osqp")


RESEED_WAIT = 20
"""Samples (2 s at 10 Hz) without IPOPT re-seeds after a re-seed failed (RTI steps continue meanwhile)."""

_CASADI_DIR = os.path.dirname(os.path.abspath(ca.__file__))


def _raised_in(exc: BaseException, directory: str) -> bool:
    """The innermost frame of ``exc``'s traceback is in a file under ``directory``."""
    frames = traceback.extract_tb(exc.__traceback__)
    return bool(frames) and os.path.abspath(frames[-1].filename).startswith(directory + os.sep)


def solver_error(exc: BaseException) -> bool:
    """``exc`` is a solver error a controller falls back on: a linear-algebra failure, or a ``RuntimeError``
    raised by CasADi (its plugins and IPOPT report through it). Anything else is a bug that fails the run."""
    return isinstance(exc, np.linalg.LinAlgError) or (isinstance(exc, RuntimeError)
                                                       and _raised_in(exc, _CASADI_DIR))


class PlanController:
    """Shared plan bookkeeping, warm-start shift and fallback of the MPCs."""

    def __init__(self, spec: ProblemSpec, reference, nominal_radii: tuple[float, float], time_budget: float | None,
                 cold_time_budget: float | None = 2.0, single_thread_blas: bool = True) -> None:
        if single_thread_blas:
            limit_blas_threads(1)
        self.spec = spec
        self.col = Collocation(spec)
        self.reference = reference
        self.nominal_radii = np.asarray(nominal_radii, dtype=float)
        self.time_budget = None if time_budget is None else float(time_budget)
        self.cold_time_budget = None if cold_time_budget is None else float(cold_time_budget)
        self.failures = 0
        """Number of samples that fell back (failed, over budget, or invalid input)."""
        self.solves = 0
        self._plan: tuple[float, np.ndarray, np.ndarray] | None = None  # (t0, X (N,3), U (N,2))
        self._last_radii = self.nominal_radii.copy()
        self._consecutive_failures = 0
        self._u_applied: np.ndarray | None = None
        self._u_prev: np.ndarray | None = None  # the first step's anchor: u_applied when the bound is on
        self._box = first_input_bounds(spec, None)  # (lo, hi) of U(t0) at this sample

    def reset(self) -> None:
        """Forget the plan, the warm start and the counters: a reset controller behaves exactly like a new one."""
        self._plan = None
        self.failures = 0
        self.solves = 0
        self._last_radii = self.nominal_radii.copy()
        self._lam = None
        self._consecutive_failures = 0
        self._reseed_wait = 0
        self._u_applied = None
        self._u_prev = None
        self._box = first_input_bounds(self.spec, None)
        qp = getattr(self, "_qp", None)
        if qp is not None:
            qp.reset()

    telemetry_columns: tuple[str, ...] = ()

    def solve(self, t: float, pose: np.ndarray, radii: np.ndarray,
              u_applied: np.ndarray | None = None) -> ControlOutput:
        """Command [omega_R, omega_L] (rad/s) at time ``t`` (s) for the measured ``pose``
        [x, y, psi] (m, m, rad) and the model radii [R_R, R_L] (m); ``u_applied`` (rad/s) is the
        command in force on the plant (``None`` before the first one). Raises ``ValueError`` for a
        ``u_applied`` that is not two finite numbers (a caller's bug, not a solver failure)."""
        t_start = time.perf_counter()
        self.solves += 1
        self._u_applied = None if u_applied is None else np.asarray(u_applied, dtype=float).copy()
        anchor = self._u_applied if self.spec.rate_bound_from_applied else None
        self._box = first_input_bounds(self.spec, anchor)  # raises for a non-finite anchor
        self._u_prev = None if anchor is None else np.clip(anchor, -self.spec.omega_max, self.spec.omega_max)
        try:
            out = self._solve(t, pose, radii, t_start)
        except (RuntimeError, np.linalg.LinAlgError) as exc:
            # only solver errors become a fallback: a linear-algebra failure, or an error raised by
            # CasADi (its plugins and IPOPT report through RuntimeError); anything else is a bug
            # that fails the run
            if not (isinstance(exc, np.linalg.LinAlgError) or _raised_in(exc, _CASADI_DIR)):
                raise
            out = self._fallback(t, f"solver error: {type(exc).__name__}: {exc}", t_start, None)
        self._consecutive_failures = self._consecutive_failures + 1 if out.fallback else 0
        return out

    def _prepare(self, t: float, pose: np.ndarray, radii: np.ndarray, t_start: float
                 ) -> ControlOutput | tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Sanitised radii, the reference (5, N) at the nodes and the initial state with its heading on the
        reference's branch; or the fallback output when pose or radii are not finite."""
        p = sanitize_pose(pose)
        r = sanitize_radii(radii)
        if p is None:
            return self._fallback(t, "non-finite pose", t_start, r)
        if r is None:
            return self._fallback(t, "non-finite radii", t_start, None)
        ref, psi = reference_at_nodes(self.reference, self.col.times(t), p[2])
        return r, ref, np.array([p[0], p[1], psi])

    def _solve(self, t: float, pose: np.ndarray, radii: np.ndarray, t_start: float) -> ControlOutput:
        raise TypeError(f"{type(self).__name__} must define _solve")

    # ------------------------------------------------------------------------------------------
    def _reference_inputs(self, ref: np.ndarray, radii: np.ndarray) -> np.ndarray:
        """Feed-forward wheel rates (N, 2) (rad/s) that realise the reference V, psidot."""
        wr, wl = inverse_rates(ref[3], ref[4], radii[0], radii[1], self.spec.half_track)
        om = self.spec.omega_max
        return np.clip(np.stack([wr, wl], axis=1), -om, om)

    def _guess(self, t: float, x0: np.ndarray, ref: np.ndarray, radii: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Shifted previous plan, or the reference if there is none, with its first input moved into this
        sample's first-step bound (a saturated previous sample must not leave an infeasible warm start).
        Heading moved to x0's branch."""
        if self._plan is None:
            Xg = ref[:3].T.copy()
            Ug = self._reference_inputs(ref, radii)
        else:
            t_prev, Xp, Up = self._plan
            Xg, Ug = self.col.shift(t_prev, Xp, Up, t, self.spec.half_track, radii)
            Xg[:, 2] += 2 * np.pi * np.round((x0[2] - Xg[0, 2]) / (2 * np.pi))
        Xg[0] = x0
        return Xg, self._into_first_step_bound(Ug)

    def _into_first_step_bound(self, U: np.ndarray) -> np.ndarray:
        """Plan inputs (N, 2) with the first input moved into this sample's first-step bound
        (:meth:`~ftc_mj.control.collocation.Collocation.project_first`); unchanged without the bound."""
        return U if self._u_prev is None else self.col.project_first(U, *self._box)

    def _fallback(self, t: float, status: str, t_start: float, radii: np.ndarray | None,
                  iterations: int = 0) -> ControlOutput:
        self.failures += 1
        om = self.spec.omega_max
        times = self.col.times(t)
        if self._plan is not None:
            t_prev, Xp, Up = self._plan
            r = self._last_radii if radii is None else radii
            X, U = self.col.shift(t_prev, Xp, Up, t, self.spec.half_track, r)
        else:
            r = self._last_radii if radii is None else radii
            ref = np.vstack([np.asarray(v, float) * np.ones_like(times) for v in self.reference.at(times)])
            U = self._reference_inputs(ref, r)
            X = ref[:3].T
        U = self._into_first_step_bound(np.clip(np.nan_to_num(U), -om, om))
        return ControlOutput(
            omega=U[0].copy(), success=False, status=f"fallback: {status}", iterations=iterations,
            solve_time=time.perf_counter() - t_start, fallback=True, predicted=X, predicted_t=times,
            predicted_omega=U,
        )

    def _accept(self, t: float, X: np.ndarray, U: np.ndarray, status: str, iterations: int, t_start: float,
                budget: float | None, radii: np.ndarray) -> ControlOutput:
        elapsed = time.perf_counter() - t_start
        if budget is not None and elapsed > budget:
            return self._fallback(t, f"over budget ({elapsed * 1e3:.1f} ms > {budget * 1e3:.1f} ms; {status})",
                                  t_start, radii, iterations)
        om = self.spec.omega_max
        U = np.clip(U, -om, om)
        lo, hi = self._box
        tol = 1e-6 * (1.0 + om)  # solvers meet bounds to ~1e-7 (IPOPT's bound relaxation, DAQP's 1e-6)
        if np.any(U[0] < lo - tol) or np.any(U[0] > hi + tol):
            return self._fallback(t, f"first input outside the first-step bound ({status})", t_start, radii,
                                  iterations)
        U[0] = np.clip(U[0], lo, hi)  # exact within the solver's tolerance
        self._plan = (t, X.copy(), U.copy())
        self._last_radii = radii.copy()
        return ControlOutput(
            omega=U[0].copy(), success=True, status=status, iterations=iterations,
            solve_time=time.perf_counter() - t_start, fallback=False, predicted=X,
            predicted_t=self.col.times(t), predicted_omega=U,
        )


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
        self._lam: tuple[np.ndarray, np.ndarray] | None = None
        self._consecutive_failures = 0
        self._reseed_wait = 0

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
        self._nlp = ca.nlpsol("nmpc", "ipopt", {"x": w, "p": p, "f": J, "g": g}, self._ipopt_options())
        self.nlp_size = (w.numel(), g.numel())

    def _ipopt_options(self) -> dict:
        """IPOPT options of every NLP of this controller (quiet, warm start, the wall-time budget)."""
        opts = {
            "print_time": False,
            "ipopt.print_level": 0,
            "ipopt.sb": "yes",
            "ipopt.max_iter": self.max_iter,
            "ipopt.warm_start_init_point": "yes",
            "ipopt.mu_init": 1e-4,
            "ipopt.tol": 1e-8,
            "error_on_fail": False,
        }
        budgets = [b for b in (self.cold_time_budget, self.time_budget) if b is not None]
        if budgets:
            opts["ipopt.max_wall_time"] = max(budgets)
        return opts

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
        reseed = self._qp is not None and self._consecutive_failures >= 2 and self._reseed_wait == 0
        self._reseed_wait = max(self._reseed_wait - 1, 0)
        cold = self._plan is None or reseed
        if self._qp is None or cold:
            ok, status, it, X, U = self._ipopt(x0, r, ref, Xg, Ug)
            budget = self.cold_time_budget if cold else self.time_budget
            if cold and self._qp is not None:
                status = f"ipopt seed: {status}"
        else:
            ok, status, X, U = self._rti_step(Xg, Ug, r, x0, ref)
            it, budget = 1, self.time_budget
            status = f"rti: {status}"
        if not ok:
            if reseed:
                # an IPOPT re-seed failed too: go on with RTI steps from the shifted plan and do not try
                # another (costly) re-seed for RESEED_WAIT samples
                self._reseed_wait = RESEED_WAIT
            return self._fallback(t, status, t_start, r, it)
        return self._accept(t, X, U, status, it, t_start, budget, r)


class OptiNMPC:
    """The same NLP written plainly with ``casadi.Opti`` + IPOPT (verification and benchmark only).

    ``solve(x0, radii, ref, X_init, U_init, u_prev=None)`` returns ``(X (N,3), U (N,2), iterations)``;
    ``u_prev`` (rad/s) is the input in force before ``t0`` (first-step bound and penalty, written here
    as a bounded constraint on ``U(t0)`` and a plain penalty term); primal and dual warm start from
    the previous call.
    """

    def __init__(self, spec: ProblemSpec) -> None:
        col = Collocation(spec)
        self.col = col
        N, h = col.N, col.h
        opti = ca.Opti()
        X = opti.variable(3, N)
        U = opti.variable(2, N)
        x0 = opti.parameter(3)
        r = opti.parameter(2)
        ref = opti.parameter(5, N)
        u_prev, lo, hi, on = opti.parameter(2), opti.parameter(2), opti.parameter(2), opti.parameter()
        D = ca.DM(col.D)
        f = col.model.casadi_derivative()
        rates = col.model.casadi_rates()
        J = 0
        for j in range(N):
            xj = ca.vertcat(X[:, j], r)
            fj = f(xj, U[:, j])[:3]
            opti.subject_to(ca.mtimes(X, D[j, :].T) / h == fj)
            vp = rates(xj, U[:, j])
            J += col.W[j] * (spec.q_pose * ca.sumsqr(X[:, j] - ref[:3, j]) + spec.q_speed * (vp[0] - ref[3, j]) ** 2
                             + spec.q_yaw_rate * (vp[1] - ref[4, j]) ** 2)
            if spec.rate_penalty > 0:
                J += col.W[j] * spec.rate_penalty * ca.sumsqr(ca.mtimes(U, D[j, :].T) / h)
        opti.subject_to(X[:, 0] == x0)
        opti.subject_to(opti.bounded(-spec.omega_max, U, spec.omega_max))
        rate = spec.omega_rate_max * h
        opti.subject_to(opti.bounded(-rate, ca.mtimes(U, D.T), rate))
        opti.subject_to(opti.bounded(lo, U[:, 0], hi))
        if spec.rate_penalty > 0:  # rate_penalty T_s |(U(t0) - u_prev)/T_s|^2 (on = 0 without u_prev)
            Ts = spec.sample_time
            J += on * spec.rate_penalty * Ts * ca.sumsqr((U[:, 0] - u_prev) / Ts)
        opti.minimize(J)
        opti.solver("ipopt", {"print_time": False, "expand": True},
                    {"print_level": 0, "sb": "yes", "tol": 1e-8, "warm_start_init_point": "yes", "mu_init": 1e-4})
        self.opti, self.X, self.U, self.x0, self.r, self.ref = opti, X, U, x0, r, ref
        self._first = (u_prev, lo, hi, on)
        self.spec = spec
        self._lam = None

    def solve(self, x0: np.ndarray, radii: np.ndarray, ref: np.ndarray, X_init: np.ndarray, U_init: np.ndarray,
              u_prev: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, int]:
        o = self.opti
        u_p, lo, hi, on = self._first
        om, step = self.spec.omega_max, self.spec.omega_rate_max * self.spec.sample_time
        if u_prev is None:
            o.set_value(u_p, np.zeros(2))
            o.set_value(on, 0.0)
            o.set_value(lo, np.full(2, -om))
            o.set_value(hi, np.full(2, om))
        else:
            ua = np.clip(u_prev, -om, om)
            o.set_value(u_p, ua)
            o.set_value(on, 1.0 if self.spec.rate_penalty_first_step else 0.0)
            o.set_value(lo, np.maximum(ua - step, -om))
            o.set_value(hi, np.minimum(ua + step, om))
        o.set_value(self.x0, x0)
        o.set_value(self.r, radii)
        o.set_value(self.ref, ref)
        o.set_initial(self.X, X_init.T)
        o.set_initial(self.U, U_init.T)
        if self._lam is not None:
            o.set_initial(o.lam_g, self._lam)
        sol = o.solve()
        self._lam = sol.value(o.lam_g)
        it = int(sol.stats()["iter_count"])
        return np.asarray(sol.value(self.X)).T, np.asarray(sol.value(self.U)).T, it
