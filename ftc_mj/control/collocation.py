"""The pseudospectral (LGL) tracking problem shared by the NMPC and the linear MPC.

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

:class:`CondensedQP` linearises the collocation about a guess and eliminates the states exactly,
which leaves a dense QP in the 2N inputs only (3 equality rows + 2N rate rows + box bounds; the
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

import contextlib
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import numpy as np

from ..model.kinematics import KinematicModel, pose_rates
from .certified_qp import CertifiedQP
from .lgl import barycentric_weights, lgl

TWO_PI = 2.0 * np.pi


def limit_blas_threads(n: int = 1) -> bool:
    """Set numpy's OpenBLAS thread count (process-wide) to ``n``; True if it could be set.

    The MPC matrices are ~100x150: multithreaded BLAS only adds synchronisation, and on a loaded
    2-core machine it made an RTI step ~6x slower (15 ms instead of 2.4 ms median). Equivalent to
    ``OPENBLAS_NUM_THREADS=1`` but works after numpy has been imported.

    It also makes runs deterministic: CasADi's bundled OpenBLAS (under IPOPT's MUMPS) with two
    threads gives round-off that differs from call to call (up to 3e-12 in the first RTI QP after an
    IPOPT seed, which a saturated closed loop amplifies to different trajectories). CasADi loads
    that library lazily with its IPOPT plugin, so it is loaded here first; the plugin then shares
    this (single-threaded) instance.
    """
    import ctypes

    ok = False
    try:
        bundled = Path(ca.__file__).parent / "libcasadi-tp-openblas.so.0"
        if bundled.is_file():
            ctypes.CDLL(str(bundled), mode=ctypes.RTLD_GLOBAL)
    except OSError:
        pass
    try:
        with open("/proc/self/maps") as fh:
            libs = {ln.split()[-1] for ln in fh if "openblas" in ln.lower() and "/" in ln}
    except OSError:
        return False
    for path in libs:
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for name in ("scipy_openblas_set_num_threads64_", "scipy_openblas_set_num_threads",
                     "openblas_set_num_threads64_", "openblas_set_num_threads"):
            fn = getattr(lib, name, None)
            if fn is not None:
                fn(ctypes.c_int(n))
                ok = True
                break
    return ok


@dataclass(frozen=True)
class ProblemSpec:
    """Numbers that define the tracking problem (units in the field comments)."""

    nodes: int = 50
    horizon: float = 5.0  # s
    half_track: float = 1.0  # m
    omega_max: float = np.radians(1000.0)  # rad/s
    omega_rate_max: float = 20.0  # rad/s^2
    q_pose: float = 10.0
    q_speed: float = 1.0
    q_yaw_rate: float = 1.0
    rate_penalty: float = 0.0
    max_lateral_accel: float | None = None  # m/s^2; None = no bound (the paper's problem)
    max_longitudinal_accel: float | None = None  # m/s^2; None = no bound
    sample_time: float = 0.1  # s, controller period T_s (the command is held that long)
    rate_bound_from_applied: bool = True  # |U(t0) - u_prev| <= omega_rate_max T_s; False = free first input
    rate_penalty_first_step: bool = False  # rate_penalty also covers U(t0) - u_prev (with the bound on)


def first_input_bounds(spec: ProblemSpec, u_prev: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Bounds ``lo ≤ U(t0) ≤ hi`` (rad/s, each (2,) [omega_R, omega_L]) on the plan's first input.

    ``u_prev`` (rad/s) is the input in force before ``t0``; the bound is
    ``|U(t0) − u_prev| ≤ omega_rate_max T_s`` intersected with ``|U(t0)| ≤ omega_max``, with ``u_prev``
    first clipped to the input bounds so that the interval is never empty. ``None``: no first-step
    bound (only ``|U(t0)| ≤ omega_max``).
    """
    om = spec.omega_max
    if u_prev is None:
        return np.full(2, -om), np.full(2, om)
    u = np.asarray(u_prev, dtype=float).ravel()
    if u.shape != (2,) or not np.all(np.isfinite(u)):
        raise ValueError(f"u_applied must be two finite wheel rates (rad/s), got {u_prev!r}")
    u = np.clip(u, -om, om)
    step = spec.omega_rate_max * spec.sample_time
    return np.maximum(u - step, -om), np.minimum(u + step, om)


def warm_started_solve(solver: ca.Function, args: dict, lam: tuple[np.ndarray, np.ndarray] | None
                       ) -> tuple[bool, str, int, np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
    """One call of an IPOPT ``nlpsol`` warm-started with the multipliers of the previous successful solve.

    Parameters
    ----------
    solver
        The ``nlpsol`` function.
    args
        Its arguments (``x0``, ``p``, bounds); the multipliers ``lam`` are added as ``lam_x0``, ``lam_g0``.
    lam
        ``(lam_x, lam_g)`` of the previous successful solve, or ``None``.

    Returns
    -------
    ok, status, iterations, w, lam
        ``ok`` when IPOPT reports success and the primal ``w`` is finite; ``lam`` the multipliers for the
        next solve, ``None`` after a failure (a failed solve's multipliers are no start).
    """
    if lam is not None:
        args = {**args, "lam_x0": lam[0], "lam_g0": lam[1]}
    res = solver(**args)
    st = solver.stats()
    w = np.asarray(res["x"]).ravel()
    ok = bool(st.get("success", False)) and bool(np.all(np.isfinite(w)))
    it = int(st.get("iter_count", 0))
    if not ok:
        return False, str(st.get("return_status", "failed")), it, w, None
    return True, str(st["return_status"]), it, w, (np.asarray(res["lam_x"]).ravel(), np.asarray(res["lam_g"]).ravel())


def first_step_penalty(spec: ProblemSpec, u_prev: np.ndarray | None) -> float:
    """Weight ``c`` of the first-step penalty ``c ‖U(t0) − u_prev‖²`` (rad/s)⁻² per unit cost:
    ``rate_penalty T_s ‖(U(t0) − u_prev)/T_s‖² = (rate_penalty / T_s) ‖U(t0) − u_prev‖²``; 0 without
    ``u_prev``, without the rate penalty or with ``rate_penalty_first_step`` off."""
    return 0.0 if u_prev is None or not spec.rate_penalty_first_step else spec.rate_penalty / spec.sample_time


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


class BufferedFunction:
    """Zero-copy evaluation of a CasADi ``Function`` on preallocated numpy arrays.

    Converting numpy arrays to ``DM`` costs ~70 ns per element through SWIG, which dominated the
    RTI step (a dense 100x100 Hessian); ``Function.buffer()`` reads and writes numpy memory in place.
    Dense column-major layout: write inputs with :meth:`arg` and read outputs with :meth:`res`.
    """

    def __init__(self, f: ca.Function) -> None:
        self.f = f
        self._buf, self._eval = f.buffer()
        self.args = [np.zeros(f.nnz_in(i)) for i in range(f.n_in())]
        self.outs = [np.zeros(f.nnz_out(i)) for i in range(f.n_out())]
        for i, a in enumerate(self.args):
            self._buf.set_arg(i, memoryview(a))
        for i, o in enumerate(self.outs):
            self._buf.set_res(i, memoryview(o))

    def __call__(self, *args: np.ndarray) -> list[np.ndarray]:
        """Evaluate; each argument is copied (flattened column-major) into the input buffers."""
        for dst, a in zip(self.args, args, strict=True):
            if isinstance(a, np.ndarray) and a.ndim == 2:
                dst.reshape(a.shape, order="F")[...] = a  # column-major in one pass (no temporary copy)
            else:
                dst[:] = np.ravel(a, order="F")
        self._eval()
        return self.outs

    def stats(self) -> dict:
        """Statistics of the last evaluation (for a wrapped solver: the solver's stats)."""
        try:
            return dict(self._buf.stats())
        except RuntimeError:
            return {}

    @property
    def ret(self) -> int:
        """Return code of the last evaluation (0 = ok)."""
        return int(self._buf.ret())


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
        self.hD0 = D[0] / h
        self._lin = BufferedFunction(col.lin)

    def pose(self, Xg: np.ndarray, Ug: np.ndarray, radii: np.ndarray, x0: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(G (3, N, 2N), hc (3, N), E (3, 2N), e (3,))``: the pose ``X_s = G[s] u + hc[s]`` (x, y, psi)
        of the collocation linearised about ``(Xg (N,3), Ug (N,2))`` as a function of the wheel rates
        ``u = [omega_R(N), omega_L(N)]``, and the node-0 collocation rows ``E u = e``."""
        N, K, c0 = self.N, self.K, self.c0
        fx, A, B = self._lin(Xg.T, Ug.T, radii)
        fx = fx.reshape(3, N, order="F")
        A = A.reshape(3, 3, N, order="F")  # A[i, j, k] = d f_i / d x_j at node k
        B = B.reshape(3, 2, N, order="F")
        # affine model f ≈ A X + B U + c
        c = fx - np.einsum("ijk,kj->ik", A, Xg) - np.einsum("ijk,kj->ik", B, Ug)
        ax, ay = A[0, 2], A[1, 2]
        G = np.zeros((3, N, 2 * N))
        hc = np.empty((3, N))
        # psi
        G[2][:, 1:N] = K * B[2, 0, 1:]
        G[2][:, N + 1:] = K * B[2, 1, 1:]
        hc[2] = c0 * x0[2] + K @ c[2, 1:]
        for s, a in ((0, ax), (1, ay)):
            Gs = K @ (a[1:, None] * G[2][1:])
            Gs[:, 1:N] += K * B[s, 0, 1:]
            Gs[:, N + 1:] += K * B[s, 1, 1:]
            G[s] = Gs
            hc[s] = c0 * x0[s] + K @ (a[1:] * hc[2][1:] + c[s, 1:])
        # node-0 collocation rows: (2/T) D(0,:) @ X_s - (A X + B U + c)_0 = 0
        E = self.hD0 @ G  # (3, 2N)
        E[:, 0] -= B[:, 0, 0]
        E[:, N] -= B[:, 1, 0]
        e = c[:, 0] + A[:, :, 0] @ x0 - hc @ self.hD0
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


class CondensedQP:
    """Linearise the collocation about a guess, eliminate the states, solve the dense input QP.

    ``qpsol`` is any CasADi conic plugin (``daqp``, ``qpoases``, ``osqp``, ``piqp``, ...). The QP
    solver is wrapped in an MX Function together with the constant rate-constraint rows and called
    through :class:`BufferedFunction` (no per-element conversions).

    With ``certified`` (the default for ``daqp``) the QP is first solved by
    :class:`~ftc_mj.control.certified_qp.CertifiedQP`: the previous sample's active set, else the one
    read off an interior-point solve, is solved exactly and accepted with a KKT certificate (or the
    QP is declared infeasible with a Farkas certificate); only an unresolved QP goes to the CasADi
    plugin. The result equals the plugin's within the solvers' tolerances; the saturated loops, where
    DAQP needs hundreds of active-set iterations, get much cheaper. ``path_counts`` counts how each
    QP was decided (``guess``, ``ipm``, ``farkas``, ``plugin``).

    Constraint rows (``A u`` in the order of ``lam_a``): the 3 node-0 collocation equalities, the 2N
    rate rows, then the optional N lateral- and N longitudinal-acceleration rows. :meth:`_rows` assembles them densely
    for the certified path; a new block of rows goes there and into the plugin's ``A`` alike. The box
    ``lbx ≤ u ≤ ubx`` is an input of both paths (:meth:`input_bounds`): ``±omega_max``, tightened on the
    two first inputs by the bound from the input in force (:func:`first_input_bounds`).
    """

    def __init__(self, col: Collocation, qpsol: str = "daqp", qp_options: dict | None = None,
                 certified: bool | None = None) -> None:
        self.col = col
        N, h, D = col.N, col.h, col.D
        n = 2 * N
        self.nu = n
        self.elim = StateElimination(col)
        Dblk = np.zeros((n, n))
        Dblk[:N, :N] = D
        Dblk[N:, N:] = D
        self.Dblk = Dblk
        sp = col.spec
        # rate penalty: (T/2) Σ w ‖(1/h) D u‖² -> u' (Dblk' diag(W) Dblk)/h² u
        Wd = np.concatenate([col.W, col.W])
        self.R_rate = 2.0 * sp.rate_penalty * (Dblk.T * Wd) @ Dblk / h**2
        self._qW3 = sp.q_pose * np.tile(col.W, 3)  # pose-error weights of the stacked states (x, y, psi)
        self.qpsol = qpsol
        opts = _default_qp_options(qpsol)
        opts.update(qp_options or {})
        self.a_lat = sp.max_lateral_accel
        self.a_lon = sp.max_longitudinal_accel
        n_lat = N if self.a_lat is not None else 0
        n_lon = N if self.a_lon is not None else 0
        nA = 3 + n + n_lat + n_lon
        a_pattern = np.zeros((nA, n), dtype=bool)
        a_pattern[:3] = True
        a_pattern[3:3 + n] = Dblk != 0
        idx = np.arange(n_lat)
        a_pattern[3 + n + idx, idx] = True
        a_pattern[3 + n + idx, N + idx] = True
        a_pattern[3 + n + n_lat:] = True
        rows, cols = np.nonzero(a_pattern)
        a_sp = ca.Sparsity.triplet(nA, n, rows.tolist(), cols.tolist())
        self.solver = ca.conic("qp", qpsol, {"h": ca.Sparsity.dense(n, n), "a": a_sp}, opts)
        rate = sp.omega_rate_max * h
        Hs, gs = ca.MX.sym("H", n, n), ca.MX.sym("g", n)
        Es, es = ca.MX.sym("E", 3, n), ca.MX.sym("e", 3)
        xs, lxs, las = ca.MX.sym("x0", n), ca.MX.sym("lam_x0", n), ca.MX.sym("lam_a0", nA)
        # lateral-acceleration rows: row j holds d(V psidot)_j/d[omega_R,j, omega_L,j] (nonzeros Lv),
        # bounds [ll, lu] from the linearisation
        Lv, ll, lu = ca.MX.sym("Lv", 2 * n_lat), ca.MX.sym("ll", n_lat), ca.MX.sym("lu", n_lat)
        lat_sp = ca.Sparsity.triplet(n_lat, n, np.concatenate([idx, idx]).tolist(),
                                     np.concatenate([idx, N + idx]).tolist())
        # longitudinal-acceleration rows dV/dt = J_V (D/h) u (dense N x 2N, values depend on the radii)
        Lo = ca.MX.sym("Lo", n_lon, n)
        lbxs, ubxs = ca.MX.sym("lbx", n), ca.MX.sym("ubx", n)
        A = ca.vertcat(Es, ca.DM(Dblk), ca.MX(lat_sp, Lv), Lo)
        lon_b = (self.a_lon or 0.0) * np.ones(n_lon)
        r = self.solver(
            h=Hs, g=gs, a=A, lba=ca.vertcat(es, -rate * np.ones(n), ll, -lon_b),
            uba=ca.vertcat(es, rate * np.ones(n), lu, lon_b),
            lbx=lbxs, ubx=ubxs, x0=xs, lam_x0=lxs, lam_a0=las,
        )
        self._qpfun = BufferedFunction(
            ca.Function("rti_qp", [Hs, gs, Es, es, Lv, ll, lu, Lo, lbxs, ubxs, xs, lxs, las],
                        [r["x"], r["lam_x"], r["lam_a"], r["cost"]])
        )
        self._J = BufferedFunction(col.rates_jac)
        self._J_cache: tuple[tuple[float, float], np.ndarray] | None = None
        self.omega_max = sp.omega_max
        self.rate_lim = rate
        self._lam_x = np.zeros(n)
        self._lam_a = np.zeros(nA)
        self.certified = (qpsol == "daqp") if certified is None else bool(certified)
        self._cqp = CertifiedQP()
        self._ws: np.ndarray | None = None  # working set of the last certified solution (the next guess)
        self.path_counts: Counter[str] = Counter()

    def reset(self) -> None:
        """Forget the dual warm start and the active-set guess (a reused solver then behaves exactly
        like a new one)."""
        self._lam_x[:] = 0.0
        self._lam_a[:] = 0.0
        self._ws = None

    # ----------------------------------------------------------------------------------------
    def build(self, Xg: np.ndarray, Ug: np.ndarray, radii: np.ndarray, x0: np.ndarray, ref: np.ndarray,
              u_prev: np.ndarray | None = None):
        """QP data for the linearisation about (Xg (N,3), Ug (N,2)).

        ``ref`` is (5, N): x, y, psi, V, psidot references at the nodes; ``u_prev`` (rad/s, (2,) or
        ``None``) the input in force before ``t0``, for the first-step rate penalty. Returns
        ``(H, g, E, e, G, hc)``: cost ``½ uᵀHu + gᵀu``, node-0 collocation rows ``E u = e``, and the
        states ``X = G u + hc`` (3N, stacked x, y, psi).
        """
        col, N = self.col, self.col.N
        sp = col.spec
        G, hc, E, e = self.elim.pose(Xg, Ug, radii, x0)
        # cost
        W = col.W
        key = (float(radii[0]), float(radii[1]))
        if self._J_cache is None or self._J_cache[0] != key:
            self._J_cache = (key, self._J(radii)[0].reshape(2, 2, order="F").copy())
        J = self._J_cache[1]  # d[V, psidot]/du, constant for given radii
        Gf = G.reshape(3 * N, 2 * N)
        GW = Gf.T * self._qW3
        H = GW @ Gf
        g = GW @ (hc.ravel() - ref[:3].ravel())
        idx = np.arange(N)
        for k, q in ((0, sp.q_speed), (1, sp.q_yaw_rate)):
            a0, a1 = J[k, 0], J[k, 1]
            qW = q * W
            H[idx, idx] += qW * a0 * a0
            H[idx + N, idx + N] += qW * a1 * a1
            H[idx, idx + N] += qW * a0 * a1
            H[idx + N, idx] += qW * a0 * a1
            g[:N] -= qW * a0 * ref[3 + k]
            g[N:] -= qW * a1 * ref[3 + k]
        H = 2.0 * H + self.R_rate
        g = 2.0 * g
        c = first_step_penalty(sp, u_prev)
        if c > 0:  # c ‖U(t0) − u_prev‖² on inputs 0 (omega_R) and N (omega_L)
            assert u_prev is not None
            for i, ui in ((0, u_prev[0]), (N, u_prev[1])):
                H[i, i] += 2.0 * c
                g[i] -= 2.0 * c * ui
        return H, g, E, e, Gf, hc.ravel()

    def input_bounds(self, u_prev: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """Box ``lbx ≤ u ≤ ubx`` (rad/s, (2N,)): ``±omega_max``, with the first inputs (``u[0]`` =
        omega_R, ``u[N]`` = omega_L at ``t0``) tightened to :func:`first_input_bounds` of ``u_prev``."""
        lo, hi = first_input_bounds(self.col.spec, u_prev)
        lbx = np.full(self.nu, -self.omega_max)
        ubx = np.full(self.nu, self.omega_max)
        lbx[[0, self.col.N]] = lo
        ubx[[0, self.col.N]] = hi
        return lbx, ubx

    def lateral_rows(self, Ug: np.ndarray, radii: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Linearised bound ``ll ≤ L u ≤ lu`` of ``|V psidot| ≤ max_lateral_accel`` about ``Ug`` (N,2).
        Returns the nonzeros of ``L`` (column-major: all d/d omega_R, then all d/d omega_L) and the
        bounds; empty arrays without a bound."""
        if self.a_lat is None:
            return np.zeros(0), np.zeros(0), np.zeros(0)
        J = self._J_cache[1] if self._J_cache is not None else self._J(radii)[0].reshape(2, 2, order="F")
        gR, gL, lin0 = lateral_accel_linearisation(Ug, J)
        return np.concatenate([gR, gL]), -self.a_lat - lin0, self.a_lat - lin0

    def longitudinal_rows(self) -> np.ndarray:
        """Rows (N, 2N) of ``dV/dt`` at the nodes in the inputs for the current radii (empty without a bound):
        ``V = J_V u`` node by node, so ``dV/dt = J_V (D/h) u``."""
        if self.a_lon is None:
            return np.zeros((0, self.nu))
        J = self._J_cache[1]
        Dh = self.col.D / self.col.h
        return np.hstack([J[0, 0] * Dh, J[0, 1] * Dh])

    @contextlib.contextmanager
    def recording(self) -> Iterator[list[list[np.ndarray]]]:
        """Record the data ``[H, g, E, e, Lv, ll, lu, Lo, lbx, ubx]`` of every QP solved inside the block
        (for tests and benchmarks that replay them through both solve paths: ``solve_qp(*q, u0)``)."""
        rec: list[list[np.ndarray]] = []
        build, lateral, longitudinal, box = self.build, self.lateral_rows, self.longitudinal_rows, self.input_bounds

        def build_rec(*a):
            out = build(*a)
            rec.append([np.copy(x) for x in out[:4]])
            return out

        def lateral_rec(*a):
            out = lateral(*a)
            rec[-1].extend(np.copy(x) for x in out)
            return out

        def longitudinal_rec():
            out = longitudinal()
            rec[-1].append(np.copy(out))
            return out

        def box_rec(*a):
            out = box(*a)
            rec[-1].extend(np.copy(x) for x in out)
            return out

        self.build, self.lateral_rows, self.longitudinal_rows = build_rec, lateral_rec, longitudinal_rec
        self.input_bounds = box_rec
        try:
            yield rec
        finally:
            del self.build, self.lateral_rows, self.longitudinal_rows, self.input_bounds

    def _rows(self, E: np.ndarray, e: np.ndarray, Lv: np.ndarray, ll: np.ndarray, lu: np.ndarray,
              Lo: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Dense constraint rows ``lba ≤ A u ≤ uba`` (same rows and order as the plugin's ``A``):
        node-0 collocation equalities, rate rows ``|D u| ≤ rate`` (rad/s per unit tau), lateral rows,
        longitudinal rows."""
        N, n = self.col.N, self.nu
        n_lat = ll.size
        n_lon = Lo.shape[0]
        A = np.empty((3 + n + n_lat + n_lon, n))
        A[:3] = E
        A[3:3 + n] = self.Dblk
        if n_lat:
            Lat = A[3 + n:]
            Lat[:] = 0.0
            j = np.arange(n_lat)
            Lat[j, j] = Lv[:N]
            Lat[j, N + j] = Lv[N:]
        if n_lon:
            A[3 + n + n_lat:] = Lo
        r = np.full(n, self.rate_lim)
        lon = np.full(n_lon, self.a_lon or 0.0)
        return A, np.concatenate([e, -r, ll, -lon]), np.concatenate([e, r, lu, lon])

    def _solve_certified(self, H: np.ndarray, g: np.ndarray, E: np.ndarray, e: np.ndarray, Lv: np.ndarray,
                         ll: np.ndarray, lu: np.ndarray, Lo: np.ndarray, lbx: np.ndarray, ubx: np.ndarray
                         ) -> tuple[str, np.ndarray | None, np.ndarray | None, np.ndarray | None]:
        """The certified path: ``(verdict, u, lam_x, lam_a)`` with verdict ``optimal``/``infeasible``/
        ``unresolved``."""
        A, lba, uba = self._rows(E, e, Lv, ll, lu, Lo)
        res = self._cqp.solve(H, g, A, lba, uba, lbx, ubx, self._ws)
        if res.status == "unresolved":
            return "unresolved", None, None, None
        self.path_counts[res.path] += 1
        self._ws = res.working_set
        return res.status, res.u, res.lam_x, res.lam_a

    def solve_qp(self, H: np.ndarray, g: np.ndarray, E: np.ndarray, e: np.ndarray, Lv: np.ndarray, ll: np.ndarray,
                 lu: np.ndarray, Lo: np.ndarray, lbx: np.ndarray, ubx: np.ndarray, u0: np.ndarray
                 ) -> tuple[bool, dict, np.ndarray, np.ndarray | None, np.ndarray | None]:
        """Solve one built QP (the data :meth:`build`, :meth:`lateral_rows`, :meth:`longitudinal_rows`
        and :meth:`input_bounds` return): the certified path first when enabled, the CasADi plugin
        (primal guess ``u0``) for what it leaves unresolved. Returns ``(ok, stats, u, lam_x, lam_a)``;
        ``ok`` is the solver's verdict, before :meth:`solve`'s independent feasibility check."""
        if self.certified:
            verdict, u, lam_x, lam_a = self._solve_certified(H, g, E, e, Lv, ll, lu, Lo, lbx, ubx)
            if verdict == "infeasible":
                return False, {"success": False, "return_status": "infeasible (Farkas certificate)"}, \
                    np.full(self.nu, np.nan), None, None
            if verdict == "optimal":
                assert u is not None
                return True, {"success": True, "return_status": "optimal (certified active set)"}, u, lam_x, lam_a
        u, lam_x, lam_a, _ = self._qpfun(H, g, E, e, Lv, ll, lu, Lo, lbx, ubx, u0, self._lam_x, self._lam_a)
        st = self._qpfun.stats()
        ok = self._qpfun.ret == 0 and bool(st.get("success", True)) and bool(np.all(np.isfinite(u)))
        self.path_counts["plugin"] += 1
        self._ws = None
        return ok, st, u, lam_x, lam_a

    def solve(self, Xg, Ug, radii, x0, ref, u_init: np.ndarray | None = None, u_prev: np.ndarray | None = None):
        """Build and solve the QP; ``u_prev`` (rad/s, (2,)) is the input in force before ``t0`` (``None``:
        no first-step bound or penalty). Returns ``(ok, status, X (N,3), U (N,2))``."""
        N = self.col.N
        H, g, E, e, G, hc = self.build(Xg, Ug, radii, x0, ref, u_prev)
        Lv, ll, lu = self.lateral_rows(Ug, radii)
        Lo = self.longitudinal_rows()
        lbx, ubx = self.input_bounds(u_prev)
        if u_init is None:
            u_init = Ug.T.ravel()
        u0 = np.clip(u_init, lbx, ubx)
        ok, st, u, lam_x, lam_a = self.solve_qp(H, g, E, e, Lv, ll, lu, Lo, lbx, ubx, u0)
        if ok:  # independent feasibility check (solvers differ in what they call success)
            tol = 1e-5 * (1.0 + np.abs(e).max())
            box_tol = 1e-6 * (1.0 + self.omega_max)
            ok = (np.abs(E @ u - e).max() < tol and np.abs(self.Dblk @ u).max() < self.rate_lim * (1 + 1e-6) + 1e-6
                  and bool(np.all(u >= lbx - box_tol) and np.all(u <= ubx + box_tol)))
            if ok and Lv.size:
                lat = Lv[:N] * u[:N] + Lv[N:] * u[N:]
                ok = bool(np.all(lat >= ll - 1e-6 * (1 + np.abs(ll))) and np.all(lat <= lu + 1e-6 * (1 + np.abs(lu))))
            if ok and Lo.size:
                ok = bool(np.abs(Lo @ u).max() <= self.a_lon * (1 + 1e-6) + 1e-6)
        if not ok:
            self._lam_x[:] = 0.0
            self._lam_a[:] = 0.0
            self._ws = None
            return False, str(st.get("return_status", "qp failed")), None, None
        self._lam_x[:] = lam_x
        self._lam_a[:] = lam_a
        u = np.clip(u, lbx, ubx)
        X = (G @ u + hc).reshape(3, N).T
        return True, str(st.get("unified_return_status", st.get("return_status", "ok"))), X, u.reshape(2, N).T


def _default_qp_options(qpsol: str) -> dict:
    if qpsol == "osqp":
        return {
            "error_on_fail": False,
            "warm_start_primal": True,
            "warm_start_dual": True,
            "osqp": {
                "verbose": False,
                "eps_abs": 1e-6,
                "eps_rel": 1e-6,
                "polish": False,
                "max_iter": 4000,
                "adaptive_rho": True,
            },
        }
    if qpsol == "qpoases":
        return {"error_on_fail": False, "printLevel": "none", "sparse": False, "schur": False}
    return {"error_on_fail": False, "print_problem": False} if qpsol == "daqp" else {"error_on_fail": False}


def sanitize_pose(pose: np.ndarray) -> np.ndarray | None:
    """The pose as a float array (3,), or ``None`` if it is not finite."""
    p = np.asarray(pose, dtype=float).ravel()
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        return None
    return p


def sanitize_radii(radii: np.ndarray, min_radius: float = 1e-3) -> np.ndarray | None:
    """The radii as (2,) floored at ``min_radius`` (m), or ``None`` if not finite."""
    r = np.asarray(radii, dtype=float).ravel()
    if r.shape != (2,) or not np.all(np.isfinite(r)):
        return None
    return np.maximum(r, min_radius)


def reference_at_nodes(reference, times: np.ndarray, psi_meas: float) -> tuple[np.ndarray, float]:
    """Reference (5, N) at the node times, and the measured heading moved by a multiple of 2π to
    the branch nearest the reference heading at the first node."""
    r = reference.at(times)
    ref = np.vstack([np.broadcast_to(np.asarray(v, float), times.shape) for v in r])
    psi = psi_meas + TWO_PI * np.round((ref[2, 0] - psi_meas) / TWO_PI)
    return ref, float(psi)
