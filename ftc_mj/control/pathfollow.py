"""Path-following NMPC (model-predictive contouring control) on the LGL pseudospectral grid.

The path is geometric, ``s -> (x_p, y_p, θ, κ)`` by arc length (:mod:`~ftc_mj.control.reference`), and
the progress ``s`` (m) is a state with its own rate ``v`` (m/s) as an extra input (model-predictive
path following, Faulwasser & Findeisen 2016; contouring control, Liniger et al. 2015). Nothing in
the problem depends on the time: the controller never asks the robot to catch up with a clock.

Grid and stacking: the NMPC's ``N`` LGL nodes over ``[t0, t0 + T]`` (:class:`Collocation`); states
``X = [x, y, psi, s]`` (m, m, rad, m), inputs ``U = [omega_R, omega_L, v]`` (rad/s, rad/s, m/s) at the
nodes and one slack ``σ ≥ 0`` (m/s²). QP variables ``u = [omega_R(N), omega_L(N), v(N), σ]``.

Dynamics (collocation at every node): the kinematics ``(2/T) D [x, y, psi] = f(X, U; R_R, R_L, b)``
and ``(2/T) D s = v``; ``X(t0) = [pose, s0]`` where ``s0`` is the arc length of the path point nearest
the measured pose (:func:`~ftc_mj.control.reference.project`), re-measured at every sample like the
pose itself.

Cost, ``Σ_j W_j (…)_j`` with the Gauss–Lobatto weights ``W_j`` (s) and the path at the node's own
progress ``s_j``::

    q_contour e_c² + q_lag e_l² + q_heading (psi − θ(s))² + q_progress (v − V_des)²
      + rate_penalty ‖(2/T) D omega‖² + progress_rate_penalty ((2/T) D v)²   + slack_penalty σ + σ²

with the contouring error ``e_c = −sin θ (x − x_p) + cos θ (y − y_p)`` (m, positive left of the path)
and the lag error ``e_l = cos θ (x − x_p) + sin θ (y − y_p)`` (m, positive ahead of the progress point).

The model's wheel rates are the commanded ones plus the offset ``δ`` of the servo compliance at the
applied command (:func:`compliance_offset`; zero on the kinematic plant): the velocity servos yield
under the tyres' yaw couple, so the robot turns less than the kinematic model of the commands says.

Constraints at every node: ``|omega − δ| ≤ omega_max``; ``|(2/T) D omega| ≤ omega_rate_max``; at
``t0`` ``|omega(t0) − δ − u_applied| ≤ omega_rate_max T_s`` (the command in force on the plant,
``T_s`` the sample time; none before the first command); ``0 ≤ v ≤ max_progress_speed``;
``|dV/dt| ≤ max_longitudinal_accel``, and across samples ``|V(t0) − V_applied| ≤
max_longitudinal_accel T_s`` (a plan may not start at a speed the robot cannot reach from the
applied command); the traction bound ``|V psidot| + β |dV/dt| ≤ max_lateral_accel + σ`` (at ``t0``
``dV/dt`` is also ``(V(t0) − V_applied)/T_s``): the lateral acceleration the inner tyre can carry
falls by ``β`` (``braking_trade``) per m/s² of braking (:mod:`ftc_mj.plant.limits`). The single
slack ``σ`` (an exact L∞ penalty) keeps the problem feasible when the applied command itself
violates the bound under the model's radii (a hand-over of new radii changes the model's
``V psidot`` of the same wheel rates); whenever the bound can be met, ``σ = 0``. With the
estimated radii the feasible speed follows from the wheel-rate bound: on a circle of radius ``R_p``
the inner wheel of radius ``r`` carries at most ``V = r omega_max / (1 − b/R_p)``.

Solvers: ``ipopt`` (the full NLP, the path symbolic through ``geometry(s, casadi)``) and
``rti-<qp>`` — one Gauss–Newton SQP step per sample about the shifted previous plan: the residuals
``e_c, e_l, psi − θ`` are linearised in ``(x, y, psi, s)`` through ``de_c/ds = −κ e_l``,
``de_l/ds = κ e_c − 1``, ``dθ/ds = κ``, the states are eliminated exactly
(:class:`~ftc_mj.control.collocation.StateElimination`) and the dense QP in ``u`` is solved by the
certified active-set path (:class:`~ftc_mj.control.certified_qp.CertifiedQP`), else the named
CasADi QP plugin. The first solve, and a re-seed after two consecutive failures, is an IPOPT solve.
A failed or over-budget solve, a solver error or a non-finite pose/radii falls back to the shifted
previous plan like the NMPC's; any other exception propagates and fails the run.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ..model.kinematics import inverse_rates
from .base import ControlOutput
from .certified_qp import CertifiedQP
from .collocation import (
    BufferedFunction,
    Collocation,
    ProblemSpec,
    StateElimination,
    _default_qp_options,
    lateral_accel_linearisation,
    limit_blas_threads,
    sanitize_pose,
    sanitize_radii,
    warm_started_solve,
)
from .lgl import interpolation_matrix
from .nmpc import RESEED_WAIT, solver_error
from .reference import Path, path_errors, project

SOLVERS = ("ipopt", "rti-daqp", "rti-qpoases", "rti-osqp")
TWO_PI = 2.0 * np.pi
SLACK_MAX = 100.0
"""Upper bound of the lateral-acceleration slack (m/s²; any violation the applied command can cause)."""
ROW_FAR = 1.0e6
"""Finite stand-in (m/s²) for the open side of a one-sided row in the certified QP path."""

TELEMETRY = ("pf_progress", "pf_contouring_error", "pf_lag_error", "pf_speed_desired", "pf_speed_planned",
             "pf_progress_speed", "pf_lateral_accel", "pf_lateral_bound", "pf_slack", "pf_yaw_offset")
"""Trace columns of the path-following NMPC (on controller samples): progress ``s0`` (m), contouring and
lag error (m) of the measured pose, desired and planned speed at ``t0`` (m/s), planned progress speed
(m/s), the robot's planned lateral acceleration ``V psidot`` at ``t0`` and its bound (m/s²), the slack ``σ``
(m/s²), the yaw-rate offset of the servo compliance (rad/s)."""


@dataclass(frozen=True)
class RobotLimits:
    """Numbers of the physical robot the path-following NMPC is given (derived by the sim layer from the plant
    model, :func:`ftc_mj.plant.limits.lateral_accel_limits`; the control layer knows no plant)."""

    liftoff_accel: float
    """Lateral acceleration (m/s²) at which the robot starts to lift its inner wheel, without braking."""
    yaw_compliance: float = 0.0
    """Commanded minus actual yaw rate (rad/s) per m/s² of lateral acceleration with the nominal tyres (s/m)."""
    braking_trade: float = 0.0
    """Loss of the lift-off limit per m/s² of braking (dimensionless)."""


@dataclass(frozen=True)
class PathFollowingSpec:
    """Numbers of the path-following problem (units in the field comments).

    ``problem`` supplies the grid and the robot (``nodes``, ``horizon``, ``half_track``,
    ``omega_max``, ``omega_rate_max``, ``rate_penalty``, ``max_lateral_accel`` — the bound on the
    robot's lateral acceleration, ``max_longitudinal_accel``); its tracking weights are not used.
    """

    problem: ProblemSpec
    desired_speed: float = 10.0  # m/s
    q_contour: float = 30.0  # 1/m² s
    q_lag: float = 10.0  # 1/m² s
    q_heading: float = 10.0  # 1/rad² s
    q_progress: float = 1.0  # s/m²
    progress_rate_penalty: float = 0.1  # s³/m²
    max_progress_speed: float = 20.0  # m/s
    yaw_compliance: float = 0.0  # s/m
    braking_trade: float = 0.0  # lateral bound lost per m/s² of longitudinal acceleration
    sample_time: float = 0.1  # s
    slack_penalty: float = 1.0e4  # per m/s² of slack


class PathFollowingNMPC:
    """Path-following NMPC. ``solve(t, pose, radii, u_applied)`` is called at the control rate.

    Parameters: ``spec`` (problem numbers), ``path`` (has ``geometry(s, lib)``), ``solver`` (one of
    :data:`SOLVERS`), ``max_iter`` (IPOPT iteration limit; 0 forces every solve to fail),
    ``time_budget`` (s, wall time of a warm solve), ``cold_time_budget`` (s, of an IPOPT solve),
    ``nominal_radii`` (m, used before any valid radii have been seen), ``qp_options`` (plugin options).
    """

    telemetry_columns: tuple[str, ...] = TELEMETRY

    def __init__(self, spec: PathFollowingSpec, path: Path, solver: str = "rti-daqp", max_iter: int = 30,
                 time_budget: float | None = None, nominal_radii: tuple[float, float] = (2.0, 2.0),
                 cold_time_budget: float | None = None, qp_options: dict | None = None) -> None:
        if solver not in SOLVERS:
            raise ValueError(f"unknown path-following NMPC solver {solver!r}; expected one of {SOLVERS}")
        limit_blas_threads(1)
        self.spec = spec
        self.path = path
        self.solver_name = solver
        self.max_iter = int(max_iter)
        self.time_budget = time_budget
        self.cold_time_budget = cold_time_budget
        self.nominal_radii = np.asarray(nominal_radii, dtype=float)
        self.col = Collocation(spec.problem)
        self.qp = PathQP(self.col, spec, path, solver.split("-", 1)[1], qp_options) if solver != "ipopt" else None
        self._nlp = PathNLP(self.col, spec, path, self.max_iter, cold_time_budget, time_budget)
        self.reset()

    def reset(self) -> None:
        """Forget the plan, the warm starts and the counters: a reset controller behaves like a new one."""
        self.failures = 0
        self.solves = 0
        self._plan: tuple[float, np.ndarray, np.ndarray] | None = None  # (t0, X (N,4), U (N,3))
        self._last_radii = self.nominal_radii.copy()
        self._consecutive_failures = 0
        self._reseed_wait = 0
        self._offset = np.zeros(2)
        self._nlp.reset()
        if self.qp is not None:
            self.qp.reset()

    # ------------------------------------------------------------------------------------------
    def solve(self, t: float, pose: np.ndarray, radii: np.ndarray,
              u_applied: np.ndarray | None = None) -> ControlOutput:
        """Command [omega_R, omega_L] (rad/s) at ``t`` (s) for the measured ``pose`` [x, y, psi]
        (m, m, rad), the model radii [R_R, R_L] (m) and the command ``u_applied`` (rad/s) in force."""
        t_start = time.perf_counter()
        self.solves += 1
        try:
            out = self._solve(t, pose, radii, u_applied, t_start)
        except (RuntimeError, np.linalg.LinAlgError) as exc:
            if not solver_error(exc):
                raise
            out = self._fallback(t, f"solver error: {type(exc).__name__}: {exc}", t_start, None)
        self._consecutive_failures = self._consecutive_failures + 1 if out.fallback else 0
        return out

    def initial_state(self, pose: np.ndarray, s_pred: float) -> np.ndarray:
        """``[x, y, psi, s0]``: the measured pose with its progress ``s0`` (the nearest path point, searched
        around ``s_pred``, the progress the previous plan predicted) and the heading moved by a multiple
        of 2π to the branch nearest the path tangent θ(s0)."""
        sp = self.spec
        window = max(0.5 * sp.desired_speed * sp.problem.horizon, 10.0)
        s0 = project(self.path, float(pose[0]), float(pose[1]), s_pred, window)
        th = float(self.path.geometry(np.array([s0])).heading[0])
        psi = float(pose[2]) + TWO_PI * np.round((th - float(pose[2])) / TWO_PI)
        return np.array([pose[0], pose[1], psi, s0])

    def _solve(self, t: float, pose: np.ndarray, radii: np.ndarray, u_applied: np.ndarray | None,
               t_start: float) -> ControlOutput:
        p, r = sanitize_pose(pose), sanitize_radii(radii)
        if p is None:
            return self._fallback(t, "non-finite pose", t_start, r)
        if r is None:
            return self._fallback(t, "non-finite radii", t_start, None)
        om = self.spec.problem.omega_max
        ua = None if u_applied is None else np.clip(np.asarray(u_applied, float), -om, om)
        if ua is not None and not np.all(np.isfinite(ua)):
            ua = None
        shifted = self._shift(t, r) if self._plan is not None else None
        s_pred = float(shifted[0][0, 3]) if shifted is not None else 0.0
        x0 = self.initial_state(p, s_pred)
        self._offset = compliance_offset(self.spec, ua, r, self.nominal_radii)
        bounds = wheel_bounds(self.spec, self.col.N, ua, self._offset)
        V_app = None if ua is None else 0.5 * float(r @ (ua + self._offset))
        Xg, Ug = self._guess(t, x0, r, shifted)
        if self.max_iter == 0:
            return self._fallback(t, "max_iter=0", t_start, r)
        ok, status, it, X, U, sig, budget = self._iterate(x0, r, bounds, V_app, Xg, Ug)
        elapsed = time.perf_counter() - t_start
        if ok and budget is not None and elapsed > budget:
            ok, status = False, f"over budget ({elapsed * 1e3:.1f} ms > {budget * 1e3:.1f} ms; {status})"
        if not ok:
            return self._fallback(t, status, t_start, r, it)
        self._plan = (t, X.copy(), U.copy())
        self._last_radii = r.copy()
        cmd = self._command(U)
        return ControlOutput(
            omega=cmd[0].copy(), success=True, status=status, iterations=it,
            solve_time=time.perf_counter() - t_start, predicted=X[:, :3], predicted_t=self.col.times(t),
            predicted_omega=cmd, telemetry=self._telemetry(x0, s_pred, X, U, r, sig))

    def _iterate(self, x0: np.ndarray, r: np.ndarray, bounds: tuple[np.ndarray, np.ndarray], V_app: float | None,
                 Xg: np.ndarray, Ug: np.ndarray) -> tuple:
        """One solve: ``(ok, status, iterations, X, U, σ, budget)``. IPOPT for the ``ipopt`` solver, for the
        first solve and for a re-seed after two consecutive failures (none for :data:`RESEED_WAIT` samples after
        a re-seed failed); else one RTI step. ``budget`` (s) is the wall-time budget of that kind of solve."""
        seed_due = self.qp is not None and self._consecutive_failures >= 2 and self._reseed_wait == 0
        self._reseed_wait = max(self._reseed_wait - 1, 0)
        first = self._plan is None or seed_due
        if self.qp is not None and not first:
            ok, status, X, U, sig = self.qp.solve(Xg, Ug, r, x0, bounds, V_app)
            return ok, f"rti: {status}", 1, X, U, sig, self.time_budget
        ok, status, it, X, U, sig = self._nlp.solve(x0, r, bounds, V_app, Xg, Ug)
        if not ok and seed_due:
            self._reseed_wait = RESEED_WAIT
        label = f"ipopt seed: {status}" if self.qp is not None else status
        return ok, label, it, X, U, sig, self.cold_time_budget if first else self.time_budget

    def _command(self, U: np.ndarray) -> np.ndarray:
        """Wheel-rate commands (N, 2) (rad/s) of the model's planned rates: minus the input offset, clipped."""
        om = self.spec.problem.omega_max
        return np.clip(np.nan_to_num(U[:, :2] - self._offset[None, :]), -om, om)

    def _telemetry(self, x0: np.ndarray, s_pred: float, X: np.ndarray, U: np.ndarray, radii: np.ndarray,
                   slack: float) -> dict[str, float]:
        sp, b = self.spec, self.spec.problem.half_track
        bias = (radii[0] * self._offset[0] - radii[1] * self._offset[1]) / (2.0 * b)
        ec, _ = path_errors(self.path, x0[:1], x0[1:2], x0[3:4])
        _, el = path_errors(self.path, x0[:1], x0[1:2], np.array([s_pred]))
        V = 0.5 * (radii[0] * U[0, 0] + radii[1] * U[0, 1])
        a = V * (radii[0] * U[0, 0] - radii[1] * U[0, 1]) / (2.0 * b)
        bound = sp.problem.max_lateral_accel
        return {
            "pf_progress": float(x0[3]), "pf_contouring_error": float(ec[0]),
            "pf_lag_error": float(el[0]) if self.solves > 1 else float("nan"),
            "pf_speed_desired": sp.desired_speed, "pf_speed_planned": float(V),
            "pf_progress_speed": float(U[0, 2]), "pf_lateral_accel": float(a),
            "pf_lateral_bound": float("nan") if bound is None else float(bound), "pf_slack": float(slack),
            "pf_yaw_offset": float(bias),
        }

    def _feed_forward(self, t: float, x0: np.ndarray, radii: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The path ahead of ``x0`` traversed at the desired speed: states (N, 4) and inputs (N, 3)."""
        sp = self.spec
        s = x0[3] + sp.desired_speed * (self.col.times(t) - t)
        g = self.path.geometry(s)
        X = np.column_stack([g.x, g.y, g.heading + (x0[2] - g.heading[0]), s])
        V = np.full_like(s, sp.desired_speed)
        wr, wl = inverse_rates(V, V * g.curvature, radii[0], radii[1], sp.problem.half_track)
        om = sp.problem.omega_max
        return X, np.column_stack([np.clip(wr, -om, om), np.clip(wl, -om, om), V])

    def _shift(self, t: float, radii: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The previous plan on the nodes starting at ``t`` (pose and wheel rates by the collocation's
        shift; progress and its rate by the same interpolation, the rate held beyond the old horizon)."""
        assert self._plan is not None
        t_prev, Xp, Up = self._plan
        col = self.col
        Xn, Un = col.shift(t_prev, Xp[:, :3], Up[:, :2], t, self.spec.problem.half_track, radii)
        tau_q = (col.times(t) - t_prev) / col.h - 1.0
        C = interpolation_matrix(col.tau, np.clip(tau_q, -1.0, 1.0), col.bw)
        s, v = C @ Xp[:, 3], C @ Up[:, 2]
        out = tau_q > 1.0
        s[out] = Xp[-1, 3] + Up[-1, 2] * (tau_q[out] - 1.0) * col.h
        v[out] = Up[-1, 2]
        return np.column_stack([Xn, s]), np.column_stack([Un, v])

    def _guess(self, t: float, x0: np.ndarray, radii: np.ndarray,
               shifted: tuple[np.ndarray, np.ndarray] | None) -> tuple[np.ndarray, np.ndarray]:
        """The shifted previous plan (heading on x0's branch), or the feed-forward; node 0 set to ``x0``."""
        if shifted is None:
            Xg, Ug = self._feed_forward(t, x0, radii)
        else:
            Xg, Ug = shifted
            Xg[:, 2] += TWO_PI * np.round((x0[2] - Xg[0, 2]) / TWO_PI)
        Xg[0] = x0
        return Xg, Ug

    def _fallback(self, t: float, status: str, t_start: float, radii: np.ndarray | None,
                  iterations: int = 0) -> ControlOutput:
        self.failures += 1
        r = self._last_radii if radii is None else radii
        if self._plan is not None:
            X, U = self._shift(t, r)
        else:  # nothing planned yet: the path from its start at the desired speed
            g = self.path.geometry(np.zeros(1))
            X, U = self._feed_forward(t, np.array([g.x[0], g.y[0], g.heading[0], 0.0]), r)
        W = self._command(U)
        return ControlOutput(omega=W[0].copy(), success=False, status=f"fallback: {status}", iterations=iterations,
                             solve_time=time.perf_counter() - t_start, fallback=True, predicted=X[:, :3],
                             predicted_t=self.col.times(t), predicted_omega=W)


def compliance_offset(spec: PathFollowingSpec, u_applied: np.ndarray | None, radii: np.ndarray,
                      nominal_radii: np.ndarray) -> np.ndarray:
    """The wheel rates (rad/s) of the robot minus the commanded ones at the applied command ``u``.

    The velocity servos yield under the tyres' yaw couple ``F = M a x_G / (2 b)`` (the robot understeers): the
    outer (right, for a left turn) wheel lags by ``F R_R / k_v``, the inner runs ahead by ``F R_L / k_v``, so
    ``δ = k a (−R_R, R_L)`` with ``a`` the robot's lateral acceleration and ``k = c b / R_0²`` from
    ``yaw_compliance`` ``c`` (s/m, the yaw-rate deficit per m/s² with the nominal tyres ``R_0``). With the
    model's ``V0, r0`` of ``u``, the robot's are ``V = V0 + p a`` and ``r = r0 − q a`` (``p = k (R_L² − R_R²)/2``,
    ``q = k (R_R² + R_L²)/(2 b)``), and ``a = V r`` is the root of ``−p q a² + (p r0 − q V0 − 1) a + V0 r0 = 0``
    that tends to ``V0 r0 / (1 + q V0)`` as ``p → 0``. Zero with ``c = 0`` or before the first command."""
    if spec.yaw_compliance == 0.0 or u_applied is None:
        return np.zeros(2)
    b = spec.problem.half_track
    k = spec.yaw_compliance * b / (0.5 * float(nominal_radii @ nominal_radii))
    V0 = 0.5 * float(radii @ u_applied)
    r0 = (radii[0] * u_applied[0] - radii[1] * u_applied[1]) / (2.0 * b)
    p = 0.5 * k * (radii[1] ** 2 - radii[0] ** 2)
    q = 0.5 * k * float(radii @ radii) / b
    B = p * r0 - q * V0 - 1.0
    disc = max(B * B + 4.0 * p * q * V0 * r0, 0.0)
    a = 2.0 * V0 * r0 / (-B + np.sqrt(disc)) if -B + np.sqrt(disc) > 0.0 else 0.0
    return k * a * np.array([-radii[0], radii[1]])


def lateral_sides(spec: PathFollowingSpec, at_t0: bool = False) -> tuple[tuple[float, float], ...]:
    """Signs ``(s_lat, s_lon)`` of the rows ``s_lat a + s_lon β dV/dt − σ ≤ A`` that make
    ``|a| + β |dV/dt| ≤ A + σ`` at the nodes, or (``at_t0``) the extra rows at ``t0`` with ``dV/dt`` the change
    of speed from the applied command's (none when ``β = 0``)."""
    if spec.braking_trade == 0.0:
        return () if at_t0 else ((1.0, 0.0), (-1.0, 0.0))
    return ((1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0))


def wheel_bounds(spec: PathFollowingSpec, N: int, u_applied: np.ndarray | None, offset: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Bounds (rad/s) of the model's wheel rates ``[omega_R(N), omega_L(N)]``: the command is the model's rate
    minus ``offset`` (:func:`compliance_offset`, rad/s), so the box is ``±omega_max + offset``;
    at ``t0`` also within ``u_applied + offset ± omega_rate_max T_s`` (no such row without an applied command)."""
    om = spec.problem.omega_max
    lo = np.repeat(offset - om, N)
    hi = np.repeat(offset + om, N)
    if u_applied is not None:
        d = spec.problem.omega_rate_max * spec.sample_time
        lo[[0, N]] = np.maximum(lo[[0, N]], u_applied + offset - d)
        hi[[0, N]] = np.minimum(hi[[0, N]], u_applied + offset + d)
    return lo, hi


# ----------------------------------------------------------------------------------------------
class PathNLP:
    """The full NLP for IPOPT (built once on an SX graph).

    ``w = [x(N), y(N), psi(N), s(N), omega_R(N), omega_L(N), v(N), σ]`` (the model's wheel rates),
    parameters ``p = [x0, y0, psi0, s0, R_R, R_L, V_applied]``. Constraint rows as :class:`PathQP`'s, exact
    instead of linearised: collocation (4N), initial state (4), wheel-rate rates (2N), traction (4N + 4, or
    2N), longitudinal acceleration (N) and the speed at ``t0`` relative to ``V_applied`` (1).
    """

    def __init__(self, col: Collocation, spec: PathFollowingSpec, path: Path, max_iter: int,
                 cold_time_budget: float | None, time_budget: float | None) -> None:
        self.col, self.spec = col, spec
        N, h, pr = col.N, col.h, spec.problem
        w = ca.SX.sym("w", 7 * N + 1)
        p = ca.SX.sym("p", 7)
        X = ca.reshape(w[: 4 * N], N, 4).T  # 4 x N
        U = ca.reshape(w[4 * N: 7 * N], N, 3).T  # 3 x N
        sig = w[7 * N]
        radii = p[4:6]
        D = ca.DM(col.D)
        Wq = ca.DM(col.W).T
        f = col.model.casadi_derivative().map(N)
        rates = col.model.casadi_rates().map(N)
        Xfull = ca.vertcat(X[:3, :], ca.repmat(radii, 1, N))
        colloc = ca.vertcat((ca.mtimes(X[:3, :], D.T) / h - f(Xfull, U[:2, :])[:3, :]),
                            ca.mtimes(X[3, :], D.T) / h - U[2, :]).T  # N x 4
        g_path = path.geometry(X[3, :].T, ca)
        dx, dy = X[0, :].T - g_path.x, X[1, :].T - g_path.y
        c, s = ca.cos(g_path.heading), ca.sin(g_path.heading)
        ec, el = -s * dx + c * dy, c * dx + s * dy
        eh = X[2, :].T - g_path.heading
        J = ca.mtimes(Wq, spec.q_contour * ec**2 + spec.q_lag * el**2 + spec.q_heading * eh**2
                      + spec.q_progress * (U[2, :].T - spec.desired_speed) ** 2)
        dU = ca.mtimes(U, D.T) / h  # 3 x N, d/dt
        J += pr.rate_penalty * ca.sum2(Wq * ca.sum1(dU[:2, :] ** 2))
        J += spec.progress_rate_penalty * ca.sum2(Wq * dU[2, :] ** 2)
        J += spec.slack_penalty * sig + sig**2
        Vp = rates(Xfull, U[:2, :])  # 2 x N
        rate = pr.omega_rate_max * h
        g = [ca.vec(colloc), X[:, 0] - p[:4], ca.vec((dU[:2, :] * h).T)]
        lbg = [np.zeros(4 * N + 4), -rate * np.ones(2 * N)]
        ubg = [np.zeros(4 * N + 4), rate * np.ones(2 * N)]
        if pr.max_lateral_accel is not None:  # ±a ± β dV/dt − σ ≤ A
            a = (Vp[0, :] * Vp[1, :]).T
            ax = dU[0, :].T * 0.5 * radii[0] + dU[1, :].T * 0.5 * radii[1]
            for sl, so in lateral_sides(spec):
                g.append(sl * a + so * spec.braking_trade * ax - sig)
                lbg.append(-np.inf * np.ones(N))
                ubg.append(pr.max_lateral_accel * np.ones(N))
            self._lat0 = sum(int(x.numel()) for x in g), len(lateral_sides(spec, True))
            for sl, so in lateral_sides(spec, True):  # at t0: the speed change from the applied command's (p[6])
                g.append(sl * a[0] + so * spec.braking_trade * (Vp[0, 0] - p[6]) / spec.sample_time - sig)
                lbg.append([-np.inf])
                ubg.append([pr.max_lateral_accel])
        if pr.max_longitudinal_accel is not None:
            g.append(dU[0, :].T * 0.5 * radii[0] + dU[1, :].T * 0.5 * radii[1])
            g.append(Vp[0, 0])  # speed at t0, within a_max T_s of the applied command's (bounds per solve)
            lbg += [-pr.max_longitudinal_accel * np.ones(N), [-np.inf]]
            ubg += [pr.max_longitudinal_accel * np.ones(N), [np.inf]]
        self._lbg, self._ubg = np.concatenate(lbg), np.concatenate(ubg)
        if pr.max_lateral_accel is None:
            self._lat0 = (0, 0)
        self._lbx = np.concatenate([-np.inf * np.ones(6 * N), np.zeros(N), [0.0]])
        self._ubx = np.concatenate([np.inf * np.ones(6 * N), spec.max_progress_speed * np.ones(N), [SLACK_MAX]])
        opts = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.max_iter": max_iter,
                "ipopt.warm_start_init_point": "yes", "ipopt.mu_init": 1e-4, "ipopt.tol": 1e-8,
                "error_on_fail": False}
        budgets = [b for b in (cold_time_budget, time_budget) if b is not None]
        if budgets:
            opts["ipopt.max_wall_time"] = max(budgets)
        self._solver = ca.nlpsol("pf_nmpc", "ipopt", {"x": w, "p": p, "f": J, "g": ca.vertcat(*g)}, opts)
        self.size = (w.numel(), self._lbg.size)
        self.reset()

    def reset(self) -> None:
        """Forget the dual warm start."""
        self._lam: tuple[np.ndarray, np.ndarray] | None = None

    def solve(self, x0: np.ndarray, radii: np.ndarray, bounds: tuple[np.ndarray, np.ndarray],
              V_applied: float | None, Xg: np.ndarray, Ug: np.ndarray
              ) -> tuple[bool, str, int, np.ndarray | None, np.ndarray | None, float]:
        """``(ok, status, iterations, X (N,4), U (N,3), σ)`` from the guess ``(Xg, Ug)``; ``bounds`` are the
        model's wheel-rate bounds (:func:`wheel_bounds`), ``V_applied`` (m/s) the speed of the applied command."""
        N = self.col.N
        lbx, ubx = self._lbx.copy(), self._ubx.copy()
        lbx[4 * N:6 * N], ubx[4 * N:6 * N] = bounds
        wg = np.clip(np.concatenate([Xg.T.ravel(), Ug.T.ravel(), [0.0]]), lbx, ubx)
        lbg, ubg = self._lbg.copy(), self._ubg.copy()
        amax = self.spec.problem.max_longitudinal_accel
        if amax is not None and V_applied is not None:
            lbg[-1], ubg[-1] = V_applied - amax * self.spec.sample_time, V_applied + amax * self.spec.sample_time
        if V_applied is None:  # no applied command yet: the t0 rows of the braking trade-off are open
            i0, n0 = self._lat0
            ubg[i0:i0 + n0] = np.inf
        args = {"x0": wg, "p": np.concatenate([x0, radii, [V_applied or 0.0]]), "lbx": lbx, "ubx": ubx,
                "lbg": lbg, "ubg": ubg}
        ok, status, it, wv, self._lam = warm_started_solve(self._solver, args, self._lam)
        if not ok:
            return False, status, it, None, None, float("nan")
        return (True, status, it, wv[: 4 * N].reshape(4, N).T, wv[4 * N: 7 * N].reshape(3, N).T,
                float(wv[7 * N]))


# ----------------------------------------------------------------------------------------------
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
        opts = _default_qp_options(qpsol)
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

