"""The accommodation per mode against the loop without it: the table of docs/findings.md ("Accommodation of every
fault, and a safe stop").

Plain script: ``.venv/bin/python benchmarks/accommodation.py [--out rows.jsonl]``. For each fault (left wheel, at
10 s): accommodated — the oracle, the configured faults as its diagnoses (``oracle = true``,
``reconfiguration.accommodation.mode = "all"``) — and not accommodated (``mode = "radii"``, today's loop), both
with the pf-nmpc, the UKF and the ``safe`` policy, on 8 conditions: circle radius 40/50/80/120 m × ccw/cw at
``min(10, sqrt(1.5 R))`` m/s (the ftc-v1 speed cap), development seeds 0–7 (one per condition). Success of a
stop-only fault (lock, unresponsive): at rest (|v| < 0.1 m/s) from 15 s on, never more than 2 m from the path,
not tipped; of a trackable one: within 0.5 m from 15 s on, lift-off after the transients ≤ 0.2 s, not tipped.
Intervals: Wilson 95 %. About 6 min of CPU.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics as st
from typing import Any

import numpy as np

from ftc_mj.config import load_config
from ftc_mj.sim.run import execute


def _actuator(kind: str, **extra: float) -> dict[str, Any]:
    return {"faults": {"actuator": [{"wheel": "left", "kind": kind, "onset": 10.0, **extra}]}}


def _sensor(sensor: str, size: float) -> dict[str, Any]:
    return {"faults": {"sensor": [{"sensor": sensor, "kind": "bias", "onset": 10.0, "size": size}]}}


CASES: dict[str, tuple[dict[str, Any], float, str]] = {
    "lock": (_actuator("lock"), 17.0, "stop"),
    "unresponsive": (_actuator("unresponsive"), 17.0, "stop"),
    "servo loss 30 %": (_actuator("loss", effectiveness=0.3), 25.0, "track"),
    "speed bias +0.5 m/s": (_sensor("speed", 0.5), 25.0, "track"),
    "gyro bias +0.02 rad/s": ({**_sensor("yaw_rate", 0.02), "sensors.yaw_rate_sigma": 0.01}, 25.0, "track"),
}
"""Fault name: (overrides, duration (s), ``stop`` or ``track``)."""
CONDITIONS = [(R, d) for R in (40.0, 50.0, 80.0, 120.0) for d in ("ccw", "cw")]


def one_run(over: dict[str, Any], duration: float, kind: str, mode: str, i: int) -> dict[str, Any]:
    """One run of condition ``i`` with the accommodation ``mode`` (``all``: the oracle); its row."""
    R, d = CONDITIONS[i]
    o = {"controller.kind": "pf-nmpc", "seed": i, "duration": duration, "reference.radius": R,
         "reference.direction": d, "reference.speed": round(min(10.0, math.sqrt(1.5 * R)), 3), **over}
    if mode == "all":
        o.update({"oracle": True, "reconfiguration.accommodation.mode": "all"})
    oc = execute(load_config("scenario1", o), None, rrd=False)
    tr, m = oc.result.trace, oc.metrics
    t, v, e = tr["t"], tr["v"], np.abs(tr["cross_track_error"])
    lift = m.get("liftoff_time_post_transient_s") or 0.0
    if kind == "stop":
        ok = bool(np.all(np.abs(v[t >= 15.0]) < 0.1) and e.max() <= 2.0 and not m.get("tipped"))
    else:
        ok = bool(e[t >= 15.0].max() <= 0.5 and lift <= 0.2 and not m.get("tipped"))
    return {"mode": mode, "R": R, "dir": d, "seed": i, "ok": ok, "max_e": float(e.max()),
            "max_e_from_15": float(e[t >= 15.0].max()), "v_at_15": float(v[t >= 15.0][0]), "liftoff_post": lift,
            "tipped": bool(m.get("tipped"))}


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of ``k`` successes in ``n``."""
    p, d = k / n, 1.0 + z * z / n
    c, h = p + z * z / (2 * n), z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return (c - h) / d, (c + h) / d


def table(rows: list[dict[str, Any]]) -> str:
    """The Markdown table of the rows: per fault and mode, successes, interval, errors, speed, lift-off."""
    lines = ["| fault | mode | success | 95 % interval | max \\|e\\| (m): median [range] | |v| at 15 s (m/s): "
             "median | lift-off after transients (s): median |", "|---|---|---|---|---|---|---|"]
    for case in dict.fromkeys(r["case"] for r in rows):
        for mode in ("radii", "all"):
            g = [r for r in rows if r["case"] == case and r["mode"] == mode]
            k = sum(r["ok"] for r in g)
            lo, hi = wilson(k, len(g))
            e = [r["max_e"] if r["kind"] == "stop" else r["max_e_from_15"] for r in g]
            label = "not accommodated" if mode == "radii" else "accommodated (oracle)"
            lines.append(f"| {case} ({g[0]['kind']}) | {label} | {k}/{len(g)} | {lo:.0%}–{hi:.0%} | "
                         f"{st.median(e):.2f} [{min(e):.2f}, {max(e):.2f}] | "
                         f"{st.median(abs(r['v_at_15']) for r in g):.2f} | "
                         f"{st.median(r['liftoff_post'] for r in g):.2f} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None, help="also write the rows (JSON lines) here")
    args = ap.parse_args()
    rows = []
    for case, (over, duration, kind) in CASES.items():
        for mode in ("all", "radii"):
            for i in range(len(CONDITIONS)):
                row = {"case": case, "kind": kind, **one_run(over, duration, kind, mode, i)}
                rows.append(row)
                print(json.dumps(row), flush=True)
    if args.out:
        with open(args.out, "w") as f:
            f.writelines(json.dumps(r) + "\n" for r in rows)
    print(table(rows))


if __name__ == "__main__":
    main()
