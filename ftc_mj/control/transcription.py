"""The LGL transcription of the tracking problem shared by the NMPCs and the linear MPC.

Decision variables on ``N`` LGL nodes over the horizon ``[t0, t0 + T]``: states
``X = [x, y, psi]`` (m, m, rad) and inputs ``U = [omega_R, omega_L]`` (rad/s) at every node.
Stacking used everywhere: ``w = [x(N), y(N), psi(N), omega_R(N), omega_L(N)]``; inputs alone
``u = [omega_R(N), omega_L(N)]``.

Constraints (paper §3): collocation ``(2/T) D X = f(X, U; R_R, R_L, b)`` at all N nodes, the
initial-state equality ``X(t0) = pose``, input bounds ``|omega| ≤ omega_max``, input-rate bounds
``|(2/T) D omega| ≤ omega_rate_max`` inside the plan and, from the input in force on the plant before
``t0`` (``u_prev``, held since the previous sample), the same bound over one controller period
``T_s``: ``|U(t0) − u_prev| ≤ omega_rate_max T_s`` (a receding-horizon controller's rate bound ties
the plan to the input it replaces; there is none before the first command). Optionally, a
lateral-acceleration (roll-over) bound ``|V psidot| ≤ max_lateral_accel`` at every node (linearised
about the guess in the QP) and a longitudinal-acceleration (pitch-over) bound
``|dV/dt| ≤ max_longitudinal_accel`` (linear in the inputs for given radii, so exact in the QP).

Cost (paper §3): ``(T/2) Σ_j w_j (q_pose ‖X_j − X_ref,j‖² + q_speed (V_j − V_ref,j)² +
q_yaw_rate (psidot_j − psidot_ref,j)²)`` plus the optional ``rate_penalty (T/2) Σ_j w_j
‖(2/T)(D U)_j‖²``, the quadrature of ``rate_penalty ∫ ‖dU/dt‖² dt`` over the horizon. With
``u_prev`` the penalty also covers the step into the plan, ``rate_penalty T_s ‖(U(t0) − u_prev)/T_s‖²``:
the same integral over the sample period before ``t0`` with the step spread evenly over it (the
smallest ``∫ ‖dU/dt‖² dt`` that reaches ``U(t0)`` from ``u_prev`` in ``T_s``). ``V`` and ``psidot``
are linear in the inputs for given radii, and the pose error is linear in the states, so the cost is
an exact quadratic: its Gauss–Newton Hessian is exact, and only the collocation constraints are
nonlinear (through cos psi, sin psi).

:class:`~ftc_mj.control.condensed_qp.CondensedQP` linearises the collocation about a guess and eliminates
the states exactly, which leaves a dense QP in the 2N inputs only (3 equality rows + 2N rate rows + box bounds; the
bound from ``u_prev`` tightens the box of the two first inputs, so the CasADi plugin and the
certified path receive it as the same ``lbx``/``ubx``). The
elimination uses the structure of the kinematics (``f`` does not depend on x, y; psidot depends on
the inputs only): with node 0 replaced by the initial condition, each state obeys
``X_s = Dt^{-1} [x0_s; rhs_s(1:)]`` with the constant matrix ``Dt = [e_0ᵀ; (2/T) D(1:, :)]``; the
three node-0 collocation equations stay as equality constraints.

Heading convention: the controllers shift the *measured* heading by a multiple of 2π so that it is
nearest the (unwrapped) reference heading at t0; predictions are reported in that frame.
"""

from __future__ import annotations

import numpy as np

from ..lazy import lazy_module
from ..model.kinematics import KinematicModel, pose_rates
from .lgl import barycentric_weights, lgl
from .spec import ProblemSpec

ca = lazy_module("casadi")


class Collocation:
    """LGL grid and the symbolic pieces of the problem (built once)."""

    def __init__(self, spec: ProblemSpec) -> None:
        self.spec = spec
        N = spec.nodes
        self.N = N
        self.tau, self.w, self.D = lgl(N)
        self.bw = barycentric_weights(self.tau)
        self.h = spec.horizon / 2.0  # dt/dtau (s)
        self.W = self.h * self.w  # quadrature weights in time (s)
        self.model = KinematicModel(b=spec.half_track)
        f = self.model.casadi_derivative()
        xs, us, rs = ca.SX.sym("x", 3), ca.SX.sym("u", 2), ca.SX.sym("r", 2)
        fx = f(ca.vertcat(xs, rs), us)[:3]
        lin = ca.Function("lin", [xs, us, rs], [fx, ca.densify(ca.jacobian(fx, xs)), ca.densify(ca.jacobian(fx, us))])
        self.lin = lin.map(N, [False, False, True], [False, False, False])  # (3xN, 2xN, 2x1) -> (3xN, 3x3N, 3x2N)
        rates = self.model.casadi_rates()
        self.rates_jac = ca.Function("rj", [rs], [ca.densify(ca.jacobian(rates(ca.vertcat(0, 0, 0, rs), us), us))])

    def nlp_terms(self, X: ca.SX, U: ca.SX, x0: ca.SX, radii: ca.SX, ref: ca.SX, u_prev: ca.SX, c_step: ca.SX
                  ) -> tuple[ca.SX, ca.SX, np.ndarray, np.ndarray]:
        """Cost and constraints of one trajectory of the NLP (module docstring), symbolically.

        Parameters
        ----------
        X, U : SX (3, N), (2, N)
            States [x, y, psi] (m, m, rad) and inputs [omega_R, omega_L] (rad/s) at the nodes.
        x0 : SX (3,)
            Initial pose; the heading on the reference's branch (rad).
        radii : SX (2,)
            Model radii [R_R, R_L] (m).
        ref : SX (5, N)
            Reference x, y, psi, V, psidot at the nodes.
        u_prev, c_step : SX (2,), SX
            Input in force before ``t0`` (rad/s) and the weight of the first-step penalty
            ``c_step ‖U(t0) − u_prev‖²`` (:func:`first_step_penalty`; 0 switches it off). The first-step
            *bound* is not a row here: it bounds the variables ``U(t0)`` (:func:`first_input_bounds`).

        Returns
        -------
        J : SX
            Quadrature of the tracking cost (plus the rate penalty and the first-step penalty when the
            rate penalty is enabled).
        g, lbg, ubg
            Constraints ``lbg ≤ g ≤ ubg`` in this order: collocation (3N, node-major), initial state (3),
            input rates ``D U`` per unit tau (2N), then the optional lateral- (N) and longitudinal- (N)
            acceleration rows.
        """
        sp, N, h = self.spec, self.N, self.h
        f = self.model.casadi_derivative().map(N)
        rates = self.model.casadi_rates().map(N)
        Xfull = ca.vertcat(X, ca.repmat(radii, 1, N))
        xdot = f(Xfull, U)[:3, :]
        D = ca.DM(self.D)
        colloc = (ca.mtimes(X, D.T) / h - xdot).T  # N x 3, rows = nodes
        Vp = rates(Xfull, U)  # 2 x N
        Wq = ca.DM(self.W).T
        err = X - ref[:3, :]
        J = sp.q_pose * ca.sum2(Wq * ca.sum1(err**2))
        J += sp.q_speed * ca.sum2(Wq * (Vp[0, :] - ref[3, :]) ** 2)
        J += sp.q_yaw_rate * ca.sum2(Wq * (Vp[1, :] - ref[4, :]) ** 2)
        dU = ca.mtimes(U, D.T)  # 2 x N, d/dtau
        if sp.rate_penalty > 0:
            J += sp.rate_penalty * ca.sum2(Wq * ca.sum1((dU / h) ** 2))
            J += c_step * ca.sumsqr(U[:, 0] - u_prev)  # the step from the input in force
        g = ca.vertcat(ca.vec(colloc), X[:, 0] - x0, ca.vec(dU.T))
        rate = sp.omega_rate_max * h
        lbg = np.concatenate([np.zeros(3 * N + 3), -rate * np.ones(2 * N)])
        ubg = np.concatenate([np.zeros(3 * N + 3), rate * np.ones(2 * N)])
        if sp.max_lateral_accel is not None:  # roll-over bound |V psidot| at every node
            g = ca.vertcat(g, (Vp[0, :] * Vp[1, :]).T)
            lbg = np.concatenate([lbg, -sp.max_lateral_accel * np.ones(N)])
            ubg = np.concatenate([ubg, sp.max_lateral_accel * np.ones(N)])
        if sp.max_longitudinal_accel is not None:  # |dV/dt| at every node
            Vd = rates(ca.vertcat(ca.DM.zeros(3, N), ca.repmat(radii, 1, N)), dU / h)[0, :]
            g = ca.vertcat(g, Vd.T)
            lbg = np.concatenate([lbg, -sp.max_longitudinal_accel * np.ones(N)])
            ubg = np.concatenate([ubg, sp.max_longitudinal_accel * np.ones(N)])
        return J, g, lbg, ubg

    def times(self, t0: float) -> np.ndarray:
        """Absolute node times (s) of a horizon starting at ``t0``."""
        return t0 + (self.tau + 1.0) * self.h

    def shift(self, t_prev: float, X: np.ndarray, U: np.ndarray, t_new: float, b: float, radii: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
        """Previous plan (X (N,3), U (N,2) on nodes starting at ``t_prev``) evaluated on the nodes
        starting at ``t_new`` by barycentric Lagrange interpolation. Beyond the old horizon end the
        inputs are held and the states extrapolated with the model (no polynomial extrapolation)."""
        tn = self.times(t_new)
        tau_q = (tn - t_prev) / self.h - 1.0
        inside = tau_q <= 1.0
        tau_c = np.clip(tau_q, -1.0, 1.0)
        diff = tau_c[:, None] - self.tau[None, :]
        exact = diff == 0.0
        diff[exact] = 1.0
        C = self.bw[None, :] / diff
        C /= C.sum(axis=1, keepdims=True)
        r, c = np.nonzero(exact)
        C[r, :] = 0.0
        C[r, c] = 1.0
        Xn = C @ X
        Un = C @ U
        if not np.all(inside):
            xe, ue = X[-1], U[-1]
            dxe = np.array(pose_rates(xe[2], radii[0], radii[1], ue[0], ue[1], b))  # numpy: a CasADi call ~0.1 ms
            dt = (tn[~inside] - (t_prev + 2 * self.h))[:, None]
            Xn[~inside] = xe[None, :] + dt * dxe[None, :]
            Un[~inside] = ue[None, :]
        return Xn, Un

    def project_first(self, U: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Plan inputs ``U`` (N, 2) (rad/s) moved so that ``lo ≤ U[0] ≤ hi`` (rad/s, (2,)).

        The correction ``δ = clip(U[0], lo, hi) − U[0]`` of each wheel fades out linearly over
        ``|δ| / omega_rate_max`` seconds, so it adds at most ``omega_rate_max`` to the plan's rate
        (a node-0-only clip would put a step of ``δ`` over the first LGL interval, ~5 ms); the
        result is clipped to ``±omega_max``. A ``U`` that meets the bounds is returned unchanged.
        """
        delta = np.clip(U[0], lo, hi) - U[0]
        if not np.any(delta):
            return U
        dt = self.times(0.0)[:, None]  # time since t0 (s) of every node
        fade = np.maximum(1.0 - dt * self.spec.omega_rate_max / np.maximum(np.abs(delta), 1e-300), 0.0)
        om = self.spec.omega_max
        V = np.clip(U + delta[None, :] * fade, -om, om)
        V[0] = np.clip(U[0], lo, hi)  # exact at t0 whatever the rounding above
        return V

