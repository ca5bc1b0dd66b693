"""The MPC lifecycle every model-predictive controller of the package shares.

One sample is: count it, remember the command in force (:meth:`MPCLifecycle._begin`), solve
(:meth:`MPCLifecycle._solve`, the controller's own problem), and turn a solver error into a fallback.
The lifecycle holds the previous plan, the counters, the last valid radii and the IPOPT re-seed
schedule: the first solve (and a re-seed after two consecutive failures) is an IPOPT solve, the
others one real-time iteration (:meth:`MPCLifecycle._iterate`); after a failed re-seed no other is
tried for :data:`RESEED_WAIT` samples. A failed or over-budget solve, a solver error or a non-finite
pose/radii never raises: the controller falls back to its previous plan shifted to the current time
(:meth:`MPCLifecycle._fallback_plan`, the controller's own), counts it in ``failures`` and says why
in ``status``. Any other exception propagates and fails the run. ``reset()`` makes a used controller
behave exactly like a new one (the simulation reuses built solvers across runs).
"""

from __future__ import annotations

import os
import time
import traceback
from collections.abc import Callable
from typing import Any

import numpy as np

from ..estimation.kernels.jit import compile_seconds_since
from ..lazy import lazy_module
from .base import ControlOutput
from .blas import limit_blas_threads
from .spec import ProblemSpec
from .transcription import Collocation

ca = lazy_module("casadi")

SOLVERS = ("ipopt", "rti-daqp", "rti-qpoases", "rti-osqp")
"""Solver names of the NMPCs: the full NLP by IPOPT, or real-time iterations with a CasADi QP plugin."""

RESEED_WAIT = 20
"""Samples (2 s at 10 Hz) without IPOPT re-seeds after a re-seed failed (RTI steps continue meanwhile)."""

def _raised_in(exc: BaseException, directory: str) -> bool:
    """The innermost frame of ``exc``'s traceback is in a file under ``directory``."""
    frames = traceback.extract_tb(exc.__traceback__)
    return bool(frames) and os.path.abspath(frames[-1].filename).startswith(directory + os.sep)


def solver_error(exc: BaseException) -> bool:
    """``exc`` is a solver error a controller falls back on: a linear-algebra failure, or a ``RuntimeError``
    raised by CasADi (its plugins and IPOPT report through it). Anything else is a bug that fails the run."""
    if isinstance(exc, np.linalg.LinAlgError):
        return True
    return isinstance(exc, RuntimeError) and _raised_in(exc, os.path.dirname(os.path.abspath(ca.__file__)))


def sanitize_pose(pose: np.ndarray) -> np.ndarray | None:
    """The pose [x, y, psi] (m, m, rad) as a float array (3,), or ``None`` if it is not finite."""
    p = np.asarray(pose, dtype=float).ravel()
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        return None
    return p


def sanitize_radii(radii: np.ndarray, min_radius: float = 1e-3) -> np.ndarray | None:
    """The radii [R_R, R_L] as (2,) floored at ``min_radius`` (m), or ``None`` if not finite."""
    r = np.asarray(radii, dtype=float).ravel()
    if r.shape != (2,) or not np.all(np.isfinite(r)):
        return None
    return np.maximum(r, min_radius)


class MPCLifecycle:
    """Solve, fall back, re-seed and reset: the sample logic of every MPC (module docstring).

    A subclass defines :meth:`_solve` (one sample of its problem) and :meth:`_fallback_plan`, and may
    extend :meth:`_begin` (what it keeps of the command in force) and :meth:`_reset_solvers`.

    Parameters
    ----------
    problem
        The tracking problem's numbers; its LGL grid (``col``) gives the node times of plans and fallbacks.
    nominal_radii
        Radii [R_R, R_L] (m) used before any valid radii have been seen.
    time_budget, cold_time_budget
        Wall time (s) of a warm solve and of an IPOPT seed solve; an over-budget solve falls back like a
        failed one. ``None``: no budget.
    single_thread_blas
        Set numpy's BLAS to one thread (:func:`~ftc_mj.control.blas.limit_blas_threads`).
    """

    telemetry_columns: tuple[str, ...] = ()

    def __init__(self, problem: ProblemSpec, nominal_radii: tuple[float, float], time_budget: float | None,
                 cold_time_budget: float | None, single_thread_blas: bool = True) -> None:
        if single_thread_blas:
            limit_blas_threads(1)
        self.col = Collocation(problem)
        self.nominal_radii = np.asarray(nominal_radii, dtype=float)
        self.time_budget = None if time_budget is None else float(time_budget)
        self.cold_time_budget = None if cold_time_budget is None else float(cold_time_budget)
        self._clear()

    def _clear(self) -> None:
        """The lifecycle's state of a new controller: no plan, no counts, the nominal radii."""
        self.failures = 0
        """Number of samples that fell back (failed, over budget, or invalid input)."""
        self.solves = 0
        self._plan: tuple[float, np.ndarray, np.ndarray] | None = None  # (t0, X, U) of the last accepted plan
        self._last_radii = self.nominal_radii.copy()
        self._consecutive_failures = 0
        self._reseed_wait = 0
        self._u_applied: np.ndarray | None = None

    def reset(self) -> None:
        """Forget the plan, the warm starts and the counters: a reset controller behaves exactly like a new one."""
        self._clear()
        self._reset_solvers()

    def _reset_solvers(self) -> None:
        """Forget the solvers' warm starts (multipliers, active sets)."""

    # ------------------------------------------------------------------------------------------
    def solve(self, t: float, pose: np.ndarray, radii: np.ndarray,
              u_applied: np.ndarray | None = None) -> ControlOutput:
        """Command [omega_R, omega_L] (rad/s) at time ``t`` (s) for the measured ``pose``
        [x, y, psi] (m, m, rad) and the model radii [R_R, R_L] (m); ``u_applied`` (rad/s) is the
        command in force on the plant (``None`` before the first one)."""
        t_start = time.perf_counter()
        self.solves += 1
        self._begin(u_applied)
        try:
            out = self._solve(t, pose, radii, t_start)
        except (RuntimeError, np.linalg.LinAlgError) as exc:
            # only solver errors become a fallback: a linear-algebra failure, or an error raised by
            # CasADi (its plugins and IPOPT report through RuntimeError); anything else is a bug
            # that fails the run
            if not solver_error(exc):
                raise
            out = self._fallback(t, f"solver error: {type(exc).__name__}: {exc}", t_start, None)
        self._consecutive_failures = self._consecutive_failures + 1 if out.fallback else 0
        return out

    def _begin(self, u_applied: np.ndarray | None) -> None:
        """Keep the command in force (rad/s) for this sample."""
        self._u_applied = None if u_applied is None else np.asarray(u_applied, dtype=float).copy()

    def _solve(self, t: float, pose: np.ndarray, radii: np.ndarray, t_start: float) -> ControlOutput:
        raise TypeError(f"{type(self).__name__} must define _solve")

    def _iterate(self, seed: Callable[[], tuple], step: Callable[[], tuple] | None
                 ) -> tuple[bool, str, int, list[Any], float | None]:
        """One solve: the IPOPT ``seed()`` for the first solve, for a re-seed after two consecutive failures
        (none for :data:`RESEED_WAIT` samples after a re-seed failed) and without real-time iterations
        (``step`` ``None``); else one real-time iteration ``step()``.

        ``seed()`` returns ``(ok, status, iterations, *plan)``, ``step()`` ``(ok, status, *plan)``. Returns
        ``(ok, status, iterations, plan, budget)`` with ``budget`` (s) the wall-time budget of that kind of solve.
        """
        reseed = step is not None and self._consecutive_failures >= 2 and self._reseed_wait == 0
        self._reseed_wait = max(self._reseed_wait - 1, 0)
        cold = self._plan is None or reseed
        if step is not None and not cold:
            ok, status, *plan = step()
            return ok, f"rti: {status}", 1, plan, self.time_budget
        ok, status, it, *plan = seed()
        if not ok and reseed:
            # an IPOPT re-seed failed too: go on with RTI steps from the shifted plan and do not try
            # another (costly) re-seed for RESEED_WAIT samples
            self._reseed_wait = RESEED_WAIT
        label = f"ipopt seed: {status}" if step is not None else status
        return ok, label, it, plan, self.cold_time_budget if cold else self.time_budget

    @staticmethod
    def _over_budget(t_start: float, budget: float | None, status: str) -> str | None:
        """The fallback status of a solve started at ``t_start`` (``perf_counter``, s) that overran ``budget`` (s),
        else ``None``. The time numba spent compiling (or loading) kernels during the solve is not counted: it is
        the process's, once, not the solve's."""
        elapsed = time.perf_counter() - t_start - compile_seconds_since(t_start)
        if budget is not None and elapsed > budget:
            return f"over budget ({elapsed * 1e3:.1f} ms > {budget * 1e3:.1f} ms; {status})"
        return None

    def _keep(self, t: float, X: np.ndarray, U: np.ndarray, radii: np.ndarray) -> None:
        """Remember the accepted plan (X, U on the nodes from ``t``, s) and its radii (m) for the next
        warm start and fallback."""
        self._plan = (t, X.copy(), U.copy())
        self._last_radii = radii.copy()

    def _planned(self, t: float, status: str, iterations: int, t_start: float, X: np.ndarray, U: np.ndarray,
                 telemetry: dict[str, float] | None = None) -> ControlOutput:
        """The output of an accepted plan: first command of ``U`` (N, 2) (rad/s), predicted poses ``X`` (N, 3)."""
        return ControlOutput(
            omega=U[0].copy(), success=True, status=status, iterations=iterations,
            solve_time=time.perf_counter() - t_start, fallback=False, predicted=X,
            predicted_t=self.col.times(t), predicted_omega=U, telemetry=telemetry or {},
        )

    def _fallback(self, t: float, status: str, t_start: float, radii: np.ndarray | None,
                  iterations: int = 0) -> ControlOutput:
        """Count a failure and command the fallback plan (:meth:`_fallback_plan`) at ``t`` (s); ``radii`` (m)
        this sample's (``None``: not valid, the last valid ones are used)."""
        self.failures += 1
        r = self._last_radii if radii is None else radii
        X, U = self._fallback_plan(t, r)
        return ControlOutput(
            omega=U[0].copy(), success=False, status=f"fallback: {status}", iterations=iterations,
            solve_time=time.perf_counter() - t_start, fallback=True, predicted=X, predicted_t=self.col.times(t),
            predicted_omega=U,
        )

    def _fallback_plan(self, t: float, radii: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Predicted poses (N, 3) and commands (N, 2) (rad/s, within every input bound) of a fallback at ``t``."""
        raise TypeError(f"{type(self).__name__} must define _fallback_plan")
