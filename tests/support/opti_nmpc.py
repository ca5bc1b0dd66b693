"""The NMPC's NLP written plainly with ``casadi.Opti`` + IPOPT: the reference the package's NMPC is
tested (and benchmarked) against."""

from __future__ import annotations

import casadi as ca
import numpy as np

from ftc_mj.control.spec import ProblemSpec
from ftc_mj.control.transcription import Collocation


class OptiNMPC:
    """The same NLP written plainly with ``casadi.Opti`` + IPOPT (the test and benchmark reference).

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

    def reset(self) -> None:
        """Forget the dual warm start (a reset instance solves like a new one)."""
        self._lam = None
        self.opti.set_initial(self.opti.lam_g, np.zeros(self.opti.lam_g.shape[0]))

    def solve(self, x0: np.ndarray, radii: np.ndarray, ref: np.ndarray, X_init: np.ndarray, U_init: np.ndarray,
              u_prev: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, int]:
        """The plan ``(X (N, 3), U (N, 2), iterations)`` from pose ``x0`` (m, m, rad) with the model radii (m),
        the reference (5, N) at the nodes and the initial guess; ``u_prev`` (rad/s) the input in force."""
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
