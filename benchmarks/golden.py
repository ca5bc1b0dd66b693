"""Golden runs: prove that a refactor leaves behaviour unchanged, bit for bit.

Runs a fixed set of closed-loop configurations in one process and prints, per run, the SHA-256 of
its trace (every column but the wall-clock ``solve_time_ms``, as raw little-endian float64/int
bytes in column order), of its events and of its metrics (without the wall-clock keys
``solve_time_ms``, ``wall_time_s``, ``realtime_factor`` and ``solves_over_period``, the count of
solves slower than the control period)::

    python benchmarks/golden.py                       # compare with benchmarks/golden.json
    python benchmarks/golden.py --write               # record a new reference (name the commit!)
    python benchmarks/golden.py --only s2-default     # one run

Exit 0 when every digest equals the reference, 1 otherwise (the differing metrics are printed).
Bitwise equality holds on one CPU type and one set of dependency versions (the README says why);
the reference records both (the CPU model name and its SIMD flags: a VM may report one model name for CPUs
whose kernels differ), and a comparison on another CPU says so instead of failing silently.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

GOLDEN = {
    "s2-default": ("scenario2", {}),
    "s2-gyro-rate-direct": ("scenario2", {"sensors.yaw_rate_sigma": 0.01, "controller.rate_penalty": 1.0,
                                          "reconfiguration.policy": "direct"}),
    "s3-pf-nmpc": ("scenario3", {"controller.kind": "pf-nmpc"}),
    "s2-robust-nmpc": ("scenario2", {"controller.kind": "robust-nmpc"}),
    "s3-imm-ukf-glr": ("scenario3", {"estimator.kind": "imm-ukf", "estimator.decision.rule": "glr"}),
    "s2-kinematic-lmpc": ("scenario2", {"plant.kind": "kinematic", "controller.kind": "lmpc"}),
}
"""The golden set: name -> (scenario, overrides); default duration (40 s) and seed (0)."""
WALL_CLOCK_COLUMNS = {"solve_time_ms"}
WALL_CLOCK_METRICS = {"solve_time_ms", "wall_time_s", "realtime_factor", "solves_over_period"}
REFERENCE = Path(__file__).with_name("golden.json")


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _trace_digest(trace) -> str:
    h = hashlib.sha256()
    for name in trace.columns:
        if name in WALL_CLOCK_COLUMNS:
            continue
        h.update(name.encode())
        h.update(np.ascontiguousarray(trace[name].to_numpy()).tobytes())
    return h.hexdigest()


def digest(name: str) -> dict:
    """The digests of one golden run (simulated in this process, nothing written)."""
    import ftc_mj

    scenario, overrides = GOLDEN[name]
    t0 = time.perf_counter()
    run = ftc_mj.run(ftc_mj.load_config(scenario, overrides), rrd=False)
    metrics = {k: v for k, v in run.metrics.items() if k not in WALL_CLOCK_METRICS}
    events = [[e.t, e.level, e.text] for e in run.events]
    return {"trace": _trace_digest(run.trace), "events": _sha(json.dumps(events).encode()),
            "metrics": _sha(json.dumps(metrics, sort_keys=True, default=str).encode()),
            "metrics_values": json.loads(json.dumps(metrics, default=str)), "rows": run.trace.height,
            "status": run.status, "seconds": round(time.perf_counter() - t0, 1)}


def _machine() -> dict:
    import casadi
    import mujoco

    rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                         cwd=Path(__file__).parent).stdout.strip()
    info = Path("/proc/cpuinfo").read_text().splitlines() if Path("/proc/cpuinfo").is_file() else []
    cpu = next((ln.split(":", 1)[1].strip() for ln in info if ln.startswith("model name")), "")
    flags = next((ln.split(":", 1)[1].split() for ln in info if ln.startswith("flags")), [])
    simd = " ".join(sorted(f for f in set(flags) if f.startswith(("avx", "fma", "sse4"))))
    return {"commit": rev, "cpu": cpu or platform.machine(), "simd": simd, "python": platform.python_version(),
            "mujoco": mujoco.__version__, "casadi": casadi.__version__, "numpy": np.__version__}


def _diff(name: str, got: dict, ref: dict) -> list[str]:
    out = [f"  {part}: differs" for part in ("trace", "events", "metrics", "rows") if got[part] != ref[part]]
    ref_m, got_m = ref["metrics_values"], got["metrics_values"]
    for k in sorted(set(ref_m) | set(got_m)):
        if json.dumps(ref_m.get(k)) != json.dumps(got_m.get(k)):  # NaN equals itself here
            out.append(f"    metrics[{k!r}]: {ref_m.get(k)!r} -> {got_m.get(k)!r}")
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--write", action="store_true", help="record the reference instead of comparing")
    ap.add_argument("--only", action="append", choices=sorted(GOLDEN), help="run only these (repeatable)")
    ap.add_argument("--reference", type=Path, default=REFERENCE)
    args = ap.parse_args()
    names = args.only or list(GOLDEN)
    ref = json.loads(args.reference.read_text()) if args.reference.is_file() else {"runs": {}}
    got = {n: digest(n) for n in names}
    if args.write:
        runs = {**ref.get("runs", {}), **got}
        args.reference.write_text(json.dumps({"machine": _machine(), "runs": runs}, indent=1) + "\n")
        print(f"wrote {args.reference} ({len(got)} runs) at {_machine()['commit']}")
        return 0
    then, now = ref.get("machine", {}), _machine()
    print(f"reference: {then}\nnow:       {now}")
    moved = [k for k in ("cpu", "simd", "python", "mujoco", "casadi", "numpy") if then.get(k) != now[k]]
    if moved:  # the model name alone can hide a different CPU: a VM may report "AMD EPYC" for several
        print(f"NOTE: the reference was recorded with another {', '.join(moved)}: digests need not match here")
    bad = 0
    for n, g in got.items():
        r = ref["runs"].get(n)
        lines = ["  no reference"] if r is None else _diff(n, g, r)
        print(f"{n:22s} {'EQUAL' if not lines else 'DIFFERS'}  ({g['rows']} rows, {g['status']}, {g['seconds']} s)")
        print("\n".join(lines)) if lines else None
        bad += bool(lines)
    print(f"{len(got) - bad}/{len(got)} golden runs bitwise equal")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
