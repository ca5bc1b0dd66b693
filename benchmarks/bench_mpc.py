"""Benchmark of the MPCs on the kinematic plant (BASELINES §2 loop), printed as a markdown table.

Loop: 30 s at 10 Hz, RK4 plant (10 ms substeps) under ZOH, start (0, −5, 0) i.e. 5 m off the
default circle (R = 50 m, 10 m/s), R_L steps 2 → 1 m at t = 10 s and the MPC is given the true
radii. Columns: build time, first (cold) solve, warm solve median/p95/max (all samples after the
first), iterations, fallbacks, time to |cross-track| < 0.1 m, tracking RMS/max for t > 5 s.

Usage: ``.venv/bin/python benchmarks/bench_mpc.py [--duration 30] [--skip-opti]``
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from ftc_mj.config import RunConfig  # noqa: E402
from ftc_mj.control import NMPC, LinearMPC, OptiNMPC, build_reference, problem_spec  # noqa: E402
from ftc_mj.control.base import ControlOutput  # noqa: E402
from ftc_mj.control.collocation import Collocation, reference_at_nodes  # noqa: E402
from ftc_mj.control.kinsim import simulate  # noqa: E402


def left_step(t: float) -> tuple[float, float]:
    return (2.0, 1.0) if t >= 10.0 else (2.0, 2.0)


class OptiController:
    """Plain CasADi Opti + IPOPT build of the same NLP, warm-started with the shifted previous plan."""

    def __init__(self, spec, reference) -> None:
        self.opti = OptiNMPC(spec)
        self.col = Collocation(spec)
        self.reference = reference
        self.failures = 0
        self._plan = None

    def solve(self, t, pose, radii) -> ControlOutput:
        t0 = time.perf_counter()
        ref, psi = reference_at_nodes(self.reference, self.col.times(t), pose[2])
        x0 = np.array([pose[0], pose[1], psi])
        if self._plan is None:
            Xg, Ug = ref[:3].T, np.zeros((self.col.N, 2)) + 5.0
        else:
            Xg, Ug = self.col.shift(*self._plan, t, 1.0, radii)
        X, U, it = self.opti.solve(x0, radii, ref, Xg, Ug)
        self._plan = (t, X, U)
        return ControlOutput(omega=U[0], iterations=it, solve_time=time.perf_counter() - t0,
                             predicted=X, predicted_t=self.col.times(t), predicted_omega=U)


def row(name: str, build: float, res, ctl) -> str:
    st = res.solve_times * 1e3
    warm = st[1:]
    its = np.array([o.iterations for o in res.outputs[1:]])
    bad = np.nonzero(np.abs(res.cross_track) >= 0.1)[0]
    bad = bad[res.t[bad] < 10.0]
    t01 = res.t[bad[-1] + 1] if len(bad) else 0.0
    return (f"| {name} | {build:.2f} | {st[0]:.1f} | **{np.median(warm):.2f}** | {np.percentile(warm, 95):.2f} | "
            f"{warm.max():.1f} | {int(np.median(its))}/{its.max()} | {ctl.failures} | {t01:.2f} | "
            f"{res.rms_error(5.0):.1e} | {res.max_abs_error(5.0):.1e} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=30.0)
    ap.add_argument("--skip-opti", action="store_true")
    args = ap.parse_args()
    cfg = RunConfig()
    cfg.controller.time_budget = 10.0  # measure, don't fall back
    ref = build_reference(cfg)
    spec = problem_spec(cfg)
    rows = []
    for solver in ("rti-daqp", "rti-qpoases", "rti-osqp", "ipopt"):
        t0 = time.perf_counter()
        ctl = NMPC(spec, ref, solver=solver, time_budget=10.0)
        build = time.perf_counter() - t0
        res = simulate(ctl, ref, args.duration, (0.0, -5.0, 0.0), true_radii=left_step)
        rows.append(row(f"NMPC {solver}", build, res, ctl))
    if not args.skip_opti:
        t0 = time.perf_counter()
        ctl = OptiController(spec, ref)
        build = time.perf_counter() - t0
        res = simulate(ctl, ref, args.duration, (0.0, -5.0, 0.0), true_radii=left_step)
        rows.append(row("plain Opti + IPOPT (expand)", build, res, ctl))
    for qp in ("daqp", "qpoases", "osqp"):
        t0 = time.perf_counter()
        ctl = LinearMPC(spec, ref, qpsol=qp, time_budget=10.0)
        build = time.perf_counter() - t0
        res = simulate(ctl, ref, args.duration, (0.0, -5.0, 0.0), true_radii=left_step)
        rows.append(row(f"LMPC {qp}", build, res, ctl))
    print(f"\nMPC benchmark: {args.duration:.0f} s at 10 Hz, N={spec.nodes}, T={spec.horizon} s, 5 m initial offset, "
          f"R_L 2→1 m at 10 s (true radii). Times in ms unless noted; load avg {os.getloadavg()[0]:.2f}.\n")
    print("| controller | build s | first ms | warm median ms | warm p95 ms | warm max ms | iters med/max "
          "| fallbacks | t(|e|<0.1 m) s | RMS |e| t>5 s (m) | max |e| t>5 s (m) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(r)


if __name__ == "__main__":
    main()
