"""Start-up of the ``ftc-mj`` command: process wall times against ``python -c "import numpy, mujoco"``.

    .venv/bin/python benchmarks/bench_startup.py [--repeat 7] [--baseline OTHER_CHECKOUT]

Each command runs as its own process (``subprocess``, timed with ``time.perf_counter``), as the console
script does: ``from ftc_mj.cli import app; app()`` with this checkout (or ``--code``) first on
``PYTHONPATH``. One round runs the reference and every command once, alternating (``--baseline``: each
command of the other checkout right after this one's); the table gives the median over ``--repeat``
rounds, the ratio to the reference's median of the same rounds and the target of the start-up issue
(``ftc-mj --help`` and ``ftc-mj scenarios`` ≤ 1.5×, a 0.1 s run ≤ 3×). A warm-up round first (not
timed) fills the caches a user's second command finds: the bytecode, the numba kernels, the solvers.

``PYTHONDONTWRITEBYTECODE`` is removed from the commands' environment (``--keep-env`` keeps it): with
it, every start compiles the package's modules from source (≈ 0.2 s), which an installed package
never does. On a shared machine, read the ratios, not the seconds.

``--importtime N``: after the table, what is left of a 0.1 s run's start: ``python -X importtime`` of one run
(caches warm), the N imports of largest cumulative time among the top-level ones and their first two levels of
children, in milliseconds (``-X importtime``'s own overhead included).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ("python -c 'import numpy, mujoco'", ["-c", "import numpy, mujoco"], None)
CLI = "import sys; from ftc_mj.cli import app; sys.argv[0] = 'ftc-mj'; sys.exit(app())"


def commands(out: str) -> list[tuple[str, list[str], float | None]]:
    """(label, python arguments, target ratio) of every timed command."""
    run = ["run", "scenario2", "--duration", "0.1", "--no-rrd", "-q", "--out", out]
    return [("ftc-mj --version", ["-c", CLI, "--version"], None),
            ("ftc-mj --help", ["-c", CLI, "--help"], 1.5),
            ("ftc-mj scenarios", ["-c", CLI, "scenarios"], 1.5),
            ("ftc-mj studies", ["-c", CLI, "studies"], None),
            ("ftc-mj run scenario2 --duration 0.1 --no-rrd -q", ["-c", CLI, *run], 3.0)]


def wall_time(args: list[str], env: dict[str, str]) -> float:
    """Seconds from starting ``python ARGS`` to its exit; the command must succeed."""
    t = time.perf_counter()
    proc = subprocess.run([sys.executable, *args], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                          text=True, cwd=tempfile.gettempdir())
    dt = time.perf_counter() - t
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(args[2:]) or args[1]}: exit {proc.returncode}: {proc.stderr.strip()[-500:]}")
    return dt


def environment(code: Path, keep: bool) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(code), env.get("PYTHONPATH", "")) if p)
    env.setdefault("OMP_NUM_THREADS", "1")
    if not keep:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def measure(codes: list[Path], repeat: int, keep: bool) -> tuple[list[float], list[list[list[float]]]]:
    """The reference's times and, per checkout and command, the times of ``repeat`` alternating rounds."""
    envs = [environment(c, keep) for c in codes]
    with tempfile.TemporaryDirectory(prefix="bench-startup.") as out:
        cmds = commands(out)
        for env in envs:  # warm-up: bytecode, numba kernels and solvers in their caches
            for _, args, _ in cmds:
                wall_time(args, env)
        ref: list[float] = []
        times = [[[] for _ in cmds] for _ in codes]
        for _ in range(repeat):
            ref.append(wall_time(REFERENCE[1], envs[0]))
            for j, (_, args, _) in enumerate(cmds):
                for i, env in enumerate(envs):
                    times[i][j].append(wall_time(args, env))
    return ref, times


def import_profile(code: Path, keep: bool, top: int) -> list[tuple[int, int, str]]:
    """``(cumulative µs, depth, module)`` of the ``top`` slowest imports at depths 0–2 of one 0.1 s run (the
    run's caches warm: run once before)."""
    env = environment(code, keep)
    with tempfile.TemporaryDirectory(prefix="bench-startup.") as out:
        args = commands(out)[-1][1]
        wall_time(args, env)
        proc = subprocess.run([sys.executable, "-X", "importtime", *args], env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.PIPE, text=True, cwd=tempfile.gettempdir(), check=True)
    rows = []
    for line in proc.stderr.splitlines():
        if line.startswith("import time:") and "cumulative" not in line:
            _, cumulative, name = line.split(":", 1)[1].split("|")
            depth = (len(name) - len(name.lstrip()) - 1) // 2
            if depth <= 2:
                rows.append((int(cumulative), depth, name.strip()))
    return sorted(rows, reverse=True)[:top]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7, help="alternating rounds (medians are reported)")
    ap.add_argument("--code", type=Path, default=ROOT, help="checkout whose ftc_mj is measured (default: this one)")
    ap.add_argument("--baseline", type=Path, help="another checkout measured in the same rounds (e.g. main)")
    ap.add_argument("--keep-env", action="store_true", help="keep PYTHONDONTWRITEBYTECODE if set")
    ap.add_argument("--importtime", type=int, default=0, metavar="N",
                    help="also print the N slowest imports of a 0.1 s run (python -X importtime)")
    args = ap.parse_args()
    codes = [args.code.resolve()] + ([args.baseline.resolve()] if args.baseline else [])
    ref, times = measure(codes, args.repeat, args.keep_env)
    r = statistics.median(ref)
    print(f"median of {args.repeat} alternating rounds; reference {REFERENCE[0]}: {r:.3f} s "
          f"(min {min(ref):.3f}, max {max(ref):.3f})\n")
    base = "" if len(codes) == 1 else " baseline (s) | baseline ratio |"
    head = f"| command | target |{base} time (s) | ratio |"
    print(head)
    print("|---" * head.count(" |") + "|")
    for j, (label, _, target) in enumerate(commands("OUT")):
        med = [statistics.median(t[j]) for t in times]
        cells = [label, f"≤ {target:g}×" if target else "–"]
        if len(codes) > 1:
            cells += [f"{med[1]:.3f}", f"{med[1] / r:.1f}×"]
        cells += [f"{med[0]:.3f}", f"{med[0] / r:.1f}×"]
        print("| " + " | ".join(cells) + " |")
    if args.importtime:
        print(f"\nThe {args.importtime} slowest imports (depth ≤ 2) of a 0.1 s run, cumulative ms (-X importtime):\n")
        for us, depth, name in import_profile(codes[0], args.keep_env, args.importtime):
            print(f"{'  ' * depth}{us / 1e3:7.1f}  {name}")


if __name__ == "__main__":
    main()
