"""Benchmark of the Rerun recorder: column-wise :func:`ftc_mj.rerun.record.write_rrd` against the naive
per-step ``log()`` approach for the same data (a synthetic 40 s, 100 Hz run with 400 NMPC solves).

Usage::

    .venv/bin/python benchmarks/bench_recorder.py [--duration 40] [--naive-rows 800] [--repeat 5]

The naive writer logs the same entities one step at a time (``set_time`` + one ``log()`` per entity
per step); it is timed on the first ``--naive-rows`` rows and scaled linearly to the whole run
(``--naive-rows 0`` = the whole run). Its file size is scaled the same way.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import rerun as rr

from ftc_mj.rerun.record import write_rrd
from ftc_mj.telemetry import Event, Solve

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository root: tests.support
from tests.support.synthetic import scalar_series, synthetic_run  # noqa: E402

RUN_BUDGET_S = 1.5
"""Wall time of a whole 40 s run the recorder budget is compared with (≤ 5 %)."""


def naive_write(path: Path, trace: dict[str, np.ndarray], solves: list[Solve], events: list[Event],
                reference: np.ndarray, rows: int) -> None:
    """The per-step way: ``log()`` every entity at every step of the first ``rows`` rows."""
    rec = rr.RecordingStream("ftc-mj-naive", recording_id="naive")
    rec.save(path)
    rec.log("/world/reference", rr.LineStrips3D([np.column_stack([reference, np.zeros(len(reference))])]),
            static=True)
    scal = scalar_series(trace)
    t = trace["t"]
    solve_at = {int(round(s.t * 100)): s for s in solves}
    ev_at: dict[int, list[Event]] = {}
    for e in events:
        ev_at.setdefault(int(round(e.t * 100)), []).append(e)
    axle = rr.RotationAxisAngle(axis=[1, 0, 0], degrees=90)
    for i in range(rows):
        rec.set_time("step", sequence=i)
        rec.set_time("sim_time", duration=np.timedelta64(int(round(t[i] * 1e9)), "ns"))
        for ent, arr in scal.items():
            rec.log(ent, rr.Scalars(arr[i]))
        psi = trace["psi"][i]
        rec.log("/world/robot", rr.Transform3D(translation=[trace["x"][i], trace["y"][i], trace["z"][i]],
                                               quaternion=rr.Quaternion(xyzw=[0, 0, np.sin(psi / 2),
                                                                              np.cos(psi / 2)])))
        for side, col, sign in (("right", "R_R", -1), ("left", "R_L", 1)):
            rec.log(f"/world/robot/wheel_{side}",
                    rr.Cylinders3D(lengths=[0.3], radii=[trace[col][i]], centers=[[0, sign * 1.0, 0]],
                                   rotation_axis_angles=[axle]))
        if i % 50 == 0:
            rec.log("/world/path", rr.LineStrips3D([np.column_stack([trace["x"][:i + 1:10], trace["y"][:i + 1:10],
                                                                     np.zeros(len(range(0, i + 1, 10)))])]))
        s = solve_at.get(i)
        if s is not None:
            rec.log("/world/prediction", rr.LineStrips3D([np.column_stack([s.predicted[:, :2],
                                                                           np.zeros(len(s.predicted))])]))
            rec.log("/solver/solve_time_ms", rr.Scalars(s.solve_time_ms))
            rec.log("/solver/iterations", rr.Scalars(float(s.iterations)))
            rec.log("/solver/status", rr.Scalars(1.0 if s.ok else 0.0))
        for e in ev_at.get(i, []):
            rec.log("/events", rr.TextLog(e.text, level=e.level.upper()))
    rec.flush()
    rec.disconnect()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=40.0)
    ap.add_argument("--naive-rows", type=int, default=800, help="rows timed for the naive writer (0 = all)")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()

    trace, solves, events, ref = synthetic_run(args.duration, n_modes=3)
    n = len(trace["t"])
    rows = n if args.naive_rows <= 0 else min(args.naive_rows, n)
    with tempfile.TemporaryDirectory() as d:
        out = Path(d)
        # first call in the process (cold: lazy imports, first RecordingStream, style cache) - what a
        # single run in a fresh process pays
        t0 = time.perf_counter()
        write_rrd(out / "warm.rrd", trace, run_id="warm", solves=solves, events=events, reference_path=ref,
                  n_modes=3)
        cold_s = time.perf_counter() - t0
        times = []
        for k in range(args.repeat):
            t0 = time.perf_counter()
            write_rrd(out / f"col{k}.rrd", trace, run_id=f"col{k}", solves=solves, events=events,
                      reference_path=ref, n_modes=3)
            times.append(time.perf_counter() - t0)
        col_s = statistics.median(times)
        col_mb = (out / "col0.rrd").stat().st_size / 1e6

        t0 = time.perf_counter()
        naive_write(out / "naive.rrd", trace, solves, events, ref, rows)
        naive_s = (time.perf_counter() - t0) * n / rows
        naive_mb = (out / "naive.rrd").stat().st_size / 1e6 * n / rows

    print(f"synthetic run: {args.duration:g} s, {n} rows at 100 Hz, {len(solves)} solves, 3 IMM modes, "
          f"{len(events)} events")
    print(f"naive writer timed on {rows} rows and scaled x{n / rows:.2f}\n")
    hdr = f"| {'writer':<34} | {'time ms':>9} | {'µs/step':>8} | {'% of 1.5 s run':>14} | {'.rrd MB':>8} |"
    print(hdr)
    print("|" + "|".join("-" * (len(c)) for c in hdr.split("|")[1:-1]) + "|")
    for name, s, mb in (("columns: write_rrd, first call", cold_s, col_mb),
                        (f"columns: write_rrd (median of {args.repeat})", col_s, col_mb),
                        ("naive per-step log()", naive_s, naive_mb)):
        print(f"| {name:<34} | {s * 1e3:9.1f} | {s / n * 1e6:8.1f} | {100 * s / RUN_BUDGET_S:13.1f}% | {mb:8.2f} |")
    print(f"\nspeed-up: {naive_s / col_s:.0f}x; min/max columns time {min(times) * 1e3:.1f}/"
          f"{max(times) * 1e3:.1f} ms")


if __name__ == "__main__":
    main()
