"""Throughput of the Gymnasium environment next to the closed loop it wraps: one 40 s episode of
scenario 2 per plant, commanded by a constant action (no controller cost) and by the built-in NMPC
computed outside the environment, against ``ftc_mj.run`` of the same config (the NMPC inside the loop),
all in this process after one warm-up of each.

    .venv/bin/python benchmarks/bench_env.py [--duration 40] [--repeats 3]

Prints, per plant, the wall and CPU time (s, median of the repeats) of each way of running the same
simulated time, and the environment's steps (one controller period, 0.1 s) per CPU second.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import ftc_mj  # noqa: E402
from ftc_mj.envs import DiffDriveEnv  # noqa: E402
from ftc_mj.wiring.control import build_controller, build_reference  # noqa: E402


def constant_episode(env: DiffDriveEnv) -> int:
    """One episode of the nominal wheel rates held constant (rad/s); the number of steps."""
    env.reset()
    steps, done = 0, False
    while not done:
        *_, terminated, truncated, _ = env.step(np.array([5.1, 4.9]))
        steps, done = steps + 1, terminated or truncated
    return steps


def nmpc_episode(env: DiffDriveEnv, ctrl) -> int:
    """One episode commanded by the NMPC ``ctrl`` (built outside the environment, reset here, as the loop
    resets its cached one); the number of steps."""
    obs, info = env.reset()
    ctrl.reset()
    pose = [env.observation_names.index(n) for n in ("x_pose", "y_pose", "psi_pose")]
    applied, steps, done = None, 0, False
    while not done:
        cmd = ctrl.solve(info["t"], obs[pose], info["model_radii"], applied)
        applied = np.array(cmd.omega, dtype=float)
        obs, _, terminated, truncated, info = env.step(cmd.omega)
        steps, done = steps + 1, terminated or truncated
    return steps


def timed(fn, arg, repeats: int) -> tuple[float, float, object]:
    """Median wall and CPU times (s) of ``repeats`` calls ``fn(arg)`` after one warm-up, and the call's
    result. The CPU time (this process's) is the fairer comparison on a shared machine."""
    result = fn(arg)
    wall, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        result = fn(arg)
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return statistics.median(wall), statistics.median(cpu), result


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--duration", type=float, default=40.0)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print(f"{'plant':<10} {'way':<34} {'wall s':>8} {'CPU s':>8} {'steps/CPU s':>12}")
    for plant in ("mujoco", "kinematic"):
        overrides = {"plant.kind": plant, "duration": args.duration}
        env = DiffDriveEnv("scenario2", overrides)
        cfg = ftc_mj.load_config("scenario2", overrides)
        ctrl = build_controller(env.config, build_reference(env.config))
        for way, fn, arg in (("env, constant action", constant_episode, env),
                             ("env, NMPC outside", lambda ec: nmpc_episode(*ec), (env, ctrl)),
                             ("ftc_mj.run (NMPC inside the loop)", lambda c: ftc_mj.run(c, rrd=False), cfg)):
            wall, cpu, result = timed(fn, arg, args.repeats)
            rate = f"{result / cpu:12.0f}" if isinstance(result, int) else f"{'':>12}"
            print(f"{plant:<10} {way:<34} {wall:8.2f} {cpu:8.2f} {rate}")


if __name__ == "__main__":
    main()
