"""Benchmark of the MPCs on the kinematic plant, printed as a markdown table.

Loop: 30 s at 10 Hz, RK4 plant (10 ms substeps) under ZOH, start (0, −5, 0) i.e. 5 m off the
default circle (R = 50 m, 10 m/s), R_L steps 2 → 1 m at t = 10 s and the MPC is given the true
radii (the path-following NMPC, ``pf-nmpc``, on the same loop with its default settings and the
actuation-rate term 1). Columns: build time, first (cold) solve, warm solve median/p95/max (all samples after the
first), iterations, fallbacks, largest change of the command between samples, time to
|cross-track| < 0.1 m, tracking RMS/max for t > 5 s. Every MPC runs twice, with the first-step bound
``|U(t0) − u_applied| ≤ omega_rate_max T_s`` (``bound``, the default) and with the first input free
(``free``, ``controller.rate_bound_from_applied = false``), in alternating order.

``--qp``: per-QP time of the RTI QP, old path (CasADi daqp plugin alone) vs new (certified active
set, :mod:`ftc_mj.control.certified_qp`), on QPs recorded from the well-behaved loop above and from a
saturated loop (the model is told swapped radii, so ~90 of the 100 inputs' bounds are active);
each QP is solved by both paths back to back, in alternating order.

``--kernels``: per RTI step (build, certified solve, checks; CPU time), the compiled kernels
(:mod:`ftc_mj.control.kernels`) against their numpy reference (``tests/support/numpy_rti.py``, the package's
code before it was compiled) on the same recorded steps, replayed back to back in alternating order: the
nominal NMPC's QP on the well-behaved and the saturated loop of ``--qp``, and the 4-scenario multi-stage QP
(the hybrid/passive methods' controller) on the kinematic scenario-2 loop of ``--robust``.

``--runs R``: whole-run wall times of three MuJoCo runs (scenario4 and scenario2 with UKF, direct
radius feedback and the NMPC — they leave the path and saturate the wheels — and scenario2 with
``sensors.yaw_rate_sigma`` 0.01), old and new path alternated R times in one process; medians.

``--robust``: the robust multi-stage NMPC (:mod:`ftc_mj.control.robust`) against the nominal NMPC on
the kinematic scenario 2 loop of the robust NMPC's acceptance test (start on the path, R_L 2 → 1 m at
10 s, every controller told the nominal radii, the paper's cost), and against do-mpc's multi-stage MPC
and nominal MPC on the same loop (``benchmarks/dompc_multistage.py``: run here when ``do_mpc`` imports, or
in the same session by ``--dompc-python PYTHON``, a Python that has do-mpc; else the multi-stage number
measured on this machine is printed with its date), with the nominal RTI NMPC's per-solve ratio to do-mpc's
nominal MPC.

``--degraded``: the path-following NMPC's degraded mode (:mod:`ftc_mj.reconfiguration.degraded`) on the
loop above: from the fault at 10 s the controller is handed the left wheel's interval
``[min_radius, 2 m]`` (the default ``reconfiguration.degraded.min_radius`` 0.05 m, the right wheel at its
point 2 m), so its lateral-acceleration rows hold at the interval's corners; RTI and IPOPT, solve-time
median/p95 before and after 10 s (the first sample after 10 s apart: it builds the interval
solvers), beside the same loop without the interval (nominal), in one process.

``--rate-bound R``: the same three 40 s MuJoCo runs plus scenario 2 without feedback, with the
first-step bound and with the first input free, alternated R times in one process; medians of wall
time and of the runs' solve-time median/p95, with the largest command step, solver failures and
cross-track maximum of each formulation.

Usage: ``.venv/bin/python benchmarks/bench_mpc.py [--duration 30] [--skip-opti] [--skip-table] [--qp] [--kernels]
[--runs 3] [--rate-bound 3] [--robust [--dompc-python PYTHON]] [--degraded]``
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import sys  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the test oracles: tests.support

import argparse  # noqa: E402
import contextlib  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402
from collections.abc import Iterator  # noqa: E402

import numpy as np  # noqa: E402

from ftc_mj.config import RunConfig  # noqa: E402
from ftc_mj.control import NMPC, LinearMPC  # noqa: E402
from ftc_mj.control.base import ControlOutput  # noqa: E402
from ftc_mj.control.condensed_qp import CondensedQP  # noqa: E402
from ftc_mj.control.robust import RobustNMPC  # noqa: E402
from ftc_mj.control.tracking import reference_at_nodes  # noqa: E402
from ftc_mj.control.transcription import Collocation  # noqa: E402
from ftc_mj.wiring.control import build_reference, problem_spec  # noqa: E402
from tests.support.kinsim import simulate  # noqa: E402
from tests.support.opti_nmpc import OptiNMPC  # noqa: E402


def left_step(t: float) -> tuple[float, float]:
    return (2.0, 1.0) if t >= 10.0 else (2.0, 2.0)


class OptiController:
    """Plain CasADi Opti + IPOPT build of the same NLP (with the first-step bound), warm-started with the
    shifted previous plan."""

    def __init__(self, spec, reference) -> None:
        self.opti = OptiNMPC(spec)
        self.col = Collocation(spec)
        self.reference = reference
        self.failures = 0
        self._plan = None

    def solve(self, t, pose, radii, u_applied=None) -> ControlOutput:
        t0 = time.perf_counter()
        ref, psi = reference_at_nodes(self.reference, self.col.times(t), pose[2])
        x0 = np.array([pose[0], pose[1], psi])
        if self._plan is None:
            Xg, Ug = ref[:3].T, np.zeros((self.col.N, 2)) + 5.0
        else:
            Xg, Ug = self.col.shift(*self._plan, t, 1.0, radii)
        X, U, it = self.opti.solve(x0, radii, ref, Xg, Ug, u_applied)
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
    step = np.abs(np.diff([o.omega for o in res.outputs], axis=0)).max()
    return (f"| {name} | {build:.2f} | {st[0]:.1f} | **{np.median(warm):.2f}** | {np.percentile(warm, 95):.2f} | "
            f"{warm.max():.1f} | {int(np.median(its))}/{its.max()} | {ctl.failures} | {step:.2f} | {t01:.2f} | "
            f"{res.rms_error(5.0):.1e} | {res.max_abs_error(5.0):.1e} |")


def record_qps(ctl: NMPC, ref, duration: float, pose, true_radii, model_radii=None) -> list[list[np.ndarray]]:
    """QP data ``[H, g, E, e, Lv, ll, lu, Lo]`` of every RTI step of a kinematic closed loop of ``ctl``."""
    with ctl._qp.recording() as rec:
        simulate(ctl, ref, duration, pose, true_radii=true_radii, model_radii=model_radii)
    return rec


def replay_qps(qp: CondensedQP, qps: list[list[np.ndarray]]) -> dict:
    """Solve every recorded QP with the plugin (old) and the certified path (new, guesses chained
    as in the loop), back to back in alternating order. Times in ms; max |u_new − u_old| (rad/s)."""
    n, na = qp.nu, qp._lam_a.size
    t_old, t_new, du = [], [], []
    qp.reset()
    qp.path_counts.clear()
    qp.certified = True  # the "new" path; "old" calls the plugin directly

    def old(q):
        t0 = time.perf_counter()
        u = qp._qpfun(*q, np.zeros(n), np.zeros(n), np.zeros(na))[0].copy()
        t_old.append(time.perf_counter() - t0)
        return u

    def new(q):
        t0 = time.perf_counter()
        ok, _, u, _, _ = qp.solve_qp(*q, np.zeros(n))  # the production dispatch: certified, else the plugin
        if not ok:
            qp._ws = None
        t_new.append(time.perf_counter() - t0)
        return u.copy() if ok and qp._ws is not None else None  # compared only where the certified path decided

    for i, q in enumerate(qps):
        if i % 2:
            u_new, u_old = new(q), old(q)
        else:
            u_old, u_new = old(q), new(q)
        if u_new is not None and qp._qpfun.ret == 0 and qp._qpfun.stats().get("success", True):
            du.append(np.abs(u_new - u_old).max())
    return {"old": np.array(t_old) * 1e3, "new": np.array(t_new) * 1e3, "du": np.array(du),
            "paths": dict(qp.path_counts)}


def qp_table(spec, ref, duration: float) -> None:
    """Per-QP time, old vs new, on the well-behaved and a saturated loop (printed)."""
    cases = {
        "well-behaved (the loop above)": ((0.0, -5.0, 0.0), left_step, None),
        "saturated (model told swapped radii)": ((0.0, 0.0, 0.0), lambda t: (1.0, 2.0), lambda t: (2.0, 1.0)),
    }
    print("\nPer-QP time of the RTI QP (ms), old = CasADi daqp plugin alone, new = certified active set; "
          f"{duration:.0f} s loops.\n")
    print("| loop | QPs | old median | old p90 | old total | new median | new p90 | new total | "
          "new decided by | max abs du (rad/s) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name, (pose, true_r, model_r) in cases.items():
        ctl = NMPC(spec, ref, solver="rti-daqp", time_budget=None, cold_time_budget=None, max_iter=300)
        ctl._qp.certified = False
        qps = record_qps(ctl, ref, duration, pose, true_r, model_r)
        r = replay_qps(ctl._qp, qps)
        o, nw = r["old"], r["new"]
        print(f"| {name} | {len(qps)} | {np.median(o):.2f} | {np.percentile(o, 90):.2f} | {o.sum():.0f} | "
              f"**{np.median(nw):.2f}** | {np.percentile(nw, 90):.2f} | {nw.sum():.0f} | {r['paths']} | "
              f"{r['du'].max():.1e} |")


def _replay(compiled, reference, calls: list[tuple]) -> tuple[np.ndarray, np.ndarray]:
    """Per-step CPU times (ms) of ``compiled.solve`` and ``reference.solve`` on the same calls, alternating which goes
    first; each keeps its own working-set guesses, from a reset."""
    compiled.reset()
    reference.reset()
    compiled.path_counts.clear()
    tc, tr = [], []
    for i, args in enumerate(calls):
        for which in ((compiled, tc), (reference, tr)) if i % 2 == 0 else ((reference, tr), (compiled, tc)):
            t0 = time.process_time()  # CPU time: the machine may be shared
            which[0].solve(*args)
            which[1].append(time.process_time() - t0)
    return np.array(tc) * 1e3, np.array(tr) * 1e3


def kernel_table(spec, ref, duration: float) -> None:
    """Per RTI step, compiled kernels against the numpy reference, on recorded steps (printed)."""
    from tests.support.numpy_rti import NumpyCondensedQP, NumpyMultiStageQP, recorded_calls

    free = {"time_budget": None, "cold_time_budget": None, "max_iter": 300}
    cases = {
        "NMPC, well-behaved (the loop above)": ((0.0, -5.0, 0.0), left_step, None),
        "NMPC, saturated (model told swapped radii)": ((0.0, 0.0, 0.0), lambda t: (1.0, 2.0), lambda t: (2.0, 1.0)),
    }
    rows = []
    for name, (pose, true_r, model_r) in cases.items():
        ctl = NMPC(spec, ref, solver="rti-daqp", **free)
        calls = recorded_calls(ctl._qp, "solve", lambda ctl=ctl, pose=pose, true_r=true_r, model_r=model_r: simulate(
            ctl, ref, duration, pose, true_radii=true_r, model_radii=model_r))
        rows.append((name, len(calls), *_replay(ctl._qp, NumpyCondensedQP(ctl.col, "daqp"), calls),
                     dict(ctl._qp.path_counts)))
    four = [(1.0, 1.0), (0.5, 1.0), (1.0, 0.5), (0.5, 0.5)]
    ctl = RobustNMPC(spec, ref, four, **free)
    sq = ctl._stage_qp
    calls = recorded_calls(sq, "solve", lambda: simulate(ctl, ref, min(duration, 25.0), (0.0, 0.0, 0.0),
                                                         true_radii=left_step, model_radii=lambda t: (2.0, 2.0)))
    rows.append(("multi-stage, 4 scenarios (robust --robust loop)", len(calls),
                 *_replay(sq, NumpyMultiStageQP(NumpyCondensedQP(ctl.col, "daqp"), sq.S, sq.k), calls),
                 dict(sq.path_counts)))
    print(f"\nPer RTI step (build, certified solve, checks), CPU ms: compiled kernels against the numpy reference "
          f"on the same steps, alternating; {duration:.0f} s loops; load avg {os.getloadavg()[0]:.2f}.\n")
    print("| QP | steps | compiled median | compiled p90 | numpy median | numpy p90 | numpy / compiled (median) "
          "| decided by |")
    print("|---|---|---|---|---|---|---|---|")
    for name, n, tc, tr, paths in rows:
        print(f"| {name} | {n} | **{np.median(tc):.2f}** | {np.percentile(tc, 90):.2f} | {np.median(tr):.2f} | "
              f"{np.percentile(tr, 90):.2f} | {np.median(tr) / np.median(tc):.1f}× | {paths} |")


@contextlib.contextmanager
def qp_path(certified: bool, clock: Counter) -> Iterator[None]:
    """Every CondensedQP built inside uses the given path; QP and IPOPT wall times go to ``clock`` (s)."""
    from ftc_mj.control import nmpc

    init, ipopt = CondensedQP.__init__, nmpc.NMPC._ipopt

    def timed(f, key):
        def g(*a, **k):
            t0 = time.perf_counter()
            try:
                return f(*a, **k)
            finally:
                clock[key] += time.perf_counter() - t0
                clock[key + "_calls"] += 1
        return g

    def init2(self, *a, **k):
        init(self, *a, **k)
        self.certified = certified
        f = self._qpfun  # the plugin: old path, and the new path's fallback
        self._qpfun = type("TimedQP", (), {"__call__": staticmethod(timed(f, "qp")), "stats": staticmethod(f.stats),
                                           "ret": property(lambda _: f.ret)})()
        self._solve_certified = timed(self._solve_certified, "qp")

    from ftc_mj.sim import cache

    cache.clear()  # controllers are cached per process: build them under the patch
    CondensedQP.__init__ = init2
    nmpc.NMPC._ipopt = timed(ipopt, "ipopt")
    try:
        yield
    finally:
        CondensedQP.__init__, nmpc.NMPC._ipopt = init, ipopt
        cache.clear()


def run_table(repeats: int) -> None:
    """Whole-run wall times of the three MuJoCo runs, old and new path alternated (printed, medians)."""
    import tempfile
    from pathlib import Path

    from ftc_mj.config import load_config
    from ftc_mj.sim.run import execute

    base = {"estimator.kind": "ukf", "feedback": True, "controller.kind": "nmpc", "duration": 40.0}
    runs = {"scenario4 feedback": ("scenario4", base), "scenario2 feedback": ("scenario2", base),
            "scenario2 yaw_rate_sigma 0.01": ("scenario2", {**base, "sensors.yaw_rate_sigma": 0.01})}
    with tempfile.TemporaryDirectory() as tmp:
        execute(load_config("scenario2", {"duration": 0.5}), Path(tmp) / "w", rrd=True)  # warm-up
    res: dict = {}
    for k in range(repeats):
        for name, (sc, ov) in runs.items():
            for certified in ((False, True) if k % 2 == 0 else (True, False)):
                clock: Counter = Counter()
                with qp_path(certified, clock):
                    m = execute(load_config(sc, ov), None).metrics
                res.setdefault((name, certified), []).append(
                    (m["wall_time_s"], clock["qp"], clock["ipopt"], clock["ipopt_calls"], m["solver_failures"],
                     m["cross_track_rms"]))
    print(f"\nWhole runs (40 s), medians of {repeats}; old = plugin alone, new = certified; load avg "
          f"{os.getloadavg()[0]:.2f}.\n")
    print("| run | path | wall s | QP s | IPOPT s (calls) | solver failures | cross-track RMS m |")
    print("|---|---|---|---|---|---|---|")
    for (name, certified), v in res.items():
        a = np.array(v)
        print(f"| {name} | {'new' if certified else 'old'} | {np.median(a[:, 0]):.2f} | {np.median(a[:, 1]):.2f} | "
              f"{np.median(a[:, 2]):.2f} ({np.median(a[:, 3]):.0f}) | {np.median(a[:, 4]):.0f} | "
              f"{np.median(a[:, 5]):.1f} |")


def _dompc_rows(dompc_python: str | None) -> list[tuple[str, dict]]:
    """do-mpc's multi-stage and nominal MPC on the same loop: in this process when ``do_mpc`` imports, else
    with ``dompc_python`` (a Python that has do-mpc) running ``dompc_multistage.py`` in the same session, else
    the numbers recorded in it (:data:`dompc_multistage.MEASURED`, multi-stage only)."""
    import dompc_multistage as dm

    try:
        import do_mpc  # noqa: F401
    except ImportError:
        if dompc_python is None:
            m = dm.MEASURED
            name = f"do-mpc multi-stage, R_L in {{2, 1}} (not installed here: measured {m['date']}, load {m['load']})"
            return [(name, {**m, "solve_ms_p95": float("nan")})]
        script = str(Path(__file__).with_name("dompc_multistage.py"))
        runs = []
        for flag, name in (([], "do-mpc multi-stage, R_L in {2, 1}"), (["--nominal"], "do-mpc nominal (R_L 2 m)")):
            out = subprocess.run([dompc_python, "-W", "ignore", script, *flag], capture_output=True, text=True,
                                 check=True).stdout
            runs.append((name, json.loads(out.strip().splitlines()[-1])))
        return runs
    return [("do-mpc multi-stage, R_L in {2, 1}", dm.run()), ("do-mpc nominal (R_L 2 m)", dm.run(robust=False))]


def robust_table(duration: float, dompc_python: str | None = None) -> None:
    """Solve times and tracking of the robust NMPC next to the nominal NMPC and do-mpc (printed), and the
    nominal RTI NMPC's per-solve lead over do-mpc's nominal MPC on the same problem."""
    cfg = RunConfig()
    ref, spec = build_reference(cfg), problem_spec(cfg)
    four = [(1.0, 1.0), (0.5, 1.0), (1.0, 0.5), (0.5, 0.5)]
    left = [(1.0, 1.0), (1.0, 0.5)]
    free = {"time_budget": None, "cold_time_budget": None}  # measure, never stop IPOPT on the wall clock
    cases = [("NMPC rti-daqp (nominal radii)", lambda: NMPC(spec, ref, "rti-daqp", **free), duration),
             ("NMPC ipopt (nominal radii)", lambda: NMPC(spec, ref, "ipopt", **free), duration),
             ("robust rti-daqp, 4 scenarios", lambda: RobustNMPC(spec, ref, four, **free), duration),
             ("robust rti-daqp, {nominal, left 50 %}", lambda: RobustNMPC(spec, ref, left, **free), duration),
             ("robust ipopt, {nominal, left 50 %}", lambda: RobustNMPC(spec, ref, left, solver="ipopt", **free),
              duration)]
    rti_median: dict[str, float] = {}
    print(f"\nRobust NMPC: kinematic scenario 2 (R_L 2 -> 1 m at 10 s, nominal radii told), paper's cost; "
          f"load avg {os.getloadavg()[0]:.2f}.\n")
    print("| controller | build s | variables | warm solve median ms | p95 ms | pre-fault offset m | "
          "max abs e after fault m | fallbacks | s simulated |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, make, dur in cases:
        t0 = time.perf_counter()
        ctl = make()
        build = time.perf_counter() - t0
        res = simulate(ctl, ref, dur, (0.0, 0.0, 0.0), true_radii=left_step, model_radii=lambda t: (2.0, 2.0))
        st = res.solve_times[1:] * 1e3
        rti_median[name] = float(np.median(st))
        pre = (res.t >= 5.0) & (res.t < 10.0)
        after = f"{res.max_abs_error(10.0):.2f}" if dur > 10.0 else "—"
        print(f"| {name} | {build:.1f} | {ctl.nlp_size[0]} | **{np.median(st):.1f}** | {np.percentile(st, 95):.1f} | "
              f"{np.mean(res.cross_track[pre]):+.2f} | {after} | {ctl.failures} | {dur:.0f} |")
    medians = {}
    for name, r in _dompc_rows(dompc_python):
        medians[name] = r["solve_ms_median"]
        print(f"| {name} | — | — | **{r['solve_ms_median']:.1f}** | {r['solve_ms_p95']:.1f} | "
              f"{r['pre_fault_offset_m']:+.2f} | {r['max_error_after_fault_m']:.2f} | — | 25 |")
    nominal = medians.get("do-mpc nominal (R_L 2 m)")
    if nominal is not None:
        ours = rti_median["NMPC rti-daqp (nominal radii)"]
        print(f"\nPer warm solve, the nominal RTI NMPC against do-mpc's nominal MPC, same session: {ours:.2f} ms "
              f"against {nominal:.1f} ms, **{nominal / ours:.1f}×** (the start-up issue's target: ≥ 30×).")


def rate_bound_table(repeats: int) -> None:
    """40 s MuJoCo runs with the first-step bound and with the first input free, alternated (printed)."""
    from ftc_mj.config import load_config
    from ftc_mj.sim.run import execute

    base = {"estimator.kind": "ukf", "controller.kind": "nmpc", "duration": 40.0}
    runs = {"scenario4 feedback": ("scenario4", {**base, "feedback": True}),
            "scenario2 feedback": ("scenario2", {**base, "feedback": True}),
            "scenario2 yaw_rate_sigma 0.01, feedback": ("scenario2", {**base, "feedback": True,
                                                                     "sensors.yaw_rate_sigma": 0.01}),
            "scenario2 feedback off": ("scenario2", {**base, "feedback": False})}
    execute(load_config("scenario2", {"duration": 0.5}), None)  # warm-up: imports, numba cache, first builds
    res: dict = {}
    for k in range(repeats):
        for name, (sc, ov) in runs.items():
            for bound in ((True, False) if k % 2 == 0 else (False, True)):
                o = execute(load_config(sc, {**ov, "controller.rate_bound_from_applied": bound}), None)
                m, tr = o.metrics, o.result.trace
                cmd = np.stack([tr["omega_R_cmd"], tr["omega_L_cmd"]], axis=1)
                res.setdefault((name, bound), []).append(
                    (m["wall_time_s"], m["solve_time_ms"]["median"], m["solve_time_ms"]["p95"],
                     m["solver_failures"], np.abs(np.diff(cmd, axis=0)).max(), m["cross_track_max"]))
    print(f"\n40 s MuJoCo runs (UKF, RTI NMPC), medians of {repeats}; bound = |U(t0) - u_applied| <= "
          f"omega_rate_max T_s, free = first input free; load avg {os.getloadavg()[0]:.2f}.\n")
    print("| run | first step | wall s | solve median ms | solve p95 ms | solver failures | largest step rad/s "
          "| max cross-track m |")
    print("|---|---|---|---|---|---|---|---|")
    for (name, bound), v in res.items():
        a = np.array(v)
        print(f"| {name} | {'bound' if bound else 'free'} | {np.median(a[:, 0]):.2f} | {np.median(a[:, 1]):.2f} | "
              f"{np.median(a[:, 2]):.2f} | {np.median(a[:, 3]):.0f} | {np.median(a[:, 4]):.2f} | "
              f"{np.median(a[:, 5]):.1f} |")


def pathfollow_rows(cfg: RunConfig, ref, duration: float) -> list[str]:
    """The path-following NMPC (its first-step bound is part of its problem) on the same loop, RTI and IPOPT,
    with the robot's limits the sim layer derives from the MJCF (kinematic plant: no yaw compliance)."""
    from ftc_mj.control import PathFollowingNMPCSettings
    from ftc_mj.sim.cache import robot_limits
    from ftc_mj.wiring.control import build_controller

    pf = cfg.model_copy(deep=True)
    pf.controller = PathFollowingNMPCSettings(**{**cfg.controller.model_dump(exclude={"kind"}), "rate_penalty": 1.0})
    pf.plant.kind = "kinematic"
    out = []
    for solver in ("rti-daqp", "ipopt"):
        pf.controller.solver = solver
        t0 = time.perf_counter()
        ctl = build_controller(pf, ref, robot_limits(pf))
        build = time.perf_counter() - t0
        res = simulate(ctl, ref, duration, (0.0, -5.0, 0.0), true_radii=left_step)
        out.append(row(f"PF-NMPC {solver} (bound; rate penalty 1)", build, res, ctl))
    return out


class FromOnset:
    """Hands a path-following NMPC the radius interval ``interval`` from ``onset`` (s) on, as the degraded mode
    does from the first alarm."""

    def __init__(self, ctl, interval, onset: float) -> None:
        self.ctl, self.interval, self.onset = ctl, interval, onset
        self.telemetry_columns = ctl.telemetry_columns

    def solve(self, t, pose, radii, u):
        self.ctl.set_radius_interval(self.interval if t >= self.onset - 1e-9 else None)
        return self.ctl.solve(t, pose, radii, u)


def degraded_table(duration: float) -> None:
    """Solve times of the path-following NMPC with the degraded mode's interval rows against without them."""
    from ftc_mj.control.pathfollow_spec import RadiusInterval
    from ftc_mj.sim.cache import robot_limits
    from ftc_mj.wiring.control import build_controller

    cfg = RunConfig(controller={"kind": "pf-nmpc", "time_budget": 10.0}, plant={"kind": "kinematic"})
    ref = build_reference(cfg)
    r_min = cfg.reconfiguration.degraded.min_radius
    interval = RadiusInterval(np.array([2.0, r_min]), np.array([2.0, 2.0]))
    print(f"\nPath-following NMPC, degraded mode: {duration:.0f} s kinematic loop, R_L 2→1 m at 10 s (true radii), "
          f"interval R_L ∈ [{r_min}, 2] m from 10 s; solve times in ms; load avg {os.getloadavg()[0]:.2f}.\n")
    print("| solver | mode | median t<10 s | p95 t<10 s | first t≥10 s (s) | median t>10 s | p95 t>10 s "
          "| max t>10 s | failures | speed at the end (m/s) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for solver in ("rti-daqp", "ipopt"):
        cfg.controller.solver = solver
        for degraded in (False, True):
            ctl = build_controller(cfg, ref, robot_limits(cfg))
            loop = FromOnset(ctl, interval, 10.0) if degraded else ctl
            res = simulate(loop, ref, duration, (0.0, -5.0, 0.0), true_radii=left_step)
            st = res.solve_times * 1e3
            k = np.arange(len(st)) / cfg.controller.rate
            pre, first, post = st[1:][k[1:] < 10.0], st[k >= 10.0][0], st[k >= 10.0][1:]
            w = res.outputs[-1].omega
            speed = (w[0] * 2.0 + w[1] * 1.0) / 2.0
            print(f"| {solver} | {'degraded' if degraded else 'nominal'} | {np.median(pre):.2f} | "
                  f"{np.percentile(pre, 95):.2f} | {first / 1e3:.2f} | **{np.median(post):.2f}** | "
                  f"{np.percentile(post, 95):.2f} | "
                  f"{post.max():.1f} | {ctl.failures} | {speed:.2f} |")


def controller_table(duration: float, skip_opti: bool) -> None:
    """The kinematic tracking loop for every MPC, with the first-step bound and with the first input free
    (alternated), and the plain Opti build (printed)."""
    cfg = RunConfig()
    cfg.controller.time_budget = 10.0  # measure, don't fall back
    ref = build_reference(cfg)
    makers = ([(f"NMPC {s}", lambda sp, s=s: NMPC(sp, ref, solver=s, time_budget=10.0))
               for s in ("rti-daqp", "rti-qpoases", "rti-osqp", "ipopt")]
              + [(f"LMPC {q}", lambda sp, q=q: LinearMPC(sp, ref, qpsol=q, time_budget=10.0))
                 for q in ("daqp", "qpoases", "osqp")])
    rows = []
    for i, (name, make) in enumerate(makers):
        for bound in ((True, False) if i % 2 == 0 else (False, True)):
            cfg.controller.rate_bound_from_applied = bound
            t0 = time.perf_counter()
            ctl = make(problem_spec(cfg))
            build = time.perf_counter() - t0
            res = simulate(ctl, ref, duration, (0.0, -5.0, 0.0), true_radii=left_step)
            rows.append(row(f"{name} ({'bound' if bound else 'free'})", build, res, ctl))
    cfg.controller.rate_bound_from_applied = True
    rows += pathfollow_rows(cfg, ref, duration)
    spec = problem_spec(cfg)
    if not skip_opti:
        t0 = time.perf_counter()
        ctl = OptiController(spec, ref)
        build = time.perf_counter() - t0
        res = simulate(ctl, ref, duration, (0.0, -5.0, 0.0), true_radii=left_step)
        rows.append(row("plain Opti + IPOPT (expand; bound)", build, res, ctl))
    print(f"\nMPC benchmark: {duration:.0f} s at 10 Hz, N={spec.nodes}, T={spec.horizon} s, 5 m initial offset, "
          f"R_L 2→1 m at 10 s (true radii). Times in ms unless noted; load avg {os.getloadavg()[0]:.2f}.\n")
    print("| controller | build s | first ms | warm median ms | warm p95 ms | warm max ms | iters med/max "
          "| fallbacks | largest step rad/s | t(\\|e\\|<0.1 m) s | RMS \\|e\\| t>5 s (m) | max \\|e\\| t>5 s (m) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(r)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=30.0)
    ap.add_argument("--skip-opti", action="store_true")
    ap.add_argument("--skip-table", action="store_true", help="skip the controller comparison table")
    ap.add_argument("--qp", action="store_true", help="per-QP time, old vs new path")
    ap.add_argument("--kernels", action="store_true", help="per RTI step, compiled kernels vs the numpy reference")
    ap.add_argument("--runs", type=int, default=0, help="whole MuJoCo runs, old vs new, this many times each")
    ap.add_argument("--rate-bound", type=int, default=0,
                    help="whole MuJoCo runs, first-step bound vs free first input, this many times each")
    ap.add_argument("--robust", action="store_true", help="robust multi-stage NMPC vs nominal NMPC and do-mpc")
    ap.add_argument("--dompc-python", default=None,
                    help="with --robust: a Python that has do-mpc (not a dependency), to run do-mpc in this session")
    ap.add_argument("--degraded", action="store_true",
                    help="path-following NMPC's degraded-mode solve time beside the nominal")
    args = ap.parse_args()
    if args.degraded:
        degraded_table(args.duration)
    if args.robust:
        robust_table(min(args.duration, 25.0), args.dompc_python)
    cfg = RunConfig()
    if args.qp:
        qp_table(problem_spec(cfg), build_reference(cfg), min(args.duration, 20.0))
    if args.kernels:
        kernel_table(problem_spec(cfg), build_reference(cfg), min(args.duration, 20.0))
    if args.runs:
        run_table(args.runs)
    if args.rate_bound:
        rate_bound_table(args.rate_bound)
    if not args.skip_table:
        controller_table(args.duration, args.skip_opti)


if __name__ == "__main__":
    main()
