"""The first run after an install: what a user waits for the numba kernels and the IPOPT solvers to be
compiled and built, against the second run of the same command.

    .venv/bin/python benchmarks/bench_first_run.py [--estimators ukf ekf imm-ukf] [--baseline OTHER_CHECKOUT]

For each estimator, ``ftc-mj run scenario2 --estimator E --duration 0.1 --no-rrd -q`` runs twice in
fresh processes with empty caches of their own (``NUMBA_CACHE_DIR`` and ``FTC_MJ_CACHE_DIR`` in a new
temporary folder: nothing compiled or built before): the first run compiles and builds, the second
loads. The table gives wall and CPU (user + system) seconds of both and the first run's excess
(first − second); the start-up issue's target is an excess ≤ 15 s. ``--baseline`` times another
checkout the same way right after this one, estimator by estimator, so both see the same machine load.
On a shared machine, read the CPU seconds: the wall time grows with the load, the compile work does not.

``--first-command``: the README's first command after the install, timed whole: with empty caches,
``ftc-mj warm-up`` (its two processes' CPU included), then ``ftc-mj run scenario2 --no-rrd -q`` (the full
40 s run, which reaches the compiled real-time iteration, unlike a 0.1 s run) and that run again; beside it,
in new empty caches, the same run twice without the warm-up.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CLI = "import sys; from ftc_mj.cli import app; sys.argv[0] = 'ftc-mj'; sys.exit(app())"


def timed(code: Path, estimator: str, caches: Path, command: list[str] | None = None) -> tuple[float, float]:
    """(wall s, CPU s, its child processes' included) of one ``ftc-mj run`` of this ``code`` with its caches in
    ``caches`` (or of ``ftc-mj COMMAND``)."""
    env = dict(os.environ, PYTHONPATH=str(code), NUMBA_CACHE_DIR=str(caches / "numba"),
               FTC_MJ_CACHE_DIR=str(caches / "ftc-mj"), OMP_NUM_THREADS="1")
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    args = [sys.executable, "-c", CLI, *(command or ["run", "scenario2", "--estimator", estimator, "--duration",
                                                     "0.1", "--no-rrd", "-q", "--out", str(caches / "out")])]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    proc = subprocess.run(args, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                          cwd=tempfile.gettempdir())
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{code} {estimator}: exit {proc.returncode}: {proc.stderr.strip()[-500:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def first_and_second(code: Path, estimator: str) -> tuple[tuple[float, float], tuple[float, float]]:
    """The first and the second run's (wall, CPU) seconds with empty caches before the first."""
    with tempfile.TemporaryDirectory(prefix="ftc-first-run-") as d:
        return timed(code, estimator, Path(d)), timed(code, estimator, Path(d))


def first_command(code: Path) -> None:
    """The README's first command (warm-up, then the default run) and the same run without the warm-up (printed)."""
    run = ["run", "scenario2", "--no-rrd", "-q", "--out"]
    rows = []
    with tempfile.TemporaryDirectory(prefix="ftc-first-run-") as d:
        rows.append(("ftc-mj warm-up (empty caches)", timed(code, "", Path(d), ["warm-up"])))
        rows.append(("then ftc-mj run scenario2", timed(code, "", Path(d), [*run, f"{d}/out"])))
        rows.append(("that run again", timed(code, "", Path(d), [*run, f"{d}/out"])))
    with tempfile.TemporaryDirectory(prefix="ftc-first-run-") as d:
        rows.append(("ftc-mj run scenario2 without the warm-up (empty caches)", timed(code, "", Path(d),
                                                                                      [*run, f"{d}/out"])))
        rows.append(("that run again", timed(code, "", Path(d), [*run, f"{d}/out"])))
    print("| command | wall (s) | CPU (s) |\n|---|---|---|")
    for label, (wall, cpu) in rows:
        print(f"| {label} | {wall:.1f} | {cpu:.1f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--estimators", nargs="+", default=["ukf", "ekf", "imm-ukf"])
    ap.add_argument("--baseline", type=Path, help="another checkout, timed the same way in this run")
    ap.add_argument("--first-command", action="store_true", help="time the README's first command (module doc)")
    args = ap.parse_args()
    if args.first_command:
        print(f"load average at start: {os.getloadavg()[0]:.2f}\n")
        first_command(ROOT)
        print(f"\nload average at end: {os.getloadavg()[0]:.2f}")
        return
    codes = [("this", ROOT)] + ([("baseline", args.baseline.resolve())] if args.baseline else [])
    print(f"load average at start: {os.getloadavg()[0]:.2f}\n")
    print("| estimator | code | first wall (s) | first CPU (s) | second wall (s) | second CPU (s) | "
          "excess wall (s) | excess CPU (s) |")
    print("|---|---|---|---|---|---|---|---|")
    for est in args.estimators:
        for label, code in codes:
            (w1, c1), (w2, c2) = first_and_second(code, est)
            print(f"| {est} | {label} | {w1:.1f} | {c1:.1f} | {w2:.1f} | {c2:.1f} | {w1 - w2:.1f} | {c1 - c2:.1f} |",
                  flush=True)
    print(f"\nload average at end: {os.getloadavg()[0]:.2f}; target: excess ≤ 15 s on an idle machine")


if __name__ == "__main__":
    main()
