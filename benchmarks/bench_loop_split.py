"""Where a run's closed loop spends its time: physics, filter, fault decision, controller, bookkeeping.

    .venv/bin/python benchmarks/bench_loop_split.py [--scenario scenario2] [--duration 40] [--repeat 3]

One run of ``--scenario`` (MuJoCo plant, the scenario's filter and controller) is built
(:class:`~ftc_mj.sim.loop.ClosedLoop`, timed as *build*: plant, solvers, kernels from their caches) and
stepped as :func:`~ftc_mj.sim.loop.simulate` does, with a ``time.perf_counter`` pair around each
component's call: *physics* (``plant.advance``: ``mj_step`` and the plant's checks), *truth + sensors*
(``plant.truth``, ``sensors.read``), *filter* (``estimator.step``), *decision* (the fault decision's
``update`` and the policy's ``observe``), *controller* (``controller.solve``); *bookkeeping* is the rest
of the estimator steps (trace rows, events, dither, the reconfiguration policy's ``radii``, the loop
itself). *after the loop*: the trace's columns with the posterior Cramér–Rao bound.

The reference, *physics alone*, replays the same run's plant commands on a copy of the initial
``MjData`` with ``mj_step(m, d, n)`` per estimator step (no fault schedule: the wheel radii stay
nominal), in the same process, alternating with the instrumented run; medians of ``--repeat`` rounds.
The issue's target: the loop ≤ 1.5× the physics alone. The timers cost ≈ 1 µs per call (a few ms per
run); the loop's total is measured without them too.
"""

from __future__ import annotations

import argparse
import copy
import statistics
import time
from collections.abc import Callable
from typing import Any

import mujoco

from ftc_mj.config import load_config
from ftc_mj.sim.loop import ClosedLoop

PARTS = ("physics", "truth + sensors", "filter", "decision", "controller")


def timed(obj: Any, name: str, acc: dict[str, float], part: str) -> None:
    """Replace ``obj.name`` by a wrapper adding its wall time (s) to ``acc[part]``."""
    fn: Callable[..., Any] = getattr(obj, name)

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        t = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            acc[part] += time.perf_counter() - t

    setattr(obj, name, wrapper)


def instrumented_run(cfg: Any, instrument: bool) -> tuple[dict[str, float], list[Any], Any]:
    """Seconds per part of one run (``instrument`` False: only build, loop, after), the commands held
    per estimator step and a copy of the initial ``MjData``."""
    acc = dict.fromkeys(("build", *PARTS, "loop", "after"), 0.0)
    t = time.perf_counter()
    loop = ClosedLoop(cfg)
    acc["build"] = time.perf_counter() - t
    p = loop.parts
    d0 = copy.deepcopy(p.plant.data)
    if instrument:
        for obj, name, part in ((p.plant, "advance", "physics"), (p.plant, "truth", "truth + sensors"),
                                (p.sensors, "read", "truth + sensors"), (p.estimator, "step", "filter"),
                                (p.decision, "update", "decision"), (p.policy, "observe", "decision"),
                                (p.controller, "solve", "controller")):
            if obj is not None:
                timed(obj, name, acc, part)
    ctrl = []
    t = time.perf_counter()
    for k in range(loop.n):
        loop.step(k)
        ctrl.append(p.plant.data.ctrl.copy())
    acc["loop"] = time.perf_counter() - t
    t = time.perf_counter()
    loop.columns()
    acc["after"] = time.perf_counter() - t
    if instrument:  # the plant is cached per process: the next run gets the class's methods back
        for obj in (p.plant, p.sensors, p.estimator, p.decision, p.policy, p.controller):
            for name in ("advance", "truth", "read", "step", "update", "observe", "solve"):
                if obj is not None and name in vars(obj):
                    delattr(obj, name)
    return acc, ctrl, (p.plant.model, d0, cfg.physics_per_estimator)


def physics_alone(model: Any, d0: Any, n: int, ctrl: list[Any]) -> float:
    """Seconds to step a copy of ``d0`` ``n`` physics steps per held command in ``ctrl``."""
    d = copy.deepcopy(d0)
    t = time.perf_counter()
    for c in ctrl:
        d.ctrl[:] = c
        mujoco.mj_step(model, d, n)
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="scenario2")
    ap.add_argument("--duration", type=float, default=40.0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    cfg = load_config(args.scenario, {"duration": args.duration})
    instrumented_run(load_config(args.scenario, {"duration": 0.5}), False)  # warm-up: caches, kernels, solvers
    runs, plain, phys = [], [], []
    for _ in range(args.repeat):
        acc, ctrl, (model, d0, n) = instrumented_run(cfg, True)
        runs.append(acc)
        phys.append(physics_alone(model, d0, n, ctrl))
        plain.append(instrumented_run(cfg, False)[0]["loop"])
    med = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
    loop, ref, bare = med["loop"], statistics.median(phys), statistics.median(plain)
    med["bookkeeping"] = loop - sum(med[p] for p in PARTS)
    steps = cfg.n_estimator_steps
    print(f"{args.scenario}, {args.duration:g} s simulated ({steps} estimator steps, "
          f"{steps * cfg.physics_per_estimator} physics steps), {cfg.estimator.kind} + {cfg.controller.kind}; "
          f"medians of {args.repeat}\n")
    print("| part | s | µs per estimator step | share of the loop |")
    print("|---|---|---|---|")
    for part in (*PARTS, "bookkeeping"):
        print(f"| {part} | {med[part]:.3f} | {med[part] / steps * 1e6:.0f} | {med[part] / loop:.0%} |")
    print(f"| **loop (instrumented)** | {loop:.3f} | {loop / steps * 1e6:.0f} | 100% |")
    print(f"| loop without timers | {bare:.3f} | {bare / steps * 1e6:.0f} | |")
    print(f"| build (before the loop) | {med['build']:.3f} | | |")
    print(f"| after the loop (columns, PCRB) | {med['after']:.3f} | | |")
    print(f"\nphysics alone (mj_step replay of the run's commands): {ref:.3f} s; loop without timers / physics "
          f"alone = {bare / ref:.2f}× (target ≤ 1.5×); the plant's advance / physics alone = "
          f"{med['physics'] / ref:.2f}×")


if __name__ == "__main__":
    main()
