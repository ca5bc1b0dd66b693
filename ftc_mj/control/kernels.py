"""Compiled (numba) cores of the real-time iteration: condensing, the tracking cost, the certified
working-set solve and the multi-stage QP's assembly.

Why: an RTI step of the tracking NMPC is a few dense products on 100x150 matrices and a working-set solve;
in numpy it was dominated by the overhead of some two hundred small array calls (condensing, the cost, the
certificate's checks and repairs). Here each part is one compiled call on preallocated buffers; the large
products (``K diag(a) K``, ``Gᵀ W G``, ``L⁻¹ C_Wᵀ``, ``YᵀY``) are numba's ``np.dot`` (BLAS) and the
Cholesky factorisation of ``YᵀY`` numba's ``np.linalg.cholesky`` (LAPACK ``potrf``), the rest loops.

The numpy reference of the same maths, operation for operation, is ``tests/support/numpy_rti.py``; the
tests require agreement to round-off (BLAS and these loops sum in different orders), and the certificate's
refusals (:mod:`~ftc_mj.control.certified_qp`) are tested on these kernels.

Kernels are recorded by :func:`ftc_mj.estimation.kernels.jit.njit` (numba imported on the first call of any
kernel), compiled once and cached on disk (``cache=True``); no fastmath, so results are reproducible from
run to run. ``error_model="numpy"``: a division by zero gives inf/NaN as in numpy. Each kernel is called
with one set of argument types (C-contiguous float64 arrays, int64 index arrays, an int8 working set), so
that it compiles once.
"""

from __future__ import annotations

import numpy as np

from ..estimation.kernels.jit import njit


@njit(cache=True, error_model="numpy")
def condense_pose(fx: np.ndarray, A: np.ndarray, B: np.ndarray, Xg: np.ndarray, Ug: np.ndarray, x0: np.ndarray,
                  K: np.ndarray, c0: np.ndarray, hD0: np.ndarray, G: np.ndarray, hc: np.ndarray, E: np.ndarray,
                  e: np.ndarray) -> None:
    """The pose ``[x, y, psi]`` of the linearised LGL collocation as an affine function of the wheel rates
    (:meth:`~ftc_mj.control.elimination.StateElimination.pose`): fills ``G`` (3, N, 2N), ``hc`` (3, N),
    ``E`` (3, 2N) and ``e`` (3,).

    ``fx`` (3N), ``A`` (9N), ``B`` (6N) are the kinematics ``f``, ``df/dx`` and ``df/du`` at the N nodes
    (column-major, as CasADi's mapped ``lin`` returns them), ``Xg`` (N, 3) and ``Ug`` (N, 2) the guess,
    ``x0`` (3,) the initial pose, ``K`` (N, N−1), ``c0`` (N,) and ``hD0`` (N,) the elimination's constant
    matrices. With ``f ≈ A X + B U + c``: ``psi = K (B_psi U)(1:) + c0 psi0 + K c_psi(1:)``, and for
    ``s`` in (x, y), whose rates are ``a_s psi + B_s U + c_s``, ``G_s = M_s diag(B_psi) + K diag(B_s)`` on the
    inputs of nodes 1… with ``M_s = K diag(a_s(1:)) K(1:, :)``.
    """
    N = Xg.shape[0]
    c = np.empty((3, N))
    for k in range(N):
        for i in range(3):
            s = fx[i + 3 * k]
            for j in range(3):
                s -= A[i + 3 * j + 9 * k] * Xg[k, j]
            for j in range(2):
                s -= B[i + 3 * j + 6 * k] * Ug[k, j]
            c[i, k] = s
    G[:] = 0.0
    for r in range(N):
        t = c0[r] * x0[2]
        for j in range(N - 1):
            G[2, r, 1 + j] = K[r, j] * B[2 + 6 * (1 + j)]
            G[2, r, N + 1 + j] = K[r, j] * B[5 + 6 * (1 + j)]
            t += K[r, j] * c[2, 1 + j]
        hc[2, r] = t
    T = np.empty((N - 1, N - 1))
    for s in range(2):
        for i in range(N - 1):
            a = A[s + 6 + 9 * (1 + i)]
            for j in range(N - 1):
                T[i, j] = a * K[1 + i, j]
        M = np.dot(K, T)
        for r in range(N):
            t = c0[r] * x0[s]
            for j in range(N - 1):
                G[s, r, 1 + j] = M[r, j] * B[2 + 6 * (1 + j)] + K[r, j] * B[s + 6 * (1 + j)]
                G[s, r, N + 1 + j] = M[r, j] * B[5 + 6 * (1 + j)] + K[r, j] * B[s + 3 + 6 * (1 + j)]
                t += K[r, j] * (A[s + 6 + 9 * (1 + j)] * hc[2, 1 + j] + c[s, 1 + j])
            hc[s, r] = t
    for s in range(3):
        for col in range(2 * N):
            t = 0.0
            for r in range(N):
                t += hD0[r] * G[s, r, col]
            E[s, col] = t
        E[s, 0] -= B[s]
        E[s, N] -= B[s + 3]
        t = c[s, 0]
        for j in range(3):
            t += A[s + 3 * j] * x0[j]
        for r in range(N):
            t -= hc[s, r] * hD0[r]
        e[s] = t


@njit(cache=True, error_model="numpy")
def tracking_cost(G: np.ndarray, hc: np.ndarray, ref: np.ndarray, W: np.ndarray, qW3: np.ndarray, J: np.ndarray,
                  q: np.ndarray, R_rate: np.ndarray, c_step: float, u_prev: np.ndarray, H: np.ndarray,
                  g: np.ndarray) -> None:
    """The tracking cost ``½ uᵀHu + gᵀu`` in the wheel rates ``u`` (2N,) (:meth:`CondensedQP.build
    <ftc_mj.control.condensed_qp.CondensedQP.build>`): fills ``H`` (2N, 2N) and ``g`` (2N,).

    Pose error ``Σ qW3 (G u + hc − ref_pose)²`` with ``G`` (3, N, 2N), ``hc`` (3, N); speed and yaw-rate
    errors ``Σ q_k W (J_k u_node − ref_{3+k})²`` with ``J`` (2, 2) = ``d[V, psidot]/d[omega_R, omega_L]``
    and ``q`` = (q_speed, q_yaw_rate); the rate penalty ``R_rate``; and, for ``c_step > 0``, the first-step
    penalty ``c_step ‖U(t0) − u_prev‖²``. ``ref`` is (5, N)."""
    N = hc.shape[1]
    n = 2 * N
    m = 3 * N
    Gf = G.reshape((m, n))
    GW = np.empty((n, m))
    d = np.empty(m)
    for row in range(m):
        d[row] = hc[row // N, row % N] - ref[row // N, row % N]
        for col in range(n):
            GW[col, row] = Gf[row, col] * qW3[row]
    Hp = np.dot(GW, Gf)
    gp = np.dot(GW, d)
    for k in range(2):
        a0, a1 = J[k, 0], J[k, 1]
        for i in range(N):
            qW = q[k] * W[i]
            Hp[i, i] += qW * a0 * a0
            Hp[i + N, i + N] += qW * a1 * a1
            Hp[i, i + N] += qW * a0 * a1
            Hp[i + N, i] += qW * a0 * a1
            gp[i] -= qW * a0 * ref[3 + k, i]
            gp[i + N] -= qW * a1 * ref[3 + k, i]
    for i in range(n):
        g[i] = 2.0 * gp[i]
        for j in range(n):
            H[i, j] = 2.0 * Hp[i, j] + R_rate[i, j]
    if c_step > 0.0:
        H[0, 0] += 2.0 * c_step
        g[0] -= 2.0 * c_step * u_prev[0]
        H[N, N] += 2.0 * c_step
        g[N] -= 2.0 * c_step * u_prev[1]


@njit(cache=True, error_model="numpy")
def add_scenario(H: np.ndarray, g: np.ndarray, A: np.ndarray, r0: int, Hi: np.ndarray, gi: np.ndarray,
                 Ai: np.ndarray, ix: np.ndarray, io: np.ndarray, w: float, rho: float, ug_own: np.ndarray) -> None:
    """Add one scenario to the multi-stage QP (:meth:`MultiStageQP.assemble
    <ftc_mj.control.multistage_qp.MultiStageQP.assemble>`): ``H[ix, ix] += w Hi``, ``g[ix] += w gi``, the
    proximal term ``rho`` about ``ug_own`` on its own inputs ``io`` (indices into ``z``), and its rows ``Ai``
    into rows ``r0…`` of ``A`` at the columns ``ix`` (the other columns stay as they are: zero)."""
    ni = ix.size
    for a in range(ni):
        g[ix[a]] += w * gi[a]
        for b in range(ni):
            H[ix[a], ix[b]] += w * Hi[a, b]
    for t in range(io.size):
        H[io[t], io[t]] += rho
        g[io[t]] -= rho * ug_own[t]
    for r in range(Ai.shape[0]):
        for a in range(ni):
            A[r0 + r, ix[a]] = Ai[r, a]


@njit(cache=True, error_model="numpy")
def ws_residual(r: np.ndarray, lo: np.ndarray, hi: np.ndarray, ws: np.ndarray) -> float:
    """``max_W |r_i − b_i| / (1 + max_W |b_i|)`` over the working set ``ws`` (``r = [u; A u]``, ``b_i`` the
    bound the working set puts constraint ``i`` on); 0 for an empty working set."""
    worst = 0.0
    size = 0.0
    empty = True
    for i in range(ws.size):
        if ws[i] != 0:
            b = hi[i] if ws[i] > 0 else lo[i]
            worst = max(worst, abs(r[i] - b))
            size = max(size, abs(b))
            empty = False
    return 0.0 if empty else worst / (1.0 + size)


@njit(cache=True, error_model="numpy")
def stationarity(H: np.ndarray, g: np.ndarray, A: np.ndarray, u: np.ndarray, lam_x: np.ndarray,
                 lam_a: np.ndarray) -> float:
    """``max |H u + g + lam_x + Aᵀ lam_a|`` relative to ``1 + max(|H||u| + |g| + |lam_x| + |A|ᵀ|lam_a|)``,
    the size of the terms whose rounding it measures."""
    n, m = u.size, lam_a.size
    stat = np.empty(n)
    scale = np.empty(n)
    for i in range(n):
        s = g[i] + lam_x[i]
        t = abs(g[i]) + abs(lam_x[i])
        for j in range(n):
            s += H[i, j] * u[j]
            t += abs(H[i, j]) * abs(u[j])
        stat[i] = s
        scale[i] = t
    for r in range(m):
        lr = lam_a[r]
        if lr != 0.0:
            for i in range(n):
                stat[i] += A[r, i] * lr
                scale[i] += abs(A[r, i]) * abs(lr)
    return np.max(np.abs(stat)) / (1.0 + np.max(scale))


@njit(cache=True, error_model="numpy")
def chol_solve(L: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``x`` with ``L Lᵀ x = b`` (``L`` lower triangular): forward, then backward substitution."""
    n = b.size
    y = np.empty(n)
    for i in range(n):
        s = b[i]
        for k in range(i):
            s -= L[i, k] * y[k]
        y[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):
        s = y[i]
        for k in range(i + 1, n):
            s -= L[k, i] * y[k]
        y[i] = s / L[i, i]
    return y


@njit(cache=True, error_model="numpy")
def eqp(Linv: np.ndarray, H: np.ndarray, g: np.ndarray, A: np.ndarray, lo: np.ndarray, hi: np.ndarray,
        ws: np.ndarray, v: np.ndarray, u: np.ndarray, lam_full: np.ndarray) -> bool:
    """Fill ``u`` (n,) and ``lam_full`` (n + m,) with the solution of ``min ½uᵀHu + gᵀu`` under the working
    set's constraints as equalities; False if its rows are dependent (or the result is not finite).

    Range-space method: with ``H = L Lᵀ``, ``Y = L⁻¹ C_Wᵀ`` and ``v = L⁻¹ g``, the multipliers solve
    ``(YᵀY) λ = −(b_W + Yᵀv)`` and ``u = −L⁻ᵀ (v + Y λ)``; up to two steps of iterative refinement on the
    KKT residual follow, with the same factors (``YᵀY`` has a condition number up to ~1e14 with ~100
    active rows; the steps bring the working-set residual from ~1e-6 to ~1e-11).
    """
    n = H.shape[0]
    lam_full[:] = 0.0
    idx = np.nonzero(ws)[0]
    w = idx.size
    if w == 0:
        u[:] = -np.dot(Linv.T, v)
        return True
    b = np.empty(w)
    nb = 0
    for t in range(w):
        b[t] = hi[idx[t]] if ws[idx[t]] > 0 else lo[idx[t]]
        if idx[t] < n:
            nb += 1
    bnd = idx[:nb]
    Ar = np.empty((w - nb, n))
    for t in range(w - nb):
        Ar[t] = A[idx[nb + t] - n]
    Y = np.empty((n, w))
    for t in range(nb):
        Y[:, t] = Linv[:, bnd[t]]
    Y[:, nb:] = np.dot(Linv, Ar.T)
    try:
        Ls = np.linalg.cholesky(np.dot(Y.T, Y))
    except Exception:  # noqa: BLE001 - numba raises LinAlgError: the working set's rows are dependent
        return False
    lam = chol_solve(Ls, -(b + np.dot(Y.T, v)))
    u[:] = -np.dot(Linv.T, v + np.dot(Y, lam))
    b_scale = 1e-12 * (1.0 + np.max(np.abs(b)))
    r2 = np.empty(w)
    for _ in range(2):  # refinement: solve the KKT system for its residual with the same factors
        for t in range(nb):
            r2[t] = b[t] - u[bnd[t]]
        r2[nb:] = b[nb:] - np.dot(Ar, u)
        if np.max(np.abs(r2)) <= b_scale:
            break
        r1 = -(g + np.dot(H, u) + np.dot(Ar.T, lam[nb:].copy()))
        for t in range(nb):
            r1[bnd[t]] -= lam[t]
        wv = np.dot(Linv, r1)
        dlam = chol_solve(Ls, np.dot(Y.T, wv) - r2)
        u += np.dot(Linv.T, wv - np.dot(Y, dlam))
        lam += dlam
    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(lam))):
        return False
    for t in range(w):
        lam_full[idx[t]] = lam[t]
    return True


@njit(cache=True, error_model="numpy")
def certify(Linv: np.ndarray, H: np.ndarray, g: np.ndarray, A: np.ndarray, lo: np.ndarray, hi: np.ndarray,
            eq: np.ndarray, tol: np.ndarray, max_repairs: int, max_repair_rows: int, ws: np.ndarray, u: np.ndarray,
            lam_full: np.ndarray) -> bool:
    """Solve the equality-constrained QP on the working set ``ws`` (int8, n + m; updated in place) and
    certify it (:meth:`CertifiedQP._try <ftc_mj.control.certified_qp.CertifiedQP._try>`): True with ``u``,
    ``lam_full`` and the final working set (equality rows cleared) when optimal.

    ``tol`` = (primal, dual, working-set, stationarity) tolerances. Certificate, in this order: working-set
    residual (refused), primal feasibility (repaired: every violated constraint added, unless more than
    ``max_repair_rows``), multiplier signs (repaired: the worst-signed one dropped), stationarity (refused);
    at most ``max_repairs`` repairs.
    """
    n, m = H.shape[0], A.shape[0]
    primal_tol, dual_tol, ws_tol, stat_tol = tol[0], tol[1], tol[2], tol[3]
    for r in range(m):
        if eq[r]:
            ws[n + r] = 1
    v = np.dot(Linv, g)
    rr = np.empty(n + m)
    for _ in range(1 + max_repairs):
        if not eqp(Linv, H, g, A, lo, hi, ws, v, u, lam_full):
            return False
        rr[:n] = u
        rr[n:] = np.dot(A, u)
        if ws_residual(rr, lo, hi, ws) > ws_tol:
            return False  # u is not on its working set: the refinement did not converge
        n_bad = 0
        for i in range(n + m):
            if max(rr[i] - hi[i], lo[i] - rr[i]) > primal_tol:
                n_bad += 1
        if n_bad:
            if n_bad > max_repair_rows:
                return False  # far from this working set: not worth repairing
            for i in range(n + m):
                over = rr[i] - hi[i]
                if max(over, lo[i] - rr[i]) > primal_tol:
                    ws[i] = 1 if over > 0 else -1
            continue
        lam_scale = 1.0 + np.max(np.abs(lam_full))
        worst, at = 0.0, -1
        for i in range(n + m):
            if ws[i] != 0 and (i < n or not eq[i - n]):
                s = lam_full[i] * ws[i]
                if at < 0 or s < worst:
                    worst, at = s, i
        if at >= 0 and worst < -dual_tol * lam_scale:
            ws[at] = 0
            continue
        if stationarity(H, g, A, u, lam_full[:n], lam_full[n:]) > stat_tol:
            return False
        for r in range(m):
            if eq[r]:
                ws[n + r] = 0
        return True
    return False


@njit(cache=True, error_model="numpy")
def tri_inv(L: np.ndarray) -> np.ndarray:
    """The inverse (lower triangular) of the lower triangular ``L`` (n, n), row by row (``X[i, :i] =
    −L[i, :i] X[:i, :i] / L[i, i]``, accumulated along rows of ``X``: contiguous inner loops)."""
    n = L.shape[0]
    X = np.zeros((n, n))
    acc = np.empty(n)
    for i in range(n):
        acc[:i] = 0.0
        for k in range(i):
            lik = L[i, k]
            for j in range(k + 1):
                acc[j] += lik * X[k, j]
        r = 1.0 / L[i, i]
        for j in range(i):
            X[i, j] = -acc[j] * r
        X[i, i] = r
    return X


@njit(cache=True, error_model="numpy")
def arrow_inverse_factor(H: np.ndarray, s: int, nv: int, F: np.ndarray) -> bool:
    """Fill ``F`` (n, n) with ``F⁻¹`` for a factor ``H = F Fᵀ`` of the multi-stage QP's Hessian; False if
    ``H`` is not positive definite.

    ``H`` couples the shared inputs ``z[:s]`` with every scenario's own block ``z[s + i nv : s + (i+1) nv]``,
    and the scenarios' blocks not with each other (an arrow). Ordered scenarios first, shared last, its
    Cholesky factor has no fill: ``L_ii = chol(H_ii)``, ``L_si = H_si L_ii⁻ᵀ``, ``L_ss = chol(H_ss − Σ L_si
    L_siᵀ)``, and so has its inverse: ``L_ii⁻¹`` on the diagonal, ``−L_ss⁻¹ L_si L_ii⁻¹`` in the last block
    row. ``F⁻¹`` is that inverse with its columns in ``z``'s order (the range-space solve of :func:`eqp`
    needs any factor of ``H``; this one costs ~S (nv³/2) flops instead of the dense ``n³/2``)."""
    S = 0 if nv == 0 else (H.shape[0] - s) // nv  # every input shared (robust horizon = all nodes): no arrow
    F[:] = 0.0
    Sc = H[:s, :s].copy()
    for i in range(S):
        o = s + i * nv
        try:
            Lii = np.linalg.cholesky(H[o:o + nv, o:o + nv].copy())
        except Exception:  # noqa: BLE001 - numba raises LinAlgError: not positive definite
            return False
        Li = tri_inv(Lii)
        Lsi = np.dot(H[o:o + nv, :s].T.copy(), Li.T)  # H_si L_ii⁻ᵀ, H_si read from the lower triangle
        Sc -= np.dot(Lsi, Lsi.T)
        F[o:o + nv, o:o + nv] = Li
        F[:s, o:o + nv] = np.dot(Lsi, Li)
    try:
        Lss = np.linalg.cholesky(Sc)
    except Exception:  # noqa: BLE001 - as above
        return False
    Ls = tri_inv(Lss)
    F[:s, :s] = Ls
    for i in range(S):
        o = s + i * nv
        F[:s, o:o + nv] = -np.dot(Ls, F[:s, o:o + nv].copy())
    return True
