"""One BLAS thread for the MPCs: after ``limit_blas_threads(1)`` every OpenBLAS in the process — numpy's and
SciPy's (the certified QP's LAPACK, which SciPy loads only when it is first used) — runs one thread, and
with a wheel's SciPy the limit does not import ``scipy.linalg`` to get there."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys

PROBE = """
import ctypes, json, sys
from ftc_mj.control.blas import limit_blas_threads
assert limit_blas_threads(1)
early = "scipy.linalg" in sys.modules  # a wheel's SciPy OpenBLAS is loaded by ctypes, not by importing SciPy
import scipy.linalg.lapack  # the certified QP's first LAPACK call, after the controller was built
libs = {ln.split()[-1] for ln in open("/proc/self/maps") if "openblas" in ln.lower() and "/" in ln}
threads = {}
for path in libs:
    lib = ctypes.CDLL(path)
    for name in ("scipy_openblas_get_num_threads64_", "scipy_openblas_get_num_threads",
                 "openblas_get_num_threads64_", "openblas_get_num_threads"):
        fn = getattr(lib, name, None)
        if fn is not None:
            threads[path] = fn()
            break
print(json.dumps({"threads": threads, "early": early}))
"""


def test_every_openblas_runs_one_thread() -> None:
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}  # OpenBLAS's own default
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, timeout=300, check=True,
                         env=env)
    got = json.loads(out.stdout.strip().splitlines()[-1])
    threads = got["threads"]
    wheel = any(importlib.util.find_spec("scipy").submodule_search_locations[0].rsplit("/", 1)[0] + "/scipy.libs"
                in p for p in threads)
    assert not (wheel and got["early"]), "limit_blas_threads imported scipy.linalg (≈ 0.1–0.2 s of start-up)"
    assert len(threads) >= 2, threads  # numpy's and SciPy's
    assert set(threads.values()) == {1}, threads  # (fails on a machine of more than one core without the limit)


RUN_PROBE = """
import ctypes, json
import numpy as np
from ftc_mj.envs import DiffDriveEnv
env = DiffDriveEnv()
env.reset(seed=0)
env.step(np.zeros(2))
libs = {ln.split()[-1] for ln in open("/proc/self/maps") if "openblas" in ln.lower() and "numpy" in ln}
threads = []
for path in libs:
    lib = ctypes.CDLL(path)
    for name in ("scipy_openblas_get_num_threads64_", "scipy_openblas_get_num_threads",
                 "openblas_get_num_threads64_", "openblas_get_num_threads"):
        if getattr(lib, name, None) is not None:
            threads.append(getattr(lib, name)())
            break
print(json.dumps(threads))
"""


def test_a_run_without_a_controller_runs_one_blas_thread() -> None:
    """A run limits BLAS when it starts, not only when it builds an MPC: the Gymnasium environment's loop (an agent
    commands, no controller) then has numpy's OpenBLAS at one thread. (On a one-core machine OpenBLAS starts with one
    thread and this cannot fail.)"""
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    out = subprocess.run([sys.executable, "-c", RUN_PROBE], capture_output=True, text=True, timeout=300, check=True,
                         env=env)
    assert json.loads(out.stdout.strip().splitlines()[-1]) == [1]  # numpy's OpenBLAS
