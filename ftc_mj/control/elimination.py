"""Condensing the linearised LGL collocation: the states as affine functions of the inputs."""

from __future__ import annotations

import numpy as np

from .kernels import condense_pose
from .solvers import BufferedFunction
from .transcription import Collocation


def lateral_accel_linearisation(Ug: np.ndarray, J: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lateral acceleration ``a = V psidot`` at the nodes linearised about the wheel rates ``Ug`` (N, 2):
    ``a(u) ≈ lin0 + gR omega_R + gL omega_L`` node by node; ``J`` (2, 2) is ``d[V, psidot]/d[omega_R,
    omega_L]`` for the radii in use (``V`` and ``psidot`` are linear in the rates). Returns
    ``(gR, gL, lin0)``, each (N,), in m/s² per rad/s and m/s²."""
    V = Ug @ J[0]
    r = Ug @ J[1]
    gR = r * J[0, 0] + V * J[1, 0]
    gL = r * J[0, 1] + V * J[1, 1]
    lin0 = V * r - (gR * Ug[:, 0] + gL * Ug[:, 1])  # a(u) ≈ a(ug) + grad·(u - ug) = lin0 + grad·u
    return gR, gL, lin0


class StateElimination:
    """Exact elimination of the states of the linearised LGL collocation (the condensing step).

    With node 0 replaced by the initial condition, each state obeys ``X_s = Dt⁻¹ [x0_s; rhs_s(1:)]``
    with the constant matrix ``Dt = [e_0ᵀ; (2/T) D(1:, :)]``; the node-0 collocation equation of each
    state stays as an equality row. :meth:`pose` does this for the pose ``[x, y, psi]`` of the
    kinematics linearised about a guess (``f`` does not depend on x, y; psidot depends on the inputs
    only), :meth:`integrator` for a state whose rate is one of the inputs (exactly linear).
    """

    def __init__(self, col: Collocation) -> None:
        N, h, D = col.N, col.h, col.D
        self.N = N
        Dt = np.vstack([np.eye(N)[:1], D[1:] / h])
        Dinv = np.linalg.inv(Dt)
        self.c0 = Dinv[:, 0].copy()
        self.K = np.ascontiguousarray(Dinv[:, 1:])
        self.hD0 = np.ascontiguousarray(D[0] / h)
        self._lin = BufferedFunction(col.lin)

    def pose(self, Xg: np.ndarray, Ug: np.ndarray, radii: np.ndarray, x0: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(G (3, N, 2N), hc (3, N), E (3, 2N), e (3,))``: the pose ``X_s = G[s] u + hc[s]`` (x, y, psi)
        of the collocation linearised about ``(Xg (N,3), Ug (N,2))`` as a function of the wheel rates
        ``u = [omega_R(N), omega_L(N)]``, and the node-0 collocation rows ``E u = e``."""
        N = self.N
        fx, A, B = self._lin(Xg.T, Ug.T, radii)
        G, hc, E, e = np.empty((3, N, 2 * N)), np.empty((3, N)), np.empty((3, 2 * N)), np.empty(3)
        condense_pose(fx, A, B, np.ascontiguousarray(Xg, dtype=float), np.ascontiguousarray(Ug, dtype=float),
                      np.ascontiguousarray(x0, dtype=float), self.K, self.c0, self.hD0, G, hc, E, e)
        return G, hc, E, e

    def integrator(self, s0: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """``(G (N, N), h (N,), E (N,), e)`` for a state with ``ds/dt = v`` (``v`` the input at the nodes):
        ``s = G v + h`` with ``s(t0) = s0``, and the node-0 collocation row ``E v = e``."""
        G = np.zeros((self.N, self.N))
        G[:, 1:] = self.K
        h = self.c0 * s0
        E = self.hD0 @ G
        E[0] -= 1.0
        return G, h, E, -float(self.hD0 @ h)

