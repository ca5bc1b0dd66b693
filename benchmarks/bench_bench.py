"""A benchmark draw's cost next to its physics, per method, and ``ftc-mj bench``'s throughput.

    .venv/bin/python benchmarks/bench_bench.py [--rounds 3] [--duration 30] [--methods paper safe ...]
    .venv/bin/python benchmarks/bench_bench.py --throughput [--draws 4] [--workers 2] [--duration 10]

**The draw table** (default): in one process, each method runs ``--rounds`` new dev draws one after the other,
as a bench worker runs them (:func:`~ftc_mj.benchmark.run.bench_run`; ``ftc-mj bench`` plans its runs method by
method; the per-process cache kept between runs as a worker keeps it; a warm-up run of the method first, not
timed, so solvers and kernels come from their caches; ``--interleave``: each round runs every method once, so
each run follows another method's and pays what switching costs: the memory budget's eviction and reloads),
timed with ``time.process_time`` (CPU s), and then replays the run's plant commands on a copy of the drawn
robot's initial ``MjData`` with bare ``mj_step`` for the same simulated time: *× bare physics* is the
median over rounds of each round's ratio. The run's parts are timed inside it (class-level wrappers, the
outermost call of a kind only): *physics* (the plant's ``advance``), *filter* (the UKF's ``step``), *QPs*
(the RTI QPs' ``solve``), *IPOPT* (every IPOPT solve; *seed*: the first of the run), *solver build/load*
(getting the IPOPT solver: from memory, the disk cache or a build; not counted in the solves). *floor* = physics +
filter + QPs + one IPOPT seed, each at the cost measured in the same run (the performance issue's
target: a draw ≤ 1.5× its floor; paper, safe, feedback-off ≤ 3× bare physics, the others ≤ 6×). Below the
table: the solver cache's entries after the warm-up and after the timed draws (it must not grow with new
draws: one path-following solver per path kind) and the process's peak resident set.

**The throughput comparison** (``--throughput``): the runs of ``ftc-mj bench`` on the study runner, each
scored in its worker, then the outputs, next to the same run configs on the same runner with the study's
default worker function (metrics only); each path starts its own LocalCluster of ``--workers`` processes;
the paths run in the order plain, bench, bench, plain (``--repeats 2``) and each path's best wall time counts.

On a shared machine, read the ratios, not the seconds.
"""

from __future__ import annotations

import argparse
import copy
import resource
import statistics
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import mujoco

from ftc_mj.benchmark.draws import draw
from ftc_mj.benchmark.methods import BUILTIN, load_methods
from ftc_mj.benchmark.report import write_outputs
from ftc_mj.benchmark.run import bench_run, plan_bench, prepare_output
from ftc_mj.control import condensed_qp, multistage_qp, nmpc, pathfollow_nlp, pathfollow_qp, robust, solver_cache
from ftc_mj.estimation.ukf import UKF
from ftc_mj.plant.robot import Plant
from ftc_mj.study.runner import run_study

PARTS = ("physics", "filter", "QPs", "IPOPT", "solver build/load")


class Timers:
    """CPU seconds per part of one run, the IPOPT solves' times and the plant's held commands."""

    def __init__(self) -> None:
        self.s = dict.fromkeys(PARTS, 0.0)
        self.ipopt: list[float] = []
        self.ctrl: list[tuple[Any, int]] = []
        self.active: set[str] = set()

    def wrap(self, fn: Callable[..., Any], part: str) -> Callable[..., Any]:
        """``fn`` timed as ``part`` (a call inside a call of the same part is not counted twice)."""

        def timed(*args: Any, **kwargs: Any) -> Any:
            if part in self.active:
                return fn(*args, **kwargs)
            self.active.add(part)
            t, built = time.process_time(), self.s["solver build/load"]
            try:
                return fn(*args, **kwargs)
            finally:  # a solver built or loaded inside (the path NLP's, on its first solve) is not this part's
                dt = time.process_time() - t - (self.s["solver build/load"] - built)
                self.s[part] += dt
                if part == "IPOPT":
                    self.ipopt.append(dt)
                self.active.discard(part)

        return timed


@contextmanager
def instrumented(timers: Timers) -> Iterator[None]:
    """Class- and module-level wrappers that time the run's parts into ``timers`` (removed on exit)."""
    patches = [(UKF, "step", "filter"), (condensed_qp.CondensedQP, "solve", "QPs"),
               (multistage_qp.MultiStageQP, "solve", "QPs"), (pathfollow_qp.PathQP, "solve", "QPs"),
               (nmpc, "warm_started_solve", "IPOPT"), (robust, "warm_started_solve", "IPOPT"),
               (pathfollow_nlp.PathNLP, "solve", "IPOPT"), (nmpc, "ipopt_solver", "solver build/load"),
               (robust, "ipopt_solver", "solver build/load"), (pathfollow_nlp, "ipopt_solver", "solver build/load")]
    saved = [(obj, name, vars(obj).get(name)) for obj, name, _ in patches]
    advance = Plant.advance

    def physics(plant: Any, n: int) -> None:
        timers.ctrl.append((plant.data.ctrl.copy(), int(n)))
        advance(plant, n)

    for obj, name, part in patches:
        setattr(obj, name, timers.wrap(getattr(obj, name), part))
    Plant.advance = timers.wrap(physics, "physics")
    try:
        yield
    finally:
        for obj, name, old in saved:
            if old is None:  # inherited: the class's own attribute goes again
                delattr(obj, name)
            else:
                setattr(obj, name, old)
        del Plant.advance


def bare_physics(model: Any, d0: Any, ctrl: list[tuple[Any, int]]) -> float:
    """CPU seconds of bare ``mj_step`` on a copy of ``d0`` through the held commands ``ctrl``."""
    d = copy.deepcopy(d0)
    t = time.process_time()
    for c, n in ctrl:
        d.ctrl[:] = c
        mujoco.mj_step(model, d, n)
    return time.process_time() - t


def timed_draw(method: Any, index: int, duration: float) -> dict[str, float]:
    """One method on dev draw ``index`` as a bench worker runs it: CPU s of the run, of its parts, of the
    IPOPT seed, of bare physics through the same commands, and the floor."""
    from ftc_mj.sim import cache

    scenario = draw("dev", index).scenario()
    scenario["duration"] = duration
    cfg = method.apply(scenario)
    plant = cache.plant_for(cfg)  # the plant the run gets (built now, reset again by the run)
    model, d0 = plant.model, copy.deepcopy(plant.data)
    timers = Timers()
    with instrumented(timers):
        t = time.process_time()
        bench_run(cfg, None, False)
        cpu = time.process_time() - t
    row = {"cpu": cpu, **timers.s, "seed": timers.ipopt[0] if timers.ipopt else 0.0,
           "ipopt_solves": float(len(timers.ipopt)), "bare": bare_physics(model, d0, timers.ctrl)}
    row["floor"] = row["physics"] + row["filter"] + row["QPs"] + row["seed"]
    return row


def draw_table(methods: list[str], rounds: int, duration: float, first: int, interleave: bool = False) -> None:
    """Print the draw table (module docstring): medians over ``rounds`` new draws per method, the methods one
    after the other as a bench worker runs them (``ftc-mj bench`` plans its runs method by method), or with
    ``interleave`` every method once per round (each run then follows another method's)."""
    ms = load_methods(methods)
    rows: dict[str, list[dict[str, float]]] = {m.name: [] for m in ms}
    entries = solver_entries()

    def warm_up(m: Any) -> None:  # solvers, kernels and plant from their caches, as in a worker's later runs
        timed_draw(m, first + rounds, min(duration, 2.0))

    if interleave:
        for m in ms:
            warm_up(m)
        for r in range(rounds):
            for m in ms:
                rows[m.name].append(timed_draw(m, first + r, duration))
    else:
        for m in ms:
            warm_up(m)
            rows[m.name] = [timed_draw(m, first + r, duration) for r in range(rounds)]
    order = "every method once per round" if interleave else "method by method, as a bench worker runs them"
    print(f"CPU per {duration:g} s draw (dev draws {first}-{first + rounds - 1}, new to the process, {order}, each "
          f"method after one warm-up draw); medians of {rounds} rounds\n")
    print("| method | CPU per draw s | × bare physics | floor s | × floor | physics | filter | QPs | IPOPT "
          "(solves) | IPOPT seed | solver build/load | bare mj_step |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, rs in rows.items():
        med = {k: statistics.median(r[k] for r in rs) for k in rs[0]}
        x_bare = statistics.median(r["cpu"] / r["bare"] for r in rs)
        x_floor = statistics.median(r["cpu"] / r["floor"] for r in rs)
        print(f"| {name} | {med['cpu']:.2f} | {x_bare:.1f}× | {med['floor']:.2f} | {x_floor:.1f}× | "
              f"{med['physics']:.2f} | {med['filter']:.2f} | {med['QPs']:.2f} | {med['IPOPT']:.2f} "
              f"({med['ipopt_solves']:.0f}) | {med['seed']:.2f} | {med['solver build/load']:.2f} | {med['bare']:.2f} |")
    print(f"\nsolver cache {solver_cache.cache_dir()}: {entries} entries before the timed draws, "
          f"{solver_entries()} after the {rounds} rounds of new draws; peak RSS of this process "
          f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB")


def solver_entries() -> int:
    """How many solvers the disk cache holds (0 when it is off): the count must not grow with new draws."""
    folder = solver_cache.cache_dir()
    return len(list(folder.glob("*.casadi.z"))) if folder is not None and folder.is_dir() else 0


def throughput(args: argparse.Namespace) -> None:
    """Print the throughput comparison (module docstring)."""
    bp = plan_bench(load_methods(args.methods), "dev", args.draws)
    for r in bp.plan.runs:
        r.config["duration"] = args.duration
    order = [("plain study", None), ("bench", bench_run)]
    sequence = [p for k in range(args.repeats) for p in (order if k % 2 == 0 else order[::-1])]
    walls: dict[str, list[float]] = {label: [] for label, _ in order}
    with tempfile.TemporaryDirectory() as tmp:
        for i, (label, fn) in enumerate(sequence):
            out = Path(tmp) / f"{i}-{label.replace(' ', '_')}"
            t0 = time.perf_counter()
            prepare_output(bp, out)  # bench.json, the file the study store copies
            rep = run_study(bp.plan, out, workers=args.workers, run_fn=fn, analyse=False)
            if fn is not None:
                assert rep.results is not None
                write_outputs(bp, rep.results, out, compare=0)
            assert len(rep.computed) == len(bp.plan.runs)
            walls[label].append(time.perf_counter() - t0)
    print(f"{len(bp.plan.runs)} runs of {args.duration:g} s ({', '.join(args.methods)}; dev draws 0-{args.draws - 1}), "
          f"{args.workers} worker(s)")
    print(f"{'path':<12} {'runs':>5} {'best wall s':>12} {'runs/s':>8}   (each path {args.repeats}x)")
    for label, w in walls.items():
        n, wall = len(bp.plan.runs), min(w)
        print(f"{label:<12} {n:>5} {wall:>12.1f} {n / wall:>8.3f}   all: " + ", ".join(f"{x:.1f}" for x in w))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--throughput", action="store_true", help="The bench-versus-study throughput comparison.")
    ap.add_argument("--methods", nargs="+", default=None, help="Default: every built-in (throughput: safe).")
    ap.add_argument("--duration", type=float, default=None, help="Simulated s per run (30; throughput: 10).")
    ap.add_argument("--rounds", type=int, default=3, help="Draw table: new draws per method.")
    ap.add_argument("--interleave", action="store_true",
                    help="Draw table: every method once per round instead of method by method (as a bench worker).")
    ap.add_argument("--first", type=int, default=10, help="Draw table: the first dev draw timed.")
    ap.add_argument("--draws", type=int, default=4, help="Throughput: dev draws per method.")
    ap.add_argument("--workers", type=int, default=2, help="Throughput: worker processes.")
    ap.add_argument("--repeats", type=int, default=2, help="Throughput: runs of each path (alternating order).")
    args = ap.parse_args()
    if args.throughput:
        args.methods = args.methods or ["safe"]
        args.duration = args.duration or 10.0
        throughput(args)
    else:
        draw_table(args.methods or list(BUILTIN), args.rounds, args.duration or 30.0, args.first, args.interleave)


if __name__ == "__main__":
    main()
