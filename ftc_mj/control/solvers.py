"""Calling CasADi solvers from numpy: buffered evaluation, warm-started IPOPT, default options."""

from __future__ import annotations

import numpy as np

from ..lazy import lazy_module

ca = lazy_module("casadi")


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



def ipopt_options(max_iter: int, cold_time_budget: float | None, time_budget: float | None) -> dict:
    """Options of an MPC's IPOPT ``nlpsol``: quiet, at most ``max_iter`` iterations, warm-started, and its
    wall time capped at the larger of the budgets (s) given."""
    opts = {
        "print_time": False,
        "ipopt.print_level": 0,
        "ipopt.sb": "yes",
        "ipopt.max_iter": max_iter,
        "ipopt.warm_start_init_point": "yes",
        "ipopt.mu_init": 1e-4,
        "ipopt.tol": 1e-8,
        "error_on_fail": False,
    }
    budgets = [b for b in (cold_time_budget, time_budget) if b is not None]
    if budgets:
        opts["ipopt.max_wall_time"] = max(budgets)
    return opts


def default_qp_options(qpsol: str) -> dict:
    """Options of the CasADi QP plugin ``qpsol`` for the RTI QPs: quiet, no exception on failure, warm starts
    (OSQP: tolerances 1e-6, at most 4000 iterations)."""
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

