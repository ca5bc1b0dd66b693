"""Linear MPC: the NMPC's problem with the dynamics linearised about the reference.

Same horizon, LGL nodes, weights and constraints as :class:`~ftc_mj.control.nmpc.NMPC`
(discretisation: the same LGL collocation, with linear dynamics). At each sample the kinematics
are linearised about the reference trajectory at the node times — reference states and the
feed-forward wheel rates that realise ``V_ref, psidot_ref`` with the *current* radius estimates —
and the resulting QP (states eliminated exactly, 2N inputs) is solved once by a CasADi QP plugin
(``daqp`` by default; ``qpoases``/``osqp`` selectable), warm-started from the shifted previous plan,
with the same first-step bound from the command in force as the NMPC.
Unlike the RTI NMPC, the linearisation point does not follow the robot, so large deviations from
the reference (heading errors of tens of degrees) are predicted less accurately.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from .base import ControlOutput
from .condensed_qp import CondensedQP
from .spec import MPCSettings, ProblemSpec
from .tracking import PlanController


class LinearMPCSettings(MPCSettings):
    """Settings of the linear MPC (``controller.kind = "lmpc"``): the MPC settings and its QP solver."""

    kind: Literal["lmpc"] = "lmpc"
    """The linear MPC (a registered controller, :data:`ftc_mj.registry.controllers`)."""
    lmpc_qpsol: Literal["daqp", "qpoases", "osqp"] = "daqp"
    """QP solver of the linear MPC (CasADi conic plugin)."""


class LinearMPC(PlanController):
    """Linear MPC on the reference-linearised kinematics. ``solve(t, pose, radii)`` per sample.

    ``qpsol``: CasADi conic plugin; ``time_budget`` (s): an over-budget solve falls back like a
    failed one; ``nominal_radii`` (m): used before any valid radii are seen.
    """

    def __init__(
        self,
        spec: ProblemSpec,
        reference,
        qpsol: str = "daqp",
        time_budget: float | None = 0.1,
        nominal_radii: tuple[float, float] = (2.0, 2.0),
        qp_options: dict | None = None,
    ) -> None:
        super().__init__(spec, reference, nominal_radii, time_budget)
        self.qpsol = qpsol
        self._qp = CondensedQP(self.col, qpsol, qp_options)

    def _solve(self, t: float, pose: np.ndarray, radii: np.ndarray, t_start: float) -> ControlOutput:
        """One QP on the model linearised about the reference (``solve`` of the base class wraps it)."""
        prep = self._prepare(t, pose, radii, t_start)
        if isinstance(prep, ControlOutput):
            return prep
        r, ref, x0 = prep
        Xr = ref[:3].T
        Ur = self._reference_inputs(ref, r)
        u_init = self._guess(t, x0, ref, r)[1].T.ravel() if self._plan is not None else Ur.T.ravel()
        ok, status, X, U = self._qp.solve(Xr, Ur, r, x0, ref, u_init, self._u_prev)
        if not ok:
            return self._fallback(t, f"qp: {status}", t_start, r, 1)
        return self._accept(t, X, U, f"qp: {status}", 1, t_start, self.time_budget, r)
