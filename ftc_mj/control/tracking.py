"""The time-parametrised tracking MPC's plan logic, shared by the linear MPC and the NMPCs.

Each sample tracks the reference at the node times of the horizon from ``t`` (:func:`reference_at_nodes`),
warm-started from the previous plan shifted to ``t`` (:meth:`~ftc_mj.control.transcription.Collocation.shift`)
or, before the first plan, from the reference and its feed-forward wheel rates. Every plan's first input is
bounded relative to the command in force on the plant (``u_applied``):
``|U(t0) − u_applied| ≤ omega_rate_max T_s`` (``ProblemSpec.rate_bound_from_applied``); the warm start
and the fallback plan are moved into that bound
(:meth:`~ftc_mj.control.transcription.Collocation.project_first`). Solving, falling back and re-seeding
are the shared :class:`~ftc_mj.control.mpc.MPCLifecycle`'s.
"""

from __future__ import annotations

import numpy as np

from ..model.kinematics import inverse_rates
from .base import ControlOutput
from .mpc import MPCLifecycle, sanitize_pose, sanitize_radii
from .spec import ProblemSpec, first_input_bounds

TWO_PI = 2.0 * np.pi


def reference_at_nodes(reference, times: np.ndarray, psi_meas: float) -> tuple[np.ndarray, float]:
    """Reference (5, N) x, y, psi, V, psidot at the node times (s), and the measured heading ``psi_meas``
    (rad) moved by a multiple of 2π to the branch nearest the reference heading at the first node."""
    r = reference.at(times)
    ref = np.vstack([np.broadcast_to(np.asarray(v, float), times.shape) for v in r])
    psi = psi_meas + TWO_PI * np.round((ref[2, 0] - psi_meas) / TWO_PI)
    return ref, float(psi)


class PlanController(MPCLifecycle):
    """Plan bookkeeping, warm-start shift, first-step bound and fallback plan of the tracking MPCs.

    ``spec`` (problem numbers), ``reference`` (has ``at(t)``), ``nominal_radii`` (m), ``time_budget`` and
    ``cold_time_budget`` (s): as for :class:`~ftc_mj.control.mpc.MPCLifecycle`.
    """

    def __init__(self, spec: ProblemSpec, reference, nominal_radii: tuple[float, float], time_budget: float | None,
                 cold_time_budget: float | None = 2.0, single_thread_blas: bool = True) -> None:
        self.spec = spec
        self.reference = reference
        super().__init__(spec, nominal_radii, time_budget, cold_time_budget, single_thread_blas)

    def set_reference(self, reference) -> None:
        """Track ``reference`` (has ``at(t)``) from the next solve on. The reference enters the problem only
        as its parameters (sampled at every solve), so a built controller, reset, serves any reference
        exactly as one built for it (the simulation's cache relies on it: ``retargetable``)."""
        self.reference = reference

    def _clear(self) -> None:
        super()._clear()
        self._lam: tuple[np.ndarray, np.ndarray] | None = None  # IPOPT multipliers of the last solve
        self._u_prev: np.ndarray | None = None  # the first step's anchor: u_applied when the bound is on
        self._box = first_input_bounds(self.spec, None)  # (lo, hi) of U(t0) at this sample

    def _reset_solvers(self) -> None:
        qp = getattr(self, "_qp", None)
        if qp is not None:
            qp.reset()

    def _begin(self, u_applied: np.ndarray | None) -> None:
        """Keep the command in force and this sample's first-step bound; ``ValueError`` for a ``u_applied``
        that is not two finite numbers (a caller's bug, not a solver failure)."""
        super()._begin(u_applied)
        anchor = self._u_applied if self.spec.rate_bound_from_applied else None
        self._box = first_input_bounds(self.spec, anchor)  # raises for a non-finite anchor
        self._u_prev = None if anchor is None else np.clip(anchor, -self.spec.omega_max, self.spec.omega_max)

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
        (:meth:`~ftc_mj.control.transcription.Collocation.project_first`); unchanged without the bound."""
        return U if self._u_prev is None else self.col.project_first(U, *self._box)

    def _fallback_plan(self, t: float, radii: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The previous plan shifted to ``t`` (s), or the reference with its feed-forward rates for ``radii``
        (m) before the first plan; inputs clipped and moved into the first-step bound."""
        om = self.spec.omega_max
        if self._plan is not None:
            t_prev, Xp, Up = self._plan
            X, U = self.col.shift(t_prev, Xp, Up, t, self.spec.half_track, radii)
        else:
            times = self.col.times(t)
            ref = np.vstack([np.asarray(v, float) * np.ones_like(times) for v in self.reference.at(times)])
            U = self._reference_inputs(ref, radii)
            X = ref[:3].T
        return X, self._into_first_step_bound(np.clip(np.nan_to_num(U), -om, om))

    def _accept(self, t: float, X: np.ndarray, U: np.ndarray, status: str, iterations: int, t_start: float,
                budget: float | None, radii: np.ndarray) -> ControlOutput:
        """The plan ``X`` (N, 3), ``U`` (N, 2) of a successful solve, unless it overran ``budget`` (s) or its
        first input leaves the first-step bound (then the fallback)."""
        over = self._over_budget(t_start, budget, status)
        if over is not None:
            return self._fallback(t, over, t_start, radii, iterations)
        om = self.spec.omega_max
        U = np.clip(U, -om, om)
        lo, hi = self._box
        tol = 1e-6 * (1.0 + om)  # solvers meet bounds to ~1e-7 (IPOPT's bound relaxation, DAQP's 1e-6)
        if np.any(U[0] < lo - tol) or np.any(U[0] > hi + tol):
            return self._fallback(t, f"first input outside the first-step bound ({status})", t_start, radii,
                                  iterations)
        U[0] = np.clip(U[0], lo, hi)  # exact within the solver's tolerance
        self._keep(t, X, U, radii)
        return self._planned(t, status, iterations, t_start, X, U)
