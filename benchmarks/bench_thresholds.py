"""What a run pays to calibrate its change detectors, with the thresholds computed and read from the disk cache.

    .venv/bin/python benchmarks/bench_thresholds.py [--draws 10] [--first 10] [--method safe]

For each ftc-v2 dev draw (the method's run config) the decision rule's and the fast tyre detector's thresholds
(``calibrated_threshold``: the nominal operating points' Riccati recursion, then the Monte Carlo bisection of
:func:`~ftc_mj.estimation.calibration.null_threshold` per point) are obtained three ways, each with the
process's in-memory cache emptied first: *off* (``FTC_MJ_SOLVER_CACHE=off``: computed), *cold* (an empty cache
folder: computed and written) and *warm* (the same folder again: read), as a bench worker meets a draw that
another method's run has calibrated already. CPU seconds (``time.process_time``) per draw, medians over the
draws, and whether the three thresholds are equal to the bit.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time

from ftc_mj.benchmark.draws import draw
from ftc_mj.benchmark.methods import load_methods
from ftc_mj.disk_cache import CACHE_ENV, SWITCH_ENV
from ftc_mj.estimation.calibration import null_threshold
from ftc_mj.wiring.decision import calibrated_threshold


def timed(cfg) -> tuple[float, float]:
    """CPU seconds and the value of ``calibrated_threshold(cfg, "cusum")`` with the in-memory cache emptied."""
    null_threshold.cache_clear()
    t = time.process_time()
    h = calibrated_threshold(cfg, "cusum")
    return time.process_time() - t, h


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=10)
    ap.add_argument("--first", type=int, default=10, help="first dev draw (default 10)")
    ap.add_argument("--method", default="safe")
    args = ap.parse_args()
    method = load_methods([args.method])[0]
    cfgs = [method.apply(draw("dev", i).scenario()) for i in range(args.first, args.first + args.draws)]
    timed(cfgs[0])  # imports and compiled kernels loaded, not timed
    rows: dict[str, list[float]] = {"off": [], "cold": [], "warm": []}
    equal = True
    with tempfile.TemporaryDirectory() as root:
        os.environ[CACHE_ENV] = root
        for cfg in cfgs:
            os.environ[SWITCH_ENV] = "off"
            t_off, h_off = timed(cfg)
            del os.environ[SWITCH_ENV]
            t_cold, h_cold = timed(cfg)
            t_warm, h_warm = timed(cfg)
            rows["off"].append(t_off)
            rows["cold"].append(t_cold)
            rows["warm"].append(t_warm)
            equal &= h_off.hex() == h_cold.hex() == h_warm.hex()
    print(f"{args.method} on dev draws {args.first}-{args.first + args.draws - 1}, CPU s per draw (median [min, max])")
    print("| cache | threshold s |")
    print("|---|---|")
    for name, v in rows.items():
        print(f"| {name} | {statistics.median(v):.3f} [{min(v):.3f}, {max(v):.3f}] |")
    print(f"thresholds equal to the bit in all three: {equal}")


if __name__ == "__main__":
    main()
