"""The built-in diagnoser's cost per run, alone: its inputs recorded from benchmark runs, replayed.

    .venv/bin/python benchmarks/bench_diagnoser.py [--method safe] [--benchmark ftc-v2] [--draws 4]
        [--repeat 5] [--baseline OTHER_CHECKOUT]

Runs ``--method`` on dev draws ``--start``… of ``--benchmark`` for ``--duration`` s as a bench worker runs them,
recording every :class:`~ftc_mj.estimation.diagnosis.DiagnosisInput` the loop hands the
:class:`~ftc_mj.estimation.diagnosis.ResidualDiagnoser` (with its settings, run context and fast tyre detector as
built), then steps a fresh
diagnoser through each recording ``--repeat`` times and prints the CPU seconds (``time.process_time``) per run
and per step: median and minimum over the repeats. ``--baseline``: the same recordings replayed by another
checkout's diagnoser in a child process (``PYTHONPATH``) in alternating rounds, and its statistics, alarms and
declarations compared with this checkout's at every step (bitwise; NaN equal to NaN).

The loop's other costs of the diagnosis (building the input, the trace row) are not in these numbers:
``bench_bench.py`` times whole runs. On a shared machine, read the ratio, not the seconds.
"""

from __future__ import annotations

import argparse
import copy
import math
import os
import pickle
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import astuple
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]


def record(method: str, version: str, draws: list[int], duration: float) -> list[dict[str, Any]]:
    """``{"settings", "context", "inputs"}`` of the diagnoser of each run of ``method`` on dev ``draws``."""
    from ftc_mj.benchmark.draws import draw
    from ftc_mj.benchmark.methods import load_methods
    from ftc_mj.benchmark.run import bench_run
    from ftc_mj.estimation.diagnosis import residual

    m = load_methods([method])[0]
    runs: list[dict[str, Any]] = []
    init, step = residual.ResidualDiagnoser.__init__, residual.ResidualDiagnoser.step

    def recording_init(self: Any, settings: Any, context: Any, change: Any = None) -> None:
        runs.append({"settings": settings, "context": context, "change": copy.deepcopy(change), "inputs": []})
        init(self, settings, context, change)

    def recording_step(self: Any, z: Any) -> Any:
        runs[-1]["inputs"].append(copy.deepcopy(z))
        return step(self, z)

    residual.ResidualDiagnoser.__init__, residual.ResidualDiagnoser.step = recording_init, recording_step
    try:
        for i in draws:
            scenario = draw("dev", i, version=version).scenario()
            scenario["duration"] = duration
            bench_run(m.apply(scenario), None, False)
    finally:
        residual.ResidualDiagnoser.__init__, residual.ResidualDiagnoser.step = init, step
    return runs


def replay(runs: list[dict[str, Any]]) -> tuple[float, list[list[tuple]]]:
    """CPU seconds to step a fresh diagnoser through every recording, and each step's output as plain tuples."""
    from ftc_mj.estimation.diagnosis import ResidualDiagnoser

    outputs: list[list[tuple]] = []
    t = time.process_time()
    for run in runs:
        d = ResidualDiagnoser(run["settings"], run["context"], copy.deepcopy(run.get("change")))
        outputs.append([(tuple(o.statistics.items()), tuple(o.alarms.items()), tuple(astuple(x) for x in o.new))
                        for o in map(d.step, run["inputs"])])
    return time.process_time() - t, outputs


def child(path: str, repeat: int) -> None:
    """The ``--child`` mode: replay the pickled recordings ``repeat`` times; pickle the times and outputs."""
    runs = pickle.loads(Path(path).read_bytes())
    times, outputs = [], None
    for _ in range(repeat):
        dt, outputs = replay(runs)
        times.append(dt)
    Path(path + ".out").write_bytes(pickle.dumps((times, outputs)))


def same(a: Any, b: Any) -> bool:
    """Equal nested tuples of floats, NaN equal to NaN."""
    if isinstance(a, tuple) and isinstance(b, tuple):
        return len(a) == len(b) and all(same(u, v) for u, v in zip(a, b, strict=True))
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return bool(a == b)


def in_checkout(code: Path, path: str, repeat: int) -> tuple[list[float], list[list[tuple]]]:
    """:func:`child` run by the checkout ``code`` (first on ``PYTHONPATH``)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in (str(code), os.environ.get("PYTHONPATH", "")) if p))
    subprocess.run([sys.executable, __file__, "--child", path, "--repeat", str(repeat)], env=env, check=True,
                   cwd=tempfile.gettempdir())
    return pickle.loads(Path(path + ".out").read_bytes())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--method", default="safe")
    ap.add_argument("--benchmark", default="ftc-v2")
    ap.add_argument("--draws", type=int, default=4)
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--duration", type=float, default=30.0)
    ap.add_argument("--repeat", type=int, default=5, help="replays (alternating rounds with --baseline)")
    ap.add_argument("--baseline", type=Path, help="another checkout whose diagnoser replays the same recordings")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.child, args.repeat)
        return
    runs = record(args.method, args.benchmark, list(range(args.start, args.start + args.draws)), args.duration)
    steps = sum(len(r["inputs"]) for r in runs)
    with tempfile.TemporaryDirectory(prefix="bench-diagnoser.") as tmp:
        path = str(Path(tmp) / "runs.pkl")
        Path(path).write_bytes(pickle.dumps(runs))
        codes = [("this checkout", ROOT)] + ([("baseline", args.baseline.resolve())] if args.baseline else [])
        times: dict[str, list[float]] = {label: [] for label, _ in codes}
        outputs: dict[str, Any] = {}
        for _ in range(args.repeat):  # alternating rounds, one replay each, in child processes
            for label, code in codes:
                dt, outputs[label] = in_checkout(code, path, 1)
                times[label] += dt
    print(f"{args.method} on {args.benchmark} dev draws {args.start}-{args.start + args.draws - 1} "
          f"({args.duration:g} s, {steps} diagnoser steps); CPU per run over {args.repeat} replays\n")
    print("| diagnoser | median s per run | min s per run | µs per step |")
    print("|---|---|---|---|")
    for label, ts in times.items():
        med = statistics.median(ts)
        print(f"| {label} | {med / len(runs):.4f} | {min(ts) / len(runs):.4f} | {med / steps * 1e6:.1f} |")
    if args.baseline:
        ratio = statistics.median(times["this checkout"]) / statistics.median(times["baseline"])
        equal = same(tuple(map(tuple, outputs["this checkout"])), tuple(map(tuple, outputs["baseline"])))
        print(f"\nthis checkout / baseline: {ratio:.2f}; every step's statistics, alarms and declarations "
              f"{'equal' if equal else 'DIFFER'}")


if __name__ == "__main__":
    main()
