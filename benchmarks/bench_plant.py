"""Benchmark of the truth plant (plain script): ``.venv/bin/python benchmarks/bench_plant.py [--sim-seconds 40]``.

Prints a markdown table:
- physics steps/s in the sim-loop pattern (``advance(10)`` + ``truth()`` + ``Sensors.read`` every 10 steps) over
  ``--sim-seconds`` of simulated time, without a fault, with a step puncture (bulk stepping) and with the scenario-4
  ramp (per-step radius updates during the ramp);
- bare MuJoCo ``mj_step(m, d, n)`` and a Python loop of single ``mj_step`` calls, for comparison;
- the cost of one radius change (``Plant.set_wheel_radius``: geom sizes + ``mj_setConst`` on scratch data + hub
  re-seat), of ``truth()`` and of ``Sensors.read``;
- the kinematic plant in the same loop pattern.

Targets: >= 80 000 physics steps/s in the loop, < 25 µs per radius change. Best of ``--repeat`` runs.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import mujoco

from ftc_mj.config import RunConfig
from ftc_mj.model.kinematics import inverse_rates
from ftc_mj.plant import Sensors
from ftc_mj.wiring.plant import build_plant


def _best(fn: Callable[[], float], repeat: int) -> float:
    return max(fn() for _ in range(repeat))


def loop_rate(cfg: RunConfig, sim_seconds: float) -> float:
    """Physics steps per wall second in the sim-loop pattern. The commands drive the 10 m/s, 50 m circle with the
    true radii (what a controller that knows the fault would ask for), so a puncture does not make the robot skid
    and tumble, which would change the physics cost."""
    plant = build_plant(cfg)
    sensors = Sensors(cfg.sensors, cfg.seed)
    n_outer = int(round(sim_seconds / (10 * cfg.plant.timestep)))
    b = cfg.plant_half_track
    tr = plant.truth()
    t0 = time.perf_counter()
    for _ in range(n_outer):
        plant.set_command(*inverse_rates(10.0, 0.2, tr.R_R, tr.R_L, b))
        plant.advance(10)
        tr = plant.truth()
        sensors.read(tr)
    return 10 * n_outer / (time.perf_counter() - t0)


def bare_rate(n: int) -> tuple[float, float]:
    """(mj_step(m, d, n) steps/s, Python loop of mj_step steps/s) on the compiled plant model."""
    p = build_plant(RunConfig())
    m, d = p.model, p.data
    d.ctrl[:] = (5.1, 4.9)
    mujoco.mj_step(m, d, 1000)
    t0 = time.perf_counter()
    mujoco.mj_step(m, d, n)
    bulk = n / (time.perf_counter() - t0)
    t0 = time.perf_counter()
    for _ in range(n):
        mujoco.mj_step(m, d)
    single = n / (time.perf_counter() - t0)
    return bulk, single


def radius_change_us(n: int = 4000) -> tuple[float, float]:
    """Mean cost (µs) of one ``set_wheel_radius`` with re-seat: (growing, which runs ``mj_setConst``; shrinking,
    which keeps the conservative larger bounds)."""
    p = build_plant(RunConfig())
    p.advance(100)
    r = 2.0
    t0 = time.perf_counter()
    for _ in range(n):  # shrinking steps of 0.1 mm: bounds kept
        r -= 1e-4
        p.set_wheel_radius("left", r)
    shrink = (time.perf_counter() - t0) / n
    p._refresh_bounds()  # bounds now fit the shrunken tyre, so each growth below must refresh them
    t0 = time.perf_counter()
    for _ in range(n):  # growing steps of 0.1 mm: every one exceeds the bounds and runs mj_setConst
        r += 1e-4
        p.set_wheel_radius("left", r)
    grow = (time.perf_counter() - t0) / n
    return grow * 1e6, shrink * 1e6


def call_us(n: int = 4000) -> tuple[float, float]:
    """Mean cost (µs) of ``truth()`` and of ``Sensors.read``."""
    cfg = RunConfig()
    cfg.sensors.yaw_rate_sigma = 0.01
    p = build_plant(cfg)
    s = Sensors(cfg.sensors, 0)
    p.set_command(5.1, 4.9)
    p.advance(1000)
    t0 = time.perf_counter()
    for _ in range(n):
        tr = p.truth()
    t_truth = (time.perf_counter() - t0) / n * 1e6
    t0 = time.perf_counter()
    for _ in range(n):
        s.read(tr)
    return t_truth, (time.perf_counter() - t0) / n * 1e6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sim-seconds", type=float, default=40.0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    T, rep = args.sim_seconds, args.repeat

    rows: list[tuple[str, str, str]] = []
    base = RunConfig()
    rows.append(("loop: no fault (steps/s)", f"{_best(lambda: loop_rate(base, T), rep):,.0f}", ">= 80,000"))
    step = RunConfig()
    step.faults.left = [(10.0, 2.0), (10.0, 1.0)]
    rows.append(("loop: 50 % step puncture at 10 s (steps/s)", f"{_best(lambda: loop_rate(step, T), rep):,.0f}",
                 ">= 80,000"))
    ramp = RunConfig()
    ramp.faults.left = [(10.0, 2.0), (29.0, 0.1)]
    rows.append(("loop: scenario-4 ramp 10-29 s (steps/s)", f"{_best(lambda: loop_rate(ramp, T), rep):,.0f}", "-"))
    bulk, single = max(bare_rate(int(T * 1000)) for _ in range(rep))
    rows.append(("bare mj_step(m, d, n) (steps/s)", f"{bulk:,.0f}", "reference"))
    rows.append(("python loop of mj_step (steps/s)", f"{single:,.0f}", "reference"))
    grow, shrink = min(radius_change_us() for _ in range(rep))
    rows.append(("one radius change, growing: + mj_setConst (µs)", f"{grow:.1f}", "< 25"))
    rows.append(("one radius change, shrinking (µs)", f"{shrink:.1f}", "< 25"))
    tt, ts = min(call_us() for _ in range(rep))
    rows.append(("truth() (µs)", f"{tt:.1f}", "-"))
    rows.append(("Sensors.read (µs)", f"{ts:.1f}", "-"))
    kin = RunConfig()
    kin.plant.kind = "kinematic"
    rows.append(("kinematic plant loop (steps/s)", f"{_best(lambda: loop_rate(kin, T), rep):,.0f}", "-"))

    w0 = max(len(r[0]) for r in rows)
    w1 = max(len(r[1]) for r in rows)
    print(f"plant benchmark: {T:g} s simulated at 1 kHz, best of {rep}, MuJoCo {mujoco.__version__}\n")
    print(f"| {'measure':<{w0}} | {'value':>{w1}} | target |")
    print(f"|{'-' * (w0 + 2)}|{'-' * (w1 + 1)}:|--------|")
    for name, value, target in rows:
        print(f"| {name:<{w0}} | {value:>{w1}} | {target} |")


if __name__ == "__main__":
    main()
