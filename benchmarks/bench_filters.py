"""Per-step cost (predict + update) of the project's filters next to filterpy's, in one run.

Plain script: ``.venv/bin/python benchmarks/bench_filters.py [--steps N] [--repeats R]``.
Scenario: excited wheel rates (wR = 5.1 + 0.8 sin 0.7t, wL = 4.9 + 0.8 cos 0.5t),
R_L drops linearly 2 → 1 m over t = 10–12 s, z = V + N(0, 0.5²) (and, for the "+yaw" rows, a gyro
psidot + N(0, 0.01²)), dt = 0.01 s. Every filter of the project runs through both backends: the
compiled step (``numba``, the default) and the numpy reference (``numpy``). Each implementation
runs ``repeats`` times over ``steps`` steps, the implementations interleaved (round robin) so that a
load change on the machine affects all of them alike; every step (the whole ``step`` call, with
measurement assembly and output) is timed with perf_counter_ns. Prints median and p95 µs/step, the
ratio to filterpy's UKF and, for the compiled rows, the speed-up over the numpy reference.

``--compile`` instead times the first step of each compiled filter kind in fresh processes: once with
an empty numba cache (``NUMBA_CACHE_DIR`` = a new temporary directory: compilation) and once more with
that cache warm (loading the cached machine code).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable

import numpy as np
from filterpy.kalman import IMMEstimator, JulierSigmaPoints, UnscentedKalmanFilter

from ftc_mj.config import RunConfig
from ftc_mj.estimation import Measurement
from ftc_mj.estimation.setup import FilterSetup
from ftc_mj.model.kinematics import KinematicModel
from ftc_mj.wiring.estimation import setup_from_config
from tests.estimation.filters import make_filter


def scenario(steps: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Wheel rates (steps, 2) (rad/s), noisy speeds (steps,) (m/s) and yaw rates (rad/s) from the
    kinematic model."""
    rng = np.random.default_rng(seed)
    model = KinematicModel(b=1.0, dt=0.01)
    t = np.arange(steps) * 0.01
    u = np.stack([5.1 + 0.8 * np.sin(0.7 * t), 4.9 + 0.8 * np.cos(0.5 * t)], axis=1)
    RL = np.interp(t, [10.0, 12.0], [2.0, 1.0])
    x = np.array([0.0, 0.0, 0.0, 2.0, 2.0])
    z = np.empty(steps)
    zy = np.empty(steps)
    for k in range(steps):
        x = model.step(x, u[k])
        x[4] = RL[k]
        z[k] = float(model.speed(x, u[k])) + 0.5 * rng.normal()
        zy[k] = float(model.yaw_rate(x, u[k])) + 0.01 * rng.normal()
    return u, z, zy


def filterpy_ukf(setup: FilterSetup, inputs: np.ndarray) -> UnscentedKalmanFilter:
    """filterpy's UKF with our model functions; wheel rates read from ``inputs`` (closure)."""
    m = setup.model
    f = UnscentedKalmanFilter(
        5, 1, setup.dt,
        hx=lambda x: np.atleast_1d(m.speed(x, inputs)),
        fx=lambda x, dt: m.step(x, inputs, dt),
        points=JulierSigmaPoints(5, kappa=setup.kappa),
    )
    f.x = setup.x0.copy()
    f.P = setup.P0.copy()
    f.Q = setup.Q.copy()
    f.R = np.eye(1) * setup.speed_sigma**2
    return f


Runner = Callable[[np.ndarray, np.ndarray], np.ndarray]


def runner_ours(make: Callable[[], object], zy: np.ndarray | None = None) -> Runner:
    """Time ``make()``'s steps; with ``zy`` the measurement includes the yaw rate."""

    def run(u: np.ndarray, z: np.ndarray) -> np.ndarray:
        f = make()
        out = np.empty(len(z))
        clock = time.perf_counter_ns
        for k in range(len(z)):
            meas = Measurement(float(z[k]), None if zy is None else float(zy[k]))
            t0 = clock()
            f.step(u[k], meas)  # type: ignore[attr-defined]
            out[k] = clock() - t0
        return out
    return run


def runner_filterpy_ukf(setup: FilterSetup) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    def run(u: np.ndarray, z: np.ndarray) -> np.ndarray:
        inputs = np.zeros(2)
        f = filterpy_ukf(setup, inputs)
        out = np.empty(len(z))
        clock = time.perf_counter_ns
        for k in range(len(z)):
            zk = np.array([z[k]])
            t0 = clock()
            inputs[:] = u[k]
            f.predict()
            f.update(zk)
            out[k] = clock() - t0
        return out
    return run


def runner_filterpy_imm(setup: FilterSetup) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    def run(u: np.ndarray, z: np.ndarray) -> np.ndarray:
        inputs = np.zeros(2)
        filters = []
        for fr, fl in ((1.0, 1.0), (0.5, 1.0), (1.0, 0.5), (0.5, 0.5)):
            f = filterpy_ukf(setup, inputs)
            f.x[3:5] = (fr * setup.nominal_radius, fl * setup.nominal_radius)
            filters.append(f)
        Pi = np.full((4, 4), 0.01) + np.eye(4) * 0.96
        imm = IMMEstimator(filters, np.full(4, 0.25), Pi)
        out = np.empty(len(z))
        clock = time.perf_counter_ns
        for k in range(len(z)):
            zk = np.array([z[k]])
            t0 = clock()
            inputs[:] = u[k]
            imm.predict()
            imm.update(zk)
            out[k] = clock() - t0
        return out
    return run


FIRST_STEPS = """
import time
t0 = time.perf_counter()
import numpy as np
from ftc_mj.config import RunConfig
from ftc_mj.estimation import Measurement
from ftc_mj.wiring.estimation import build_estimator
t1 = time.perf_counter()
print(f"imports {t1 - t0:6.2f} s", end="")
for name, kind in (("UKF", "ukf"), ("EKF", "ekf"), ("IMM-UKF", "imm-ukf"), ("IMM-EKF", "imm-ekf")):
    cfg = RunConfig.model_validate({"sensors": {"yaw_rate_sigma": 0.01}, "estimator": {"kind": kind}})
    t = time.perf_counter()
    build_estimator(cfg).step(np.array([5.0, 5.0]), Measurement(10.0, 0.0))
    print(f" | {name} built + first step {time.perf_counter() - t:6.2f} s", end="")
print(f" | total {time.perf_counter() - t0:6.2f} s")
"""


def compile_times() -> None:
    """First-step times in fresh processes, cold and warm numba cache (see the module docstring)."""
    with tempfile.TemporaryDirectory() as cache:
        env = os.environ | {"NUMBA_CACHE_DIR": cache}
        for label in ("cold cache", "warm cache"):
            out = subprocess.run([sys.executable, "-c", FIRST_STEPS], env=env, capture_output=True, text=True,
                                 check=True).stdout.strip()
            print(f"{label}: {out}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=1500)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--compile", action="store_true", help="time compilation and cache loading instead")
    args = ap.parse_args()
    if args.compile:
        compile_times()
        return
    cfg4 = RunConfig()
    cfg5 = RunConfig.model_validate({"estimator": {"kind": "imm-ukf", "imm_models": 5}})
    yaw = {"sensors": {"yaw_rate_sigma": 0.01}}
    cfg4y = RunConfig.model_validate(yaw)
    cfg5y = RunConfig.model_validate(yaw | {"estimator": {"kind": "imm-ukf", "imm_models": 5}})
    setup = setup_from_config(cfg4)
    u, z, zy = scenario(args.steps)
    filters: dict[str, tuple[Callable[[RunConfig, str], object], RunConfig, RunConfig]] = {
        "EKF": (lambda c, b: make_filter("ekf", c, reference=b == "numpy"), cfg4, cfg4y),
        "UKF": (lambda c, b: make_filter("ukf", c, reference=b == "numpy"), cfg4, cfg4y),
        "IMM-EKF 4": (lambda c, b: make_filter("imm-ekf", c, reference=b == "numpy"), cfg4, cfg4y),
        "IMM-EKF 5": (lambda c, b: make_filter("imm-ekf", c, reference=b == "numpy"), cfg5, cfg5y),
        "IMM-UKF 4": (lambda c, b: make_filter("imm-ukf", c, reference=b == "numpy"), cfg4, cfg4y),
        "IMM-UKF 5": (lambda c, b: make_filter("imm-ukf", c, reference=b == "numpy"), cfg5, cfg5y),
    }
    runs: dict[str, Callable[[np.ndarray, np.ndarray], np.ndarray]] = {}
    for name, (make, c_speed, c_yaw) in filters.items():
        for sensors, c, gyro in (("", c_speed, None), (" +yaw", c_yaw, zy)):
            for backend in ("numba", "numpy"):
                runs[f"{name}{sensors} {backend}"] = runner_ours(
                    lambda make=make, c=c, backend=backend: make(c, backend), gyro)
    runs["filterpy UKF"] = runner_filterpy_ukf(setup)
    runs["filterpy IMMEstimator 4 UKF"] = runner_filterpy_imm(setup)
    samples: dict[str, list[np.ndarray]] = {k: [] for k in runs}
    for run in runs.values():  # warm-up (code generation, compiled-code cache, caches)
        run(u[:50], z[:50])
    for _ in range(args.repeats):
        for name, run in runs.items():
            samples[name].append(run(u, z))
    medians = {name: float(np.median(np.concatenate(parts))) / 1e3 for name, parts in samples.items()}
    ref = medians["filterpy UKF"]
    print(f"{args.steps} steps x {args.repeats} repeats, per-step wall time (predict + update)")
    print(f"{'implementation':30s} {'median µs':>10s} {'p95 µs':>10s} {'steps/s':>10s} {'÷ filterpy UKF':>15s}"
          f" {'numpy ÷ numba':>14s}")
    for name, parts in samples.items():
        us = np.concatenate(parts) / 1e3
        med = medians[name]
        ref_name = name.removesuffix(" numba") + " numpy"
        gain = f"{medians[ref_name] / med:14.1f}" if name.endswith(" numba") else ""
        print(f"{name:30s} {med:10.1f} {float(np.percentile(us, 95)):10.1f} {1e6 / med:10.0f} {med / ref:15.2f}"
              f" {gain}")


if __name__ == "__main__":
    main()
