"""Path-following NMPC (model-predictive contouring control) on the LGL pseudospectral grid.

The path is geometric, ``s -> (x_p, y_p, θ, κ)`` by arc length (:mod:`~ftc_mj.control.reference`), and
the progress ``s`` (m) is a state with its own rate ``v`` (m/s) as an extra input (model-predictive
path following, Faulwasser & Findeisen 2016; contouring control, Liniger et al. 2015). Nothing in
the problem depends on the time: the controller never asks the robot to catch up with a clock.

Grid and stacking: the NMPC's ``N`` LGL nodes over ``[t0, t0 + T]`` (:class:`Collocation`); states
``X = [x, y, psi, s]`` (m, m, rad, m), inputs ``U = [omega_R, omega_L, v]`` (rad/s, rad/s, m/s) at the
nodes and one slack ``σ ≥ 0`` (m/s²). QP variables ``u = [omega_R(N), omega_L(N), v(N), σ]``.

Dynamics (collocation at every node): the kinematics ``(2/T) D [x, y, psi] = f(X, U; R_R, R_L, b)``
and ``(2/T) D s = v``; ``X(t0) = [pose, s0]``.

Progress feedback (``max_lag``, m). With ``max_lag = 0`` ``s0`` is the arc length of the path point nearest
the measured pose (:func:`~ftc_mj.control.reference.project`), re-measured at every sample like the pose: the
lag error at ``t0`` is then always zero and nothing feeds back the progress the robot actually made — a robot
slower than its model is never behind anything. With ``max_lag > 0`` the progress is a state carried from plan
to plan, as in model-predictive contouring control with a virtual path parameter (Lam, Manzie & Good 2010;
the path parameter of model-predictive path following, Faulwasser & Findeisen 2016, is the controller's own
state): ``s0`` is the previous plan's predicted progress for ``t0``, clipped to within ``max_lag`` of the
nearest path point (a bound that keeps the lag, and so the linearisation of ``e_c``, ``e_l`` about the path
point, small; Liniger's MPCC re-projects at every sample, which the clipping does whenever the lag exceeds
it). The lag error at ``t0`` is then the progress the robot failed (or exceeded) to make, and the lag cost
``q_lag e_l²`` closes the loop on it: a model that overstates the robot's speed (a tyre smaller than its model
radius) leaves the robot behind its progress point, and the plan speeds the model up. The action is partial:
the plan may also slow its progress point, which the progress term prices weakly (with both tyres at half the
model radius the robot runs at 6.1 m/s instead of 5 m/s of the desired 10, ``max_lag`` 2 m, kinematic plant,
``tests/control/test_pathfollow.py``). A penalty on the measured progress rate would need a speed estimate the
filter does not make; the carried state was chosen for that reason. Off by default (docs/findings.md).

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

Degraded mode (:meth:`PathFollowingNMPC.set_radius_interval`, :mod:`ftc_mj.reconfiguration.degraded`): while
a radius interval is in force the traction bound also holds at every radius of it — the robot's
``V psidot`` is monotone in each radius, so two rows per node at the interval's corners suffice
(:class:`~ftc_mj.control.pathfollow_spec.RadiusInterval`), each with its own slack ``τ_j`` (an L1 exact penalty):
the speed reduction follows from those rows, not from a rule. The mode's NLP and QP are separate instances
(built on the first degraded sample).

Solvers: ``ipopt`` (the full NLP, the path symbolic through ``geometry(s, casadi)``) and
``rti-<qp>`` — one Gauss–Newton SQP step per sample about the shifted previous plan: the residuals
``e_c, e_l, psi − θ`` are linearised in ``(x, y, psi, s)`` through ``de_c/ds = −κ e_l``,
``de_l/ds = κ e_c − 1``, ``dθ/ds = κ``, the states are eliminated exactly
(:class:`~ftc_mj.control.elimination.StateElimination`) and the dense QP in ``u`` is solved by the
certified active-set path (:class:`~ftc_mj.control.certified_qp.CertifiedQP`), else the named
CasADi QP plugin. The first solve, and a re-seed after two consecutive failures, is an IPOPT solve.
A failed or over-budget solve, a solver error or a non-finite pose/radii falls back to the shifted
previous plan like the NMPC's (the shared :class:`~ftc_mj.control.mpc.MPCLifecycle`); any other exception
propagates and fails the run.

The spec and the robot's limits are in :mod:`~ftc_mj.control.pathfollow_spec`, the NLP in
:mod:`~ftc_mj.control.pathfollow_nlp`, the QP in :mod:`~ftc_mj.control.pathfollow_qp`.
"""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np
from pydantic import Field

from ..context import RunContext
from ..model.kinematics import inverse_rates
from .base import ControlOutput
from .lgl import interpolation_matrix
from .mpc import SOLVERS, MPCLifecycle, sanitize_pose, sanitize_radii
from .nmpc import NMPCSettings
from .pathfollow_nlp import PathNLP, nlp_structure
from .pathfollow_qp import PathQP
from .pathfollow_spec import (
    PathFollowingSettings,
    PathFollowingSpec,
    RadiusInterval,
    RobotLimits,
    compliance_offset,
    path_following_problem,
    servo_limited,
    wheel_bounds,
)
from .reference import Path, path_errors, project
from .spec import tracking_problem

TWO_PI = 2.0 * np.pi
MIN_EFFECTIVENESS = 0.05
"""Smallest servo effectiveness the actuator model takes (:meth:`PathFollowingNMPC.set_actuator_effectiveness`)."""

TELEMETRY = ("pf_progress", "pf_contouring_error", "pf_lag_error", "pf_speed_desired", "pf_speed_planned",
             "pf_progress_speed", "pf_lateral_accel", "pf_lateral_bound", "pf_slack", "pf_yaw_offset",
             "pf_degraded", "pf_corner_slack", "pf_R_R_lo", "pf_R_R_hi", "pf_R_L_lo", "pf_R_L_hi", "pf_skid")
"""Trace columns of the path-following NMPC (on controller samples): progress ``s0`` (m), contouring and
lag error (m) of the measured pose, desired and planned speed at ``t0`` (m/s), planned progress speed
(m/s), the robot's planned lateral acceleration ``V psidot`` at ``t0`` and its bound (m/s²), the slack ``σ``
(m/s²), the yaw-rate offset of the servo compliance (rad/s); the degraded mode: 1 while a radius interval
is in force (else 0), the largest slack ``τ_j`` of its rows (m/s²), the interval ``[lo, hi]`` of each radius
(m; the model radius when not degraded) and the wheels whose no-slip test fails (1 right + 2 left)."""


DEGRADED_MIN_ITER = 300
"""Smallest IPOPT iteration limit of the degraded mode's NLP. Its first solve starts from a nominal plan that
breaks the interval rows by up to the full corner excess (≈ 20 m/s² against a 3 m/s² bound when a suspect
tyre's interval reaches down to 0.05 m) and needed 144 iterations on the kinematic scenario-2 loop of
``benchmarks/bench_mpc.py --degraded`` (13–18 once warm). Within the NMPC's default 30 it fails, its
failure leaves no multipliers to warm-start from, and every later solve fails too: IPOPT would never honour
the interval. The wall-time budgets still bound each solve."""


class PathFollowingNMPCSettings(NMPCSettings):
    """Settings of the path-following NMPC (``controller.kind = "pf-nmpc"``): the NMPC's grid, solver and budgets
    (its tracking weights and ``rate_penalty`` are not read) and its own cost terms and bounds in
    ``path_following``."""

    kind: Literal["pf-nmpc"] = "pf-nmpc"  # type: ignore[assignment]
    """Path following on the geometric path (a registered controller, :data:`ftc_mj.registry.controllers`)."""
    path_following: PathFollowingSettings = Field(default_factory=PathFollowingSettings)
    """The path-following problem's own settings."""


def path_following_spec(settings: PathFollowingNMPCSettings, context: RunContext, desired_speed: float,
                        limits: RobotLimits | None = None) -> PathFollowingSpec:
    """The path-following problem (:func:`~ftc_mj.control.pathfollow_spec.path_following_problem`) of the
    ``pf-nmpc`` settings at ``desired_speed`` (m/s) on the grid of their tracking problem and the run context; the
    actuation-rate weight is ``fix_heading_rate_penalty`` when the context's sensors give the controller a heading
    from pose fixes without a gyro (:func:`heading_from_fixes`)."""
    pf = settings.path_following
    if pf.fix_heading_rate_penalty is not None and heading_from_fixes(context.sensors):
        pf = pf.model_copy(update={"rate_penalty": pf.fix_heading_rate_penalty})
    return path_following_problem(tracking_problem(settings, context), pf, desired_speed, limits)


def heading_from_fixes(sensors: object) -> bool:
    """Whether the controller's heading is the filter's estimate from pose fixes with no yaw-rate gyro between them
    (``sensors.pose_source = "sensor"`` and no ``yaw_rate_sigma``): what the robot's own sensor set says, not the
    plant."""
    return (getattr(sensors, "pose_source", "truth") == "sensor"
            and getattr(sensors, "position_sigma", None) is not None
            and getattr(sensors, "yaw_rate_sigma", None) is None)


class PathFollowingNMPC(MPCLifecycle):
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
        self.spec = spec
        self._base_spec = spec
        """The problem before the servos' bounds (:func:`servo_limited` makes :attr:`spec` from it)."""
        self.path = path
        self.solver_name = solver
        self.max_iter = int(max_iter)
        super().__init__(spec.problem, nominal_radii, time_budget, cold_time_budget)
        self._qp_args = (qp_options, cold_time_budget, time_budget)
        self._build_solvers()  # the degraded mode's solvers are built on first use

    def set_reference(self, path: Path, spec: PathFollowingSpec | None = None) -> None:
        """Follow ``path`` with the problem numbers of ``spec`` (default: the current ones) from the next solve on:
        a new draw's path, desired speed and robot limits. The path's numbers and the desired speed are
        parameters of the built NLP and QP (:mod:`~ftc_mj.control.pathfollow_path`), so a built controller, reset,
        serves them exactly as one built for them (the simulation's cache relies on it: ``retargetable``); a
        problem of another structure (another path kind, other tracking weights) builds its solvers anew — the
        actuation-rate weight (larger on a draw whose heading comes from pose fixes, :func:`path_following_spec`) is
        a parameter too —; the grid cannot change."""
        spec = self._base_spec if spec is None else spec
        mine = self.spec.problem
        if dataclasses.replace(spec.problem, max_lateral_accel=mine.max_lateral_accel,
                               max_longitudinal_accel=mine.max_longitudinal_accel,
                               rate_penalty=mine.rate_penalty) != mine:
            raise ValueError("set_reference: the path-following NMPC's grid and robot cannot change")
        self._base_spec, self.path = spec, path
        self._set_problem(servo_limited(spec, self._effectiveness))

    def _set_problem(self, spec: PathFollowingSpec) -> None:
        """Solve ``spec`` on the current path from the next sample on (its bounds are bounds of the built NLP's
        rows and read by the QP at every build; another structure builds the solvers anew)."""
        path = self.path
        self.spec = spec
        if nlp_structure(spec, path) != self._nlp.structure:
            self._build_solvers()
            return
        for solver in (self._nlp, self.qp, *(self._robust or ())):
            if solver is not None:
                solver.set_problem(spec, path)

    def _build_solvers(self) -> None:
        """The NLP and QP of the current spec and path (the degraded mode's on its first use)."""
        qp_options, cold, warm = self._qp_args
        rti = self.solver_name != "ipopt"
        self.qp = PathQP(self.col, self.spec, self.path, self.solver_name.split("-", 1)[1], qp_options) if rti else None
        self._nlp = PathNLP(self.col, self.spec, self.path, self.max_iter, cold, warm)
        self._robust: tuple[PathNLP, PathQP | None] | None = None

    def set_radius_interval(self, interval: RadiusInterval | None) -> None:
        """The radius interval of the degraded mode for the next solves (``None``: the mode is off). While it is
        in force the lateral-acceleration bound holds at every radius of the interval (:class:`PathQP`)."""
        self._interval = interval

    @property
    def degraded_solvers(self) -> tuple[PathNLP, PathQP | None]:
        """The NLP and QP with the interval rows (built on the first degraded sample, then kept)."""
        if self._robust is None:
            qp_options, cold, warm = self._qp_args
            qp = (PathQP(self.col, self.spec, self.path, self.solver_name.split("-", 1)[1], qp_options, robust=True)
                  if self.qp is not None else None)
            max_iter = max(self.max_iter, DEGRADED_MIN_ITER)
            self._robust = (PathNLP(self.col, self.spec, self.path, max_iter, cold, warm, robust=True), qp)
        return self._robust

    def set_actuator_effectiveness(self, effectiveness: np.ndarray) -> None:
        """The servos' remaining effectiveness [e_R, e_L] (fractions of gain and torque limit) for the next
        solves (the accommodation of a diagnosed servo loss): a servo at ``e`` yields ``1/e`` times as much
        under the same load, so its wheel's compliance offset is divided by ``e`` (floored at
        :data:`MIN_EFFECTIVENESS`; a weaker servo is a safe stop's, not this controller's), and the lateral and
        longitudinal bounds follow the weakest servo's torque (:func:`servo_limited`)."""
        self._effectiveness = np.maximum(np.asarray(effectiveness, dtype=float), MIN_EFFECTIVENESS)
        self._set_problem(servo_limited(self._base_spec, self._effectiveness))

    def _clear(self) -> None:
        super()._clear()  # plans are (t0, X (N,4), U (N,3))
        self._offset = np.zeros(2)
        self._interval: RadiusInterval | None = None
        self._effectiveness = np.ones(2)
        if hasattr(self, "_nlp") and self.spec != self._base_spec:  # a reset forgets the servos' bounds too
            self._set_problem(self._base_spec)

    def _reset_solvers(self) -> None:
        for solver in (self._nlp, self.qp, *(self._robust or ())):
            if solver is not None:
                solver.reset()

    def initial_state(self, pose: np.ndarray, s_pred: float | None) -> np.ndarray:
        """``[x, y, psi, s0]``: the measured pose with its progress ``s0`` and the heading moved by a multiple
        of 2π to the branch nearest the path tangent θ(s0).

        ``s_pred`` (m) is the progress the previous plan predicted for now (``None`` before the first plan).
        The progress is carried from plan to plan (progress feedback, module docstring): ``s0 = s_pred``
        clipped to ``s_proj ± max_lag``, ``s_proj`` the nearest path point (searched around ``s_pred``);
        ``max_lag = 0`` or no previous plan: ``s0 = s_proj``."""
        sp = self.spec
        window = max(0.5 * sp.desired_speed * sp.problem.horizon, 10.0)
        guess = 0.0 if s_pred is None else s_pred
        s0 = project(self.path, float(pose[0]), float(pose[1]), guess, window)
        if s_pred is not None and sp.max_lag > 0.0:
            s0 = float(np.clip(s_pred, s0 - sp.max_lag, s0 + sp.max_lag))
        th = float(self.path.geometry(np.array([s0])).heading[0])
        psi = float(pose[2]) + TWO_PI * np.round((th - float(pose[2])) / TWO_PI)
        return np.array([pose[0], pose[1], psi, s0])

    def _solve(self, t: float, pose: np.ndarray, radii: np.ndarray, t_start: float) -> ControlOutput:
        """One sample (the lifecycle's ``solve`` wraps it): the model's wheel-rate bounds at the command in
        force, the guess, one solve (:meth:`_iterate`), and the plan's commands or the fallback."""
        u_applied = self._u_applied
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
        s_pred = float(shifted[0][0, 3]) if shifted is not None else None
        x0 = self.initial_state(p, s_pred)
        self._offset = compliance_offset(self.spec, ua, r, self.nominal_radii) / self._effectiveness
        bounds = wheel_bounds(self.spec, self.col.N, ua, self._offset)
        V_app = None if ua is None else 0.5 * float(r @ (ua + self._offset))
        Xg, Ug = self._guess(t, x0, r, shifted)
        if self.max_iter == 0:
            return self._fallback(t, "max_iter=0", t_start, r)
        iv = self._interval
        nlp, qp = (self._nlp, self.qp) if iv is None else self.degraded_solvers
        ok, status, it, plan, budget = self._iterate(
            lambda: nlp.solve(x0, r, bounds, V_app, Xg, Ug, iv),
            None if qp is None else (lambda: qp.solve(Xg, Ug, r, x0, bounds, V_app, iv)))
        over = self._over_budget(t_start, budget, status) if ok else None
        if over is not None:
            ok, status = False, over
        if not ok:
            return self._fallback(t, status, t_start, r, it)
        X, U, sig = plan
        self._keep(t, X, U, r)
        tel = self._telemetry(x0, s_pred, X, U, r, sig)
        tel["pf_corner_slack"] = 0.0 if iv is None else (qp if "rti" in status and qp is not None else nlp).corner_slack
        return self._planned(t, status, it, t_start, X[:, :3], self._command(U), tel)

    def _command(self, U: np.ndarray) -> np.ndarray:
        """Wheel-rate commands (N, 2) (rad/s) of the model's planned rates: minus the input offset, clipped."""
        om = self.spec.problem.omega_max
        return np.clip(np.nan_to_num(U[:, :2] - self._offset[None, :]), -om, om)

    def _telemetry(self, x0: np.ndarray, s_pred: float | None, X: np.ndarray, U: np.ndarray, radii: np.ndarray,
                   slack: float) -> dict[str, float]:
        sp, b = self.spec, self.spec.problem.half_track
        bias = (radii[0] * self._offset[0] - radii[1] * self._offset[1]) / (2.0 * b)
        ec, _ = path_errors(self.path, x0[:1], x0[1:2], x0[3:4])
        _, el = path_errors(self.path, x0[:1], x0[1:2], np.array([0.0 if s_pred is None else s_pred]))
        V = 0.5 * (radii[0] * U[0, 0] + radii[1] * U[0, 1])
        a = V * (radii[0] * U[0, 0] - radii[1] * U[0, 1]) / (2.0 * b)
        bound = sp.problem.max_lateral_accel
        return {
            "pf_progress": float(x0[3]), "pf_contouring_error": float(ec[0]),
            "pf_lag_error": float(el[0]) if s_pred is not None else float("nan"),
            "pf_speed_desired": sp.desired_speed, "pf_speed_planned": float(V),
            "pf_progress_speed": float(U[0, 2]), "pf_lateral_accel": float(a),
            "pf_lateral_bound": float("nan") if bound is None else float(bound), "pf_slack": float(slack),
            "pf_yaw_offset": float(bias), **self._interval_telemetry(radii),
        }

    def _interval_telemetry(self, radii: np.ndarray) -> dict[str, float]:
        """The degraded mode's columns (module constant :data:`TELEMETRY`) but the slack."""
        iv = self._interval
        lo, hi = (radii, radii) if iv is None else (iv.lo, iv.hi)
        skid = (0, 0) if iv is None else iv.skid
        return {"pf_degraded": float(iv is not None), "pf_R_R_lo": float(lo[0]), "pf_R_R_hi": float(hi[0]),
                "pf_R_L_lo": float(lo[1]), "pf_R_L_hi": float(hi[1]), "pf_skid": float(skid[0]) + 2.0 * skid[1]}

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

    def _fallback_plan(self, t: float, radii: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The previous plan shifted to ``t`` (s), or before the first plan the path from its start at the
        desired speed: predicted poses (N, 3) and commands (N, 2) (rad/s)."""
        if self._plan is not None:
            X, U = self._shift(t, radii)
        else:  # nothing planned yet: the path from its start at the desired speed
            g = self.path.geometry(np.zeros(1))
            X, U = self._feed_forward(t, np.array([g.x[0], g.y[0], g.heading[0], 0.0]), radii)
        return X[:, :3], self._command(U)
