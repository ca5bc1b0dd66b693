"""do-mpc's robust multi-stage MPC and its nominal MPC on the kinematic robot, scenario 2: the reference
points for the robust and the nominal NMPC's rows of ``bench_mpc.py --robust``.

Standalone (numpy, casadi, do-mpc only; do-mpc is not a dependency of ftc-mj): run it in a venv that
has do-mpc, e.g. ``python -m venv /tmp/dompc && /tmp/dompc/bin/pip install do-mpc`` and
``/tmp/dompc/bin/python benchmarks/dompc_multistage.py [--nominal]`` (prints one JSON line).
``bench_mpc.py --robust`` calls :func:`run` when ``do_mpc`` imports, runs this script with
``--dompc-python PYTHON`` in the same session when given, and otherwise prints :data:`MEASURED`.

Problem: the kinematic differential drive (half track 1 m, R_R = 2 m) tracking the default circle
(50 m, 10 m/s, counter-clockwise) with the NMPC's weights (pose 10, speed 1, yaw rate 1; do-mpc
requires an ``rterm``: 1e-3 on the per-step input change), inputs within ±1000 deg/s; horizon 5 s as 50
steps of 0.1 s (do-mpc's default orthogonal collocation, degree 2); the uncertain left radius
R_L ∈ {2, 1} m with robust horizon 1 (``n_robust = 1``). Closed loop: exact plant (RK4, 10 substeps),
R_L steps 2 → 1 m at t = 10 s, 25 s; the controller's scenario set contains the true radii. ``--nominal``:
the same MPC told the nominal R_L = 2 m only (one scenario, ``n_robust = 0``), as the nominal NMPC row is.
"""

from __future__ import annotations

import math
import time

import numpy as np

MEASURED = {
    "date": "2026-12-03",
    "solve_ms_median": 38.2,
    "solve_ms_p95": 44.0,
    "pre_fault_offset_m": -0.44,
    "max_error_after_fault_m": 1.75,
    "load": "0.67",
}
"""Numbers of :func:`run` (multi-stage) measured on this project's 2-core machine (do-mpc 5.1.2, CasADi 3.8.2),
copied from ``bench_mpc.py --robust --dompc-python`` on an idle machine; the nominal MPC measured 28.9 ms
(p95 36.2 ms) in the same session."""

B, RR, V_REF, RADIUS = 1.0, 2.0, 10.0, 50.0
OMEGA_MAX = math.radians(1000.0)


def _reference(t: np.ndarray) -> tuple[np.ndarray, ...]:
    """Circle through the origin heading +x, centre (0, 50): x, y, psi, V, psidot at times ``t`` (s)."""
    w = V_REF / RADIUS
    return (RADIUS * np.sin(w * t), RADIUS * (1 - np.cos(w * t)), w * t, np.full_like(t, V_REF), np.full_like(t, w))


def _rates(x: np.ndarray, u: np.ndarray, r_l: float) -> np.ndarray:
    V = 0.5 * (RR * u[0] + r_l * u[1])
    return np.array([V * math.cos(x[2]), V * math.sin(x[2]), (RR * u[0] - r_l * u[1]) / (2 * B)])


def build(n_horizon: int = 50, t_step: float = 0.1, robust: bool = True):
    """The do-mpc multi-stage MPC (robust horizon 1, R_L ∈ {2, 1} m), or (``robust=False``) the nominal MPC
    (R_L = 2 m)."""
    import casadi as ca
    import do_mpc

    model = do_mpc.model.Model("continuous")
    model.set_variable("_x", "x")
    model.set_variable("_x", "y")
    psi = model.set_variable("_x", "psi")
    wr = model.set_variable("_u", "omega_R")
    wl = model.set_variable("_u", "omega_L")
    r_l = model.set_variable("_p", "R_L")
    for n in ("x_ref", "y_ref", "psi_ref", "V_ref", "r_ref"):
        model.set_variable("_tvp", n)
    V = 0.5 * (RR * wr + r_l * wl)
    r = (RR * wr - r_l * wl) / (2 * B)
    model.set_rhs("x", V * ca.cos(psi))
    model.set_rhs("y", V * ca.sin(psi))
    model.set_rhs("psi", r)
    model.setup()
    mpc = do_mpc.controller.MPC(model)
    mpc.settings.n_horizon = n_horizon
    mpc.settings.t_step = t_step
    mpc.settings.n_robust = 1 if robust else 0
    mpc.settings.store_full_solution = False
    mpc.settings.nlpsol_opts = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes"}
    mx, mu, mp, mt = model.x, model.u, model.p, model.tvp  # the symbols as rebuilt by model.setup()
    Vm = 0.5 * (RR * mu["omega_R"] + mp["R_L"] * mu["omega_L"])
    rm = (RR * mu["omega_R"] - mp["R_L"] * mu["omega_L"]) / (2 * B)
    err = (10.0 * ((mx["x"] - mt["x_ref"]) ** 2 + (mx["y"] - mt["y_ref"]) ** 2 + (mx["psi"] - mt["psi_ref"]) ** 2)
           + (Vm - mt["V_ref"]) ** 2 + (rm - mt["r_ref"]) ** 2)
    mpc.set_objective(lterm=err, mterm=ca.DM(0))
    mpc.set_rterm(omega_R=1e-3, omega_L=1e-3)
    for name in ("omega_R", "omega_L"):
        mpc.bounds["lower", "_u", name] = -OMEGA_MAX
        mpc.bounds["upper", "_u", name] = OMEGA_MAX
    mpc.set_uncertainty_values(R_L=np.array([2.0, 1.0] if robust else [2.0]))
    tvp = mpc.get_tvp_template()

    def tvp_fun(t_now):
        ts = t_now + t_step * np.arange(n_horizon + 1)
        vals = _reference(ts)
        for k in range(n_horizon + 1):
            for name, v in zip(("x_ref", "y_ref", "psi_ref", "V_ref", "r_ref"), vals, strict=True):
                tvp["_tvp", k, name] = v[k]
        return tvp

    mpc.set_tvp_fun(tvp_fun)
    mpc.setup()
    return mpc


def run(duration: float = 25.0, robust: bool = True) -> dict:
    """Closed loop of scenario 2 (module docstring). Returns the solve times and the tracking numbers."""
    mpc = build(robust=robust)
    x = np.zeros(3)
    mpc.x0 = x
    mpc.u0 = np.array([5.1, 4.9])
    mpc.set_initial_guess()
    dt, n_sub = 0.1, 10
    times, ctes, solve = [], [], []
    for k in range(int(round(duration / dt))):
        t = k * dt
        t0 = time.perf_counter()
        u = np.asarray(mpc.make_step(x.reshape(3, 1))).ravel()
        solve.append(time.perf_counter() - t0)
        for i in range(n_sub):
            r_l = 1.0 if t + i * dt / n_sub >= 10.0 else 2.0
            h = dt / n_sub
            k1 = _rates(x, u, r_l)
            k2 = _rates(x + 0.5 * h * k1, u, r_l)
            k3 = _rates(x + 0.5 * h * k2, u, r_l)
            k4 = _rates(x + h * k3, u, r_l)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            times.append(t + (i + 1) * h)
            ctes.append(RADIUS - math.hypot(x[0], x[1] - RADIUS))
    t_arr, e = np.array(times), np.array(ctes)
    st = np.array(solve[1:]) * 1e3
    return {"solve_ms_median": float(np.median(st)), "solve_ms_p95": float(np.percentile(st, 95)),
            "pre_fault_offset_m": float(np.mean(e[(t_arr >= 5) & (t_arr < 10)])),
            "max_error_after_fault_m": float(np.max(np.abs(e[t_arr >= 10]))), "final_m": float(e[-1])}


if __name__ == "__main__":
    import json
    import os
    import sys

    res = run(robust="--nominal" not in sys.argv[1:])
    print(json.dumps({**res, "load": f"{os.getloadavg()[0]:.2f}"}))
