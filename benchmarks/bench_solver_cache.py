"""Building an NMPC's IPOPT solver afresh against loading it from the solver cache, in the same run.

    .venv/bin/python benchmarks/bench_solver_cache.py [--repeat 3]

For the tracking NMPC, the path-following NMPC and the 4-scenario robust NMPC of scenario 3: the
controller's construction time (s) with ``FTC_MJ_SOLVER_CACHE=off`` (``ca.nlpsol`` derives the
Jacobian and Hessian) and with a warm cache in a temporary folder (the serialised solver is loaded),
best of ``--repeat``, and their ratio. The cache's own first build (fresh build + serialising) is
shown too: it is what the first process on a machine pays.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

from ftc_mj.config import load_config
from ftc_mj.disk_cache import CACHE_ENV, SWITCH_ENV
from ftc_mj.sim.cache import robot_limits
from ftc_mj.sim.loop import build_reference
from ftc_mj.wiring.control import build_controller

KINDS = ("nmpc", "pf-nmpc", "robust-nmpc")


def build_time(kind: str) -> float:
    """Seconds to construct the scenario-3 controller ``kind`` (reference and limits prepared first)."""
    cfg = load_config("scenario3", {"controller.kind": kind})
    ref, lim = build_reference(cfg), robot_limits(cfg)
    t = time.perf_counter()
    build_controller(cfg, ref, lim)
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    print("| controller | fresh build (s) | first cached build (s) | load from cache (s) | fresh / load |")
    print("|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as root:
        os.environ[CACHE_ENV] = root
        for kind in KINDS:
            os.environ[SWITCH_ENV] = "off"
            fresh = min(build_time(kind) for _ in range(args.repeat))
            os.environ[SWITCH_ENV] = "on"
            first = build_time(kind)
            load = min(build_time(kind) for _ in range(args.repeat))
            print(f"| {kind} | {fresh:.2f} | {first:.2f} | {load:.2f} | {fresh / load:.1f}× |")


if __name__ == "__main__":
    main()
