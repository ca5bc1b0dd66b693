"""Multi-stage (scenario-tree) robust NMPC over wheel-radius scenarios: passive fault tolerance.

The multi-stage NMPC of Lucia, Finkler and Engell (J. Process Control 23, 2013) on the LGL problem
of :mod:`~ftc_mj.control.transcription`:

* ``S`` radius scenarios ``r_i = f_i ⊙ r``: fractions ``f_i`` (e.g. nominal, each wheel at 50 %,
  both) of the model radii ``r`` handed to :meth:`~RobustNMPC.solve` (the nominal radii when no
  reconfiguration feeds the controller, which makes the scenario set fixed);
* one state trajectory ``X_i`` (3, N) and one input trajectory ``U_i`` (2, N) per scenario, each
  subject to every constraint of the nominal problem (collocation with ``r_i``, initial state, input
  and input-rate bounds, the optional acceleration bounds);
* non-anticipativity: the inputs at the first ``k`` nodes (the robust horizon) are *one* set of
  decision variables shared by all scenarios. The default ``k`` covers every node inside the first
  control period, i.e. every input the plant may receive before the next measurement; beyond it each
  scenario has its own inputs (recourse: by then the controller has measured more);
* the input-rate bound relative to the command in force, ``|U(t0) − u_applied| ≤ omega_rate_max T_s``
  (:func:`~ftc_mj.control.spec.first_input_bounds`), on the shared first input, and the optional
  first-step penalty (:func:`~ftc_mj.control.spec.first_step_penalty`) in every scenario's cost
  (the same term in each, since the first input is shared);
* objective ``Σ_i w_i J_i`` (``expected``; weights normalised to sum 1) or ``max_i J_i`` over the
  scenarios of positive weight (``worst``, as an epigraph ``J_i ≤ t``, minimise ``t``), with ``J_i``
  the nominal tracking cost of scenario ``i``.

Solvers: ``ipopt`` solves the whole NLP (``S (5N − 2k) + 2k`` variables), warm-started from the
shifted previous scenario plans and multipliers. ``rti-daqp`` (expected cost only) takes one
Gauss–Newton step per sample: each scenario's collocation is linearised about its shifted plan and
its states are eliminated exactly (:meth:`CondensedQP.build
<ftc_mj.control.condensed_qp.CondensedQP.build>`), leaving a dense QP in
``z = [u_shared (2k); v_1 (2(N−k)); …; v_S (2(N−k))]`` whose Hessian is ``Σ w_i P_iᵀ H_i P_i``
(``P_i`` selects scenario ``i``'s inputs from ``z``), solved by the certified active-set path
(:class:`~ftc_mj.control.certified_qp.CertifiedQP`), else by DAQP. The first solve, and a re-seed
after two failures, is an IPOPT solve, as in :class:`~ftc_mj.control.nmpc.NMPC` whose sample logic
(fallbacks, budgets, re-seeds) this class reuses.

Weights can be changed between samples (:meth:`RobustNMPC.set_scenario_weights`) without
rebuilding anything; the simulation loop uses this to re-weight the scenarios with the fault
detection and identification (the *hybrid* of passive and active FTC). A weight only scales a
scenario's cost (zero is allowed): the constraints of every scenario hold whatever its weight —
except that a scenario whose weight is below ``prune_below`` is *pruned*: its cost and its
constraints leave the problem (its rows are relaxed, parametrically, nothing is rebuilt). Why one
may want that: an implausible scenario's cost is orders of magnitude larger than the plausible
ones' (even a weight of 0.001 pulls the robot off the path, docs/control.md), and its rate rows, kept by
its recourse inputs
near their previous plan, still bound the shared inputs in the RTI iteration. On the MuJoCo robot
the pruned hybrid diverged, though (docs/findings.md), so it is off by default.

So that the QP stays strictly convex (and well conditioned) when a weight is small or zero, it adds
the proximal term ``(ρ_i/2) ‖v_i − v_i,g‖²`` on each scenario's own inputs about their guess,
``ρ_i`` = :data:`~ftc_mj.control.multistage_qp.PROXIMAL` times the mean diagonal of that scenario's Hessian
in them times ``max(0, 1 − S w_i)`` (none from the uniform weight 1/S up, where the scenario's own cost conditions
the block); it vanishes at a fixed point of the iteration, so the RTI iterates converge to the NLP's
solution for the exact weights.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from ..fields import NonNegFloat, StrictModel, ranged, ranged_int
from ..lazy import lazy_module
from .base import ControlOutput
from .multistage_qp import MultiStageQP
from .nmpc import NMPC, NMPCSettings
from .solver_cache import ipopt_solver
from .solvers import warm_started_solve
from .spec import ProblemSpec, first_step_penalty
from .transcription import Collocation

ca = lazy_module("casadi")

OBJECTIVES = ("expected", "worst")
ROBUST_SOLVERS = ("ipopt", "rti-daqp")


ScenarioFraction = ranged(0.0, 2.0, lo_open=True)
"""A scenario radius as a fraction of the model radius, in (0, 2]."""


class RobustSettings(StrictModel):
    """The scenarios and weighting of the multi-stage robust NMPC (the ``controller.robust`` table): one
    state trajectory per radius scenario, shared inputs over the robust horizon, all constraints in
    every scenario."""

    scenarios: list[tuple[ScenarioFraction, ScenarioFraction]] = Field(
        default_factory=lambda: [(1.0, 1.0), (0.5, 1.0), (1.0, 0.5), (0.5, 0.5)], min_length=1, max_length=16)
    """Scenario radii ``[R_R, R_L]`` as fractions of the model radii the reconfiguration policy hands over
    (the nominal radii under policy ``none``). Default: no fault, right at 50 %, left at 50 %, both at
    50 % (the 4-model IMM bank, in its order)."""
    weights: list[NonNegFloat] | None = None
    """Scenario weights (one per scenario, not all zero; normalised); unset = uniform."""
    robust_horizon_nodes: ranged_int(1, 200) | None = None
    """Input nodes shared by all scenarios (non-anticipativity); unset = every node inside the first
    control period (5 of the default 50). More shared nodes make the NLP harder
    (docs/config-defaults.md)."""
    objective: Literal["expected", "worst"] = "expected"
    """``expected``: the weighted mean of the scenario costs; ``worst``: their maximum over the
    scenarios of positive weight (an epigraph; needs ``controller.solver = "ipopt"``)."""
    weighting: Literal["fixed", "posterior"] = "fixed"
    """``fixed``: the configured weights (passive FTC). ``posterior``: at every solve the weights are
    the filter's posterior probabilities of the scenario radii (:mod:`~ftc_mj.reconfiguration.scenario_weights`;
    needs an estimator): a hybrid of passive and active FTC."""
    posterior_tolerance: ranged(0.0, 10.0, lo_open=True, unit="m") = 0.25
    """``posterior`` weighting: standard deviation (m) added to the filter's radius σ in every direction
    — how far the true radii may lie from a scenario and still count as that scenario."""
    posterior_floor: ranged(0.0, 1.0, hi_open=True) = 0.01
    """``posterior`` weighting: share of the weight spread uniformly over all scenarios whatever the
    filter says (no scenario is dismissed outright)."""
    prune_below: ranged(0.0, 1.0, hi_open=True) = 0.0
    """A scenario whose (normalised) weight is below this leaves the problem, cost and constraints (the
    one of largest weight never does); 0 = never. The default (floor 0.01, no pruning) was chosen by the
    rule of the development study ``robust_hybrid_dev`` (docs/findings.md)."""

    @model_validator(mode="after")
    def _weights_match(self) -> RobustSettings:
        """One weight per scenario, not all zero."""
        if self.weights is not None:
            if len(self.weights) != len(self.scenarios):
                raise ValueError(f"weights: {len(self.weights)} weights for {len(self.scenarios)} scenarios")
            if sum(self.weights) <= 0:
                raise ValueError("weights: must not all be zero")
        return self


class RobustNMPCSettings(NMPCSettings):
    """Settings of the multi-stage robust NMPC (``controller.kind = "robust-nmpc"``): the NMPC's and the
    scenarios in ``robust``."""

    kind: Literal["robust-nmpc"] = "robust-nmpc"  # type: ignore[assignment]
    """The robust NMPC over radius scenarios (a registered controller, :data:`ftc_mj.registry.controllers`)."""
    robust: RobustSettings = Field(default_factory=RobustSettings)
    """Settings of the robust multi-stage NMPC (its scenarios and their weighting)."""

    @model_validator(mode="after")
    def _solvable(self) -> RobustNMPCSettings:
        """Its solver (IPOPT or the RTI on daqp), the ``worst`` objective (IPOPT only), the robust horizon (at
        most ``nodes``)."""
        if self.solver not in ROBUST_SOLVERS:
            raise ValueError(f"solver: robust-nmpc is solved by 'ipopt' or 'rti-daqp', not {self.solver!r}")
        if self.robust.objective == "worst" and self.solver != "ipopt":
            raise ValueError("robust.objective: 'worst' is not a QP; it needs controller.solver = 'ipopt'")
        if self.robust.robust_horizon_nodes is not None and self.robust.robust_horizon_nodes > self.nodes:
            raise ValueError(f"robust.robust_horizon_nodes: at most controller.nodes = {self.nodes}")
        return self


def scenario_radii(fractions: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Radii (S, 2) [R_R, R_L] (m) of the scenarios: ``fractions`` (S, 2) of the model ``radii`` (2,) (m)."""
    return np.asarray(fractions, dtype=float) * np.asarray(radii, dtype=float)[None, :]


def control_period_nodes(col: Collocation, control_period: float) -> int:
    """Number of LGL nodes at times ``t0 ≤ t_j < t0 + control_period`` (s) (at least node 0): the inputs a
    zero-order-held plant may receive before the next sample."""
    return max(1, int(np.sum((col.tau + 1.0) * col.h < control_period * (1.0 - 1e-9))))


def normalised_weights(weights: np.ndarray, n: int) -> np.ndarray:
    """``weights`` (n,) scaled to sum 1. Raises ``ValueError`` unless they are finite, non-negative
    and not all zero."""
    w = np.asarray(weights, dtype=float).ravel()
    if w.shape != (n,) or not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
        raise ValueError(f"scenario weights must be {n} finite non-negative numbers, not all zero; got {w}")
    return w / w.sum()


def moved_to(X: np.ndarray, x0: np.ndarray) -> np.ndarray:
    """States X (N, 3) [x, y, psi] (m, m, rad) moved by the planar rigid motion that takes ``X[0]`` to
    ``x0`` (3,): rotated by ``Δψ = ψ0 − ψ(0)`` about ``X[0]``, then translated to ``x0``.

    The kinematics do not depend on the position, and a rotation turns the velocity with the heading,
    so if X solves the dynamics for some inputs from ``X[0]``, the result solves them for the same
    inputs from ``x0``.
    """
    d = x0[2] - X[0, 2]
    c, s = np.cos(d), np.sin(d)
    rel = X[:, :2] - X[0, :2]
    out = np.empty_like(X)
    out[:, 0] = x0[0] + c * rel[:, 0] - s * rel[:, 1]
    out[:, 1] = x0[1] + s * rel[:, 0] + c * rel[:, 1]
    out[:, 2] = X[:, 2] + d
    out[0] = x0
    return out


class RobustNMPC(NMPC):
    """Multi-stage robust NMPC (module docstring). ``solve(t, pose, radii, u_applied)`` per sample.

    Parameters
    ----------
    spec, reference
        The tracking problem and the reference, as for :class:`~ftc_mj.control.nmpc.NMPC`.
    fractions : array (S, 2)
        Scenario radii [R_R, R_L] as fractions of the radii handed to ``solve``.
    weights : array (S,), optional
        Scenario weights (normalised; default uniform) used until :meth:`set_scenario_weights` says
        otherwise.
    robust_nodes : int, optional
        Shared (non-anticipative) input nodes ``k``; default: every node inside the first control period.
    objective : ``"expected"`` or ``"worst"``
        ``Σ w_i J_i`` or ``max_i J_i`` over the scenarios not pruned (``worst`` needs ``ipopt``).
    prune_below : float
        A scenario whose normalised weight is below this leaves the problem (cost and constraints); the
        scenario of largest weight never does.
    solver : ``"ipopt"`` or ``"rti-daqp"``
    max_iter, time_budget, cold_time_budget, nominal_radii
        As for :class:`~ftc_mj.control.nmpc.NMPC`.
    """

    def __init__(self, spec: ProblemSpec, reference, fractions: np.ndarray, weights: np.ndarray | None = None,
                 robust_nodes: int | None = None, objective: str = "expected", prune_below: float = 0.0,
                 solver: str = "rti-daqp", max_iter: int = 30, time_budget: float | None = 0.1,
                 nominal_radii: tuple[float, float] = (2.0, 2.0), cold_time_budget: float | None = 2.0) -> None:
        if solver not in ROBUST_SOLVERS:
            raise ValueError(f"unknown robust NMPC solver {solver!r}; expected one of {ROBUST_SOLVERS}")
        if objective not in OBJECTIVES:
            raise ValueError(f"unknown objective {objective!r}; expected one of {OBJECTIVES}")
        if objective == "worst" and solver != "ipopt":
            raise ValueError("the worst-case objective is not a QP: it needs solver 'ipopt'")
        f = np.asarray(fractions, dtype=float)
        if f.ndim != 2 or f.shape[1] != 2 or f.shape[0] < 1 or not np.all(f > 0):
            raise ValueError(f"scenario fractions must be (S, 2) positive numbers; got {f.tolist()}")
        self.fractions = f
        self.S = f.shape[0]
        self.objective = objective
        self.prune_below = float(prune_below)
        self.base_weights = normalised_weights(np.ones(self.S) if weights is None else weights, self.S)
        self.weights = self.base_weights.copy()
        self._robust_nodes = robust_nodes
        self._stages: tuple[float, np.ndarray, np.ndarray] | None = None  # (t0, X (S,N,3), U (S,N,2))
        self.telemetry_columns = tuple(f"scenario_weight_{i + 1}" for i in range(self.S))
        super().__init__(spec, reference, solver=solver, max_iter=max_iter, time_budget=time_budget,
                         nominal_radii=nominal_radii, cold_time_budget=cold_time_budget)
        self._stage_qp = MultiStageQP(self._qp, self.S, self.k) if self._qp is not None else None

    def reset(self) -> None:
        """Forget plans, warm starts, counters and weights set since: a reset controller is a new one."""
        super().reset()
        self._stages = None
        self.weights = self.base_weights.copy()
        if getattr(self, "_stage_qp", None) is not None:
            self._stage_qp.reset()

    def set_scenario_weights(self, weights: np.ndarray | None) -> None:
        """Weights (S,) of the scenarios from the next solve on (normalised to sum 1; ``None`` = the
        configured ones). A weight scales its scenario's cost; the constraints of every scenario not
        pruned (weight ≥ ``prune_below``) hold. Raises ``ValueError`` for weights that are not finite,
        non-negative and not all zero."""
        self.weights = self.base_weights.copy() if weights is None else normalised_weights(weights, self.S)

    @property
    def stage_weights(self) -> np.ndarray:
        """Weights (S,) in the problem: NaN for a pruned scenario, the others renormalised to sum 1."""
        keep = self.weights >= self.prune_below
        keep[int(np.argmax(self.weights))] = True
        w = np.where(keep, self.weights, np.nan)
        return w / np.nansum(w)

    def solve(self, t: float, pose: np.ndarray, radii: np.ndarray,
              u_applied: np.ndarray | None = None) -> ControlOutput:
        """As :meth:`NMPC.solve <ftc_mj.control.mpc.MPCLifecycle.solve>`; the telemetry holds the
        scenario weights used (``scenario_weight_1`` …; 0 for a pruned scenario)."""
        out = super().solve(t, pose, radii, u_applied)
        out.telemetry.update(zip(self.telemetry_columns, (float(w) for w in np.nan_to_num(self.stage_weights)),
                                 strict=True))
        return out

    # ------------------------------------------------------------------------------------------
    def _build_nlp(self) -> None:
        col, sp, N, S = self.col, self.spec, self.col.N, self.S
        k = self.k = (control_period_nodes(col, sp.sample_time) if self._robust_nodes is None
                      else int(self._robust_nodes))
        if not 1 <= k <= N:
            raise ValueError(f"robust horizon must be 1..{N} nodes; got {k}")
        nv = 5 * N - 2 * k  # per scenario: 3N states and 2(N - k) own inputs
        worst = self.objective == "worst"
        w = ca.SX.sym("w", 2 * k + S * nv + int(worst))
        p = ca.SX.sym("p", 5 + 5 * N + S + 3)  # pose, radii, reference, weights, u_prev, first-step weight
        x0, radii, ref = p[:3], p[3:5], ca.reshape(p[5:5 + 5 * N], N, 5).T
        wt, u_prev, c_step = p[5 + 5 * N:5 + 5 * N + S], p[5 + 5 * N + S:7 + 5 * N + S], p[7 + 5 * N + S]
        Us = ca.reshape(w[:2 * k], k, 2).T
        costs, gs, lbg, ubg, self._scen_rows = [], [], [], [], []
        for i in range(S):
            off = 2 * k + i * nv
            X = ca.reshape(w[off:off + 3 * N], N, 3).T
            V = ca.reshape(w[off + 3 * N:off + nv], N - k, 2).T
            Ji, gi, lo, hi = col.nlp_terms(X, ca.horzcat(Us, V), x0, ca.DM(self.fractions[i]) * radii, ref,
                                           u_prev, c_step)
            costs.append(Ji)
            n0 = sum(len(v) for v in lbg)
            self._scen_rows.append(slice(n0, n0 + len(lo)))
            gs.append(gi)
            lbg.append(lo)
            ubg.append(hi)
        J = ca.vertcat(*costs)
        if worst:
            gs.append(J - w[-1])  # J_i <= t for the scenarios of positive weight (bounds set per solve)
            lbg.append(np.full(S, -np.inf))
            ubg.append(np.zeros(S))
            f = w[-1]
        else:
            f = ca.dot(wt, J)
        g = ca.vertcat(*gs)
        self._lbg, self._ubg = np.concatenate(lbg), np.concatenate(ubg)
        om = sp.omega_max
        stage = np.concatenate([np.full(3 * N, np.inf), np.full(2 * (N - k), om)])
        self._ubx = np.concatenate([np.full(2 * k, om), np.tile(stage, S), np.full(int(worst), np.inf)])
        self._lbx = -self._ubx
        self._nlp = ipopt_solver("robust_nmpc", {"x": w, "p": p, "f": f, "g": g}, self._ipopt_options())
        self._costs = ca.Function("scenario_costs", [w, p], [J])
        self.nlp_size = (w.numel(), g.numel())

    def _pack(self, X: np.ndarray, U: np.ndarray) -> np.ndarray:
        """NLP variables from scenario plans X (S, N, 3), U (S, N, 2); the shared inputs from the
        scenario of largest weight."""
        k, rep = self.k, int(np.argmax(self.weights))
        parts = [U[rep, :k].T.ravel()]
        for i in range(self.S):
            parts += [X[i].T.ravel(), U[i, k:].T.ravel()]
        if self.objective == "worst":
            parts.append(np.zeros(1))
        return np.concatenate(parts)

    def _unpack(self, wv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Scenario plans X (S, N, 3), U (S, N, 2) from the NLP variables."""
        N, k = self.col.N, self.k
        Us = wv[:2 * k].reshape(2, k).T
        nv = 5 * N - 2 * k
        X, U = np.empty((self.S, N, 3)), np.empty((self.S, N, 2))
        for i in range(self.S):
            off = 2 * k + i * nv
            X[i] = wv[off:off + 3 * N].reshape(3, N).T
            U[i, :k] = Us
            U[i, k:] = wv[off + 3 * N:off + nv].reshape(2, N - k).T
        return X, U

    def _ipopt(self, x0, radii, ref, Xg, Ug):
        """The full multi-stage NLP from the scenario guesses: ``(ok, status, iterations, X, U)``."""
        w = self.stage_weights
        keep = ~np.isnan(w)
        u_prev = np.zeros(2) if self._u_prev is None else self._u_prev
        pv = np.concatenate([x0, radii, ref.ravel(), np.nan_to_num(w), u_prev,
                             [first_step_penalty(self.spec, self._u_prev)]])
        wg = self._pack(Xg, Ug)
        lbg, ubg = self._lbg.copy(), self._ubg.copy()
        for i in np.nonzero(~keep)[0]:  # a pruned scenario's constraints are relaxed
            lbg[self._scen_rows[i]], ubg[self._scen_rows[i]] = -np.inf, np.inf
        lbx, ubx = self._lbx.copy(), self._ubx.copy()
        first = [0, self.k]  # the shared omega_R, omega_L at t0
        lbx[first], ubx[first] = self._box
        if self.objective == "worst":
            ubg[-self.S:] = np.where(keep, 0.0, np.inf)
            wg[-1] = float(np.max(np.asarray(self._costs(wg, pv)).ravel()[keep]))
        args = {"x0": wg, "p": pv, "lbx": lbx, "ubx": ubx, "lbg": lbg, "ubg": ubg}
        ok, status, it, wv, self._lam = warm_started_solve(self._nlp, args, self._lam)
        if not ok:
            return False, status, it, None, None
        X, U = self._unpack(wv)
        return True, status, it, X, U

    def scenario_costs(self, x0: np.ndarray, radii: np.ndarray, ref: np.ndarray, X: np.ndarray,
                       U: np.ndarray) -> np.ndarray:
        """Tracking cost ``J_i`` (S,) of scenario plans X (S, N, 3), U (S, N, 2) from pose ``x0`` with
        model radii ``radii`` (m) and the reference (5, N) at the nodes."""
        pv = np.concatenate([x0, radii, ref.ravel(), np.ones(self.S), np.zeros(3)])
        return np.asarray(self._costs(self._pack(X, U), pv)).ravel()

    def _rti_step(self, Xg, Ug, radii, x0, ref):
        """One real-time iteration of the multi-stage QP about the scenario guesses."""
        assert self._stage_qp is not None
        return self._stage_qp.solve(Xg, Ug, scenario_radii(self.fractions, radii), x0, ref, self.stage_weights,
                                    self._u_prev)

    def _guess(self, t: float, x0: np.ndarray, ref: np.ndarray, radii: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Scenario guesses X (S, N, 3), U (S, N, 2), each with its first input moved into this sample's
        first-step bound (as the nominal NMPC's guess); the reference with each scenario's feed-forward
        inputs before the first plan.

        After it: the previous scenario plans *not* shifted in time, their states moved to start at
        ``x0`` (:func:`moved_to`; heading on x0's branch). A multi-stage plan is not time-consistent:
        each scenario's recourse inputs after the robust horizon differ from the shared ones, so a shift
        by one period puts them into the new shared block and one Gauss–Newton step per sample settles
        at a fixed point that is not the NLP's (docs/control.md). The previous solution read as the
        plan from ``t`` is the NLP's solution at a steady state on the circle (the problem seen from
        the robot does not change) and a guess one period off in a transient."""
        rs = scenario_radii(self.fractions, radii)
        N, S = self.col.N, self.S
        if self._stages is None:
            Xg = np.repeat(ref[:3].T[None], S, axis=0)
            Ug = np.stack([self._reference_inputs(ref, r) for r in rs])
        else:
            Xp, Up = self._stages[1], self._stages[2]
            Xg, Ug = np.empty((S, N, 3)), np.empty((S, N, 2))
            for i in range(S):
                Xg[i], Ug[i] = moved_to(Xp[i], x0), Up[i]
        Xg[:, 0] = x0
        return Xg, np.stack([self._into_first_step_bound(u) for u in Ug])

    def _accept(self, t: float, X: np.ndarray, U: np.ndarray, status: str, iterations: int, t_start: float,
                budget: float | None, radii: np.ndarray) -> ControlOutput:
        """Keep the scenario plans; the plan of the scenario of largest weight is the one predicted
        (and shifted on a fallback). Its first input, as applied (within the first-step bound), is every
        scenario's."""
        rep = int(np.argmax(self.weights))
        out = super()._accept(t, X[rep], U[rep], status, iterations, t_start, budget, radii)
        if not out.fallback:
            om = self.spec.omega_max
            Us = np.clip(U, -om, om)
            Us[:, 0] = out.omega
            self._stages = (t, X.copy(), Us)
        return out
