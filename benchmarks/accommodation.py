"""The accommodation per mode: the accommodated loop against the radii-only loop and the oracle — the table of
docs/findings.md ("Accommodation of every fault, and a safe stop").

Plain script: ``.venv/bin/python benchmarks/accommodation.py --seeds 0-4 [--sensors pose] [--out rows.jsonl]``;
``--rows a.jsonl,b.jsonl,c.jsonl`` prints the rows of several sensor sets as one table, a column per set.
For each fault (left wheel, at 10 s) and each seed, three loops (the settings of :mod:`ftc_mj.benchmark.methods`):

- ``accommodated``: the built-in ``pathfollow`` method — UKF, pf-nmpc, the ``safe`` policy, the run's diagnoser
  (``[diagnosis]``) and ``reconfiguration.accommodation.mode = "all"``;
- ``radii only``: the same with ``mode = "radii"`` (the loop before the accommodation);
- ``oracle``: the benchmark's ``oracle`` row — the same controller told the truth (true pose and radii, the
  configured faults as its diagnoses, ``oracle = true``), no estimator;
- ``tyre from diagnosis`` (only with ``--loops``): ``pathfollow`` with ``accommodation.tyre = "diagnosis"``.

Seed ``i`` runs condition ``i mod 8``: circle radius 40/50/80/120 m × ccw/cw at ``min(10, sqrt(1.5 R))`` m/s (the
ftc-v1 speed cap). Seeds 0–999 are development seeds; held-out seeds (≥ 1000) are for the acceptance after the
design is frozen. Success of a stop-only fault (lock, unresponsive): at rest (|v| < 0.1 m/s) from 15 s on, never more
than 2 m from the path, not tipped; of a trackable one: within 0.5 m from 15 s on, lift-off after the transients
≤ 0.2 s, not tipped. Intervals: Wilson 95 %. A few seconds of CPU per run (24 runs per seed).
"""

from __future__ import annotations

import argparse
import json
import math
import statistics as st
from typing import Any

import numpy as np

from ftc_mj.benchmark.methods import BUILTIN, REFERENCE_ROWS
from ftc_mj.config import load_config
from ftc_mj.sim.run import execute


def _actuator(kind: str, **extra: float) -> dict[str, Any]:
    return {"faults": {"actuator": [{"wheel": "left", "kind": kind, "onset": 10.0, **extra}]}}


def _sensor(sensor: str, size: float) -> dict[str, Any]:
    return {"faults": {"sensor": [{"sensor": sensor, "kind": "bias", "onset": 10.0, "size": size}]}}


def _tyre(fraction: float) -> dict[str, Any]:
    return {"faults": {"left": [[10.0, 2.0], [10.0, 2.0 * fraction]]}}


CASES: dict[str, tuple[dict[str, Any], float, str]] = {
    "tyre step to 30 %": (_tyre(0.3), 22.0, "track"),
    "tyre step to 70 %": (_tyre(0.7), 22.0, "track"),
    "tyre step to 95 %": (_tyre(0.95), 22.0, "track"),
    "servo loss 30 %": (_actuator("loss", effectiveness=0.3), 22.0, "track"),
    "lock": (_actuator("lock"), 17.0, "stop"),
    "unresponsive": (_actuator("unresponsive"), 17.0, "stop"),
    "speed bias +0.5 m/s": (_sensor("speed", 0.5), 22.0, "track"),
    "gyro bias +0.02 rad/s": ({**_sensor("yaw_rate", 0.02), "sensors.yaw_rate_sigma": 0.01}, 22.0, "track"),
}
"""Fault name: (overrides, duration (s), ``stop`` or ``track``)."""
SENSORS: dict[str, dict[str, Any]] = {
    "speed": {},
    "pose": {"sensors.position_sigma": 0.05, "sensors.position_rate": 10.0, "sensors.pose_source": "sensor"},
    "gyro": {"sensors.yaw_rate_sigma": 0.01},
    "pose+gyro": {"sensors.position_sigma": 0.05, "sensors.position_rate": 10.0, "sensors.pose_source": "sensor",
                  "sensors.yaw_rate_sigma": 0.01},
}
"""Sensor sets (``--sensors``): ``speed`` (the scenarios' default: the speed sensor, σ 0.5 m/s, and the controller
told the true pose), ``pose`` (the benchmark's information: with 10 Hz pose fixes, σ 0.05 m and 0.05 rad, the
controller's pose the filter's), ``gyro`` (with a yaw-rate gyro, σ 0.01 rad/s, the pose told) and ``pose+gyro``.
A case's own sensor settings (the gyro bias's gyro) are kept."""
CONDITIONS = [(R, d) for R in (40.0, 50.0, 80.0, 120.0) for d in ("ccw", "cw")]
LOOPS = {"accommodated": BUILTIN["pathfollow"][1],
         "radii only": {**BUILTIN["pathfollow"][1], "reconfiguration.accommodation.mode": "radii"},
         "oracle": REFERENCE_ROWS["oracle"][1],
         "tyre from diagnosis": {**BUILTIN["pathfollow"][1], "reconfiguration.accommodation.tyre": "diagnosis"}}
"""Loop name: its settings (the benchmark's ``pathfollow`` method, it with the radii only, its ``oracle`` row, and it
with the declared tyre size as the radius — not run unless named in ``--loops``)."""
DEFAULT_LOOPS = ("accommodated", "radii only", "oracle")


def one_run(over: dict[str, Any], duration: float, kind: str, loop: str, seed: int,
            sensors: str = "speed") -> dict[str, Any]:
    """One run of ``seed`` (condition ``seed mod 8``) with the ``loop``'s settings and the ``sensors`` set; its row."""
    R, d = CONDITIONS[seed % len(CONDITIONS)]
    o = {"controller.kind": "pf-nmpc", "seed": seed, "duration": duration, "reference.radius": R,
         "reference.direction": d, "reference.speed": round(min(10.0, math.sqrt(1.5 * R)), 3),
         **SENSORS[sensors], **over, **LOOPS[loop]}
    oc = execute(load_config("scenario1", o), None, rrd=False)
    tr, m = oc.result.trace, oc.metrics
    t, v, e = tr["t"], tr["v"], np.abs(tr["cross_track_error"])
    lift = m.get("liftoff_time_post_transient_s") or 0.0
    at_rest = bool(np.all(np.abs(v[t >= 15.0]) < 0.1))
    if kind == "stop":
        ok = bool(at_rest and e.max() <= 2.0 and not m.get("tipped"))
    else:
        ok = bool(e[t >= 15.0].max() <= 0.5 and lift <= 0.2 and not m.get("tipped"))
    return {"loop": loop, "R": R, "dir": d, "seed": seed, "ok": ok, "at_rest": at_rest, "max_e": float(e.max()),
            "max_e_from_15": float(e[t >= 15.0].max()), "v_at_15": float(v[t >= 15.0][0]), "liftoff_post": lift,
            "tipped": bool(m.get("tipped"))}


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of ``k`` successes in ``n``."""
    p, d = k / n, 1.0 + z * z / n
    c, h = p + z * z / (2 * n), z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return max((c - h) / d, 0.0), min((c + h) / d, 1.0)


def _share(k: int, n: int) -> str:
    lo, hi = wilson(k, n)
    return f"{k}/{n} ({lo:.0%}–{hi:.0%})"


def _distances(g: list[dict[str, Any]]) -> list[float]:
    """The largest |e| (m) of each row: over the run for a stop, from 15 s on for a tracked fault."""
    return [r["max_e"] if r["kind"] == "stop" else r["max_e_from_15"] for r in g]


def table(rows: list[dict[str, Any]]) -> str:
    """The Markdown table of the rows: per fault and loop, successes and at-rest with intervals, the largest
    distance from the path (a stop: over the run; a tracked fault: from 15 s on), speed at 15 s, lift-off."""
    lines = ["| fault | loop | success (95 % interval) | at rest from 15 s (95 % interval) | max \\|e\\| (m): median "
             "[range] | \\|v\\| at 15 s (m/s): median | lift-off after transients (s): median |",
             "|---|---|---|---|---|---|---|"]
    for case in dict.fromkeys(r["case"] for r in rows):
        for loop in LOOPS:
            g = [r for r in rows if r["case"] == case and r["loop"] == loop]  # loops not run have no rows
            if not g:
                continue
            e = _distances(g)
            lines.append(f"| {case} ({g[0]['kind']}) | {loop} | {_share(sum(r['ok'] for r in g), len(g))} | "
                         f"{_share(sum(r['at_rest'] for r in g), len(g)) if g[0]['kind'] == 'stop' else '—'} | "
                         f"{st.median(e):.2f} [{min(e):.2f}, {max(e):.2f}] | "
                         f"{st.median(abs(r['v_at_15']) for r in g):.2f} | "
                         f"{st.median(r['liftoff_post'] for r in g):.2f} |")
    return "\n".join(lines)


SET_NAMES = {"speed": "speed sensor, pose told", "pose": "pose sensor (the benchmark's)",
             "gyro": "speed sensor + gyro, pose told", "pose+gyro": "pose sensor + gyro"}
"""Column headings of :func:`sets_table`."""


def sets_table(rows: list[dict[str, Any]]) -> str:
    """The Markdown table of rows of several sensor sets, a column each (docs/findings.md's per-mode table): per
    fault and loop, successes (Wilson 95 %); the largest |e| (m; a stop: over the run, a tracked fault: from 15 s
    on), median [range]; lift-off after the transients (s), median."""
    sets = list(dict.fromkeys(r["sensors"] for r in rows))
    lines = ["| fault | loop | " + " | ".join(SET_NAMES.get(s, s) for s in sets) + " |",
             "|---|---|" + "---|" * len(sets)]
    for case in dict.fromkeys(r["case"] for r in rows):
        for loop in LOOPS:
            cells = []
            for s in sets:
                g = [r for r in rows if r["case"] == case and r["loop"] == loop and r["sensors"] == s]
                if not g:
                    cells.append("—")
                    continue
                e = _distances(g)
                cells.append(f"{_share(sum(r['ok'] for r in g), len(g))}; {st.median(e):.2f} [{min(e):.2f}, "
                             f"{max(e):.2f}]; {st.median(r['liftoff_post'] for r in g):.2f}")
            if any(c != "—" for c in cells):
                kind = next(r["kind"] for r in rows if r["case"] == case)
                lines.append(f"| {case} ({kind}) | {loop} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def seed_range(text: str) -> list[int]:
    """``"0-4"`` → [0, 1, 2, 3, 4]; ``"1000,1003"`` → [1000, 1003]."""
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out += list(range(int(lo), int(hi or lo) + 1))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0-4", help="seeds, e.g. 0-4 or 1000-1009 or 3,5 (default 0-4)")
    ap.add_argument("--cases", default=None, help="comma-separated fault names (default: all)")
    ap.add_argument("--loops", default=",".join(DEFAULT_LOOPS), help=f"comma-separated loops of {list(LOOPS)}")
    ap.add_argument("--sensors", default="speed", choices=list(SENSORS),
                    help="sensor set (default speed: the scenarios' speed sensor, the pose told)")
    ap.add_argument("--out", default=None, help="also write the rows (JSON lines) here")
    ap.add_argument("--rows", default=None, help="print the table of rows written by --out, run nothing; several "
                                                 "files (comma-separated): one column per sensor set")
    args = ap.parse_args()
    if args.rows:
        rows = []
        for name in args.rows.split(","):
            with open(name) as f:
                rows += [json.loads(line) for line in f]
        print(table(rows) if "," not in args.rows else sets_table(rows))
        return
    cases = CASES if args.cases is None else {c: CASES[c] for c in args.cases.split(",")}
    rows = []
    for case, (over, duration, kind) in cases.items():
        for loop in args.loops.split(","):
            for seed in seed_range(args.seeds):
                row = {"case": case, "kind": kind, "sensors": args.sensors,
                       **one_run(over, duration, kind, loop, seed, args.sensors)}
                rows.append(row)
                print(json.dumps(row), flush=True)
    if args.out:
        with open(args.out, "w") as f:
            f.writelines(json.dumps(r) + "\n" for r in rows)
    print(f"sensors: {args.sensors}")
    print(table(rows))


if __name__ == "__main__":
    main()
