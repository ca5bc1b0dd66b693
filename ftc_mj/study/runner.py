"""Run a study plan on dask.distributed (or serially in-process), persisting each row as it arrives.

The client submits the missing runs, iterates ``as_completed`` and writes each result as
``OUT/rows/<key>.parquet`` atomically the moment it arrives, so an interruption (Ctrl-C, a killed
client, a lost worker) loses at most the runs in flight. Re-running the same command computes
only the runs without a row. ``results.parquet`` is collected at the end.

The cluster (:mod:`.cluster`) and the rows (:mod:`.rows`) have their own modules.
"""

from __future__ import annotations

import contextlib
import json
import signal
import threading
import time
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import polars as pl

from ..errors import BadInput
from ..identity import source_revision
from ..io import writer_lock
from .cluster import open_client, validate_address
from .plan import PlannedRun, StudyPlan
from .rows import failed_result, make_row
from .store import StudyStore
from .worker import RunFn, run_one

RrdMode = Literal["none", "failures", "all", "compare"]
"""What ``--rrd`` keeps: no run folder, those of failed runs, all, all plus an overlay recording."""


class StudyInterruptedError(Exception):
    """The study was interrupted (Ctrl-C); every finished run has been persisted."""


@dataclass
class StudyReport:
    """What one invocation did."""

    out: Path
    invocation: str
    planned: int
    already_done: int
    computed: list[str] = field(default_factory=list)
    failed: list[str] = field(default_factory=list)
    """Keys of computed runs whose status is not ok (including ``unstable``)."""
    unstable: list[str] = field(default_factory=list)
    """Keys of computed runs whose physics became unstable (status ``unstable``)."""
    outcomes: dict[str, int] = field(default_factory=dict)
    """How many computed runs ended with each physical outcome (``on the path``, ``off the path``,
    ``tipped over``, ``not judged``: :mod:`ftc_mj.metrics.outcome`)."""
    wall_time_s: float = 0.0
    results: pl.DataFrame | None = None

    @property
    def runs_per_min(self) -> float:
        return 60.0 * len(self.computed) / self.wall_time_s if self.wall_time_s > 0 else float("nan")


# ---------------------------------------------------------------------------- run
def plan_todo(plan: StudyPlan, store: StudyStore, *, retry_failed: bool = False,
              limit: int | None = None) -> tuple[list[PlannedRun], int]:
    """Runs still to compute (plan order) and how many of the plan are already done."""
    done = store.done_keys()
    if retry_failed:
        done -= store.failed_keys()
    todo = [r for r in plan.runs if r.key not in done]
    already = len(plan.runs) - len(todo)
    if limit is not None and limit < len(todo):
        todo = covering_order(todo, plan.axis_columns)[: max(0, limit)]
    return todo, already


def covering_order(runs: list[PlannedRun], columns: list[str]) -> list[PlannedRun]:
    """``runs`` reordered so that a prefix covers as many axis values as it can: greedily the run adding
    the most ``(axis, label)`` pairs not yet taken (ties: the seed first in the plan, then plan order);
    once every value is taken, the rest by seed, then plan order. ``--limit N`` takes the first N, so
    a small N samples every axis instead of the seeds of the first combination."""
    seed_rank = {sd: i for i, sd in enumerate(dict.fromkeys(r.seed for r in runs))}
    rest = sorted(runs, key=lambda r: (seed_rank[r.seed], r.index))

    def pairs(r: PlannedRun) -> set[tuple[str, str]]:
        return {(c, json.dumps(r.labels.get(c), default=str)) for c in columns}

    wanted = set().union(*(pairs(r) for r in rest)) if rest else set()
    covered: set[tuple[str, str]] = set()
    picked: list[PlannedRun] = []
    while rest and covered != wanted:
        gains = [len(pairs(r) - covered) for r in rest]
        best = max(range(len(rest)), key=lambda i: (gains[i], -i))
        covered |= pairs(rest[best])
        picked.append(rest.pop(best))
    return picked + rest


def describe_selection(todo: list[PlannedRun], columns: list[str], missing: int) -> str:
    """One line saying which runs a ``--limit`` took: their number, the axis values and seeds covered."""
    parts = []
    for c in columns:
        vals = list(dict.fromkeys(str(r.labels.get(c)) for r in todo))
        parts.append(f"{c} {', '.join(vals)}")
    parts.append("seeds " + ", ".join(str(s) for s in dict.fromkeys(r.seed for r in todo)))
    return f"--limit: computing {len(todo)} of {missing} missing runs, covering " + "; ".join(parts)


def run_study(
    plan: StudyPlan,
    out: Path,
    *,
    workers: int = 2,
    address: str | None = None,
    client: Any | None = None,
    serial: bool = False,
    rrd: RrdMode = "none",
    limit: int | None = None,
    retry_failed: bool = False,
    run_fn: RunFn | None = None,
    progress: bool = False,
    analyse: bool = True,
    on_row: Callable[[dict[str, Any]], None] | None = None,
    dashboard: str = "127.0.0.1:0",
    echo: Callable[[str], None] | None = None,
    client_workers: int | None = None,
) -> StudyReport:
    """Compute the plan's missing runs into ``out`` and collect/analyse the results.

    Execution: ``serial`` runs in this process (no dask); else ``client`` if given (left open),
    else a connection to ``address``, else a LocalCluster of ``workers`` processes (dashboard at
    ``dashboard``). Validation of the output folder and of the address happens before anything is
    written. ``rrd = "compare"`` keeps every run's folder (like ``all``) and writes
    ``OUT/compare.rrd`` overlaying them (:func:`write_study_comparison`). ``echo`` receives one-line
    notes: quarantined rows, what a ``limit`` took and, with the progress bar, what starts (before the
    first run finishes); ``client_workers``: the number of worker processes of a given ``client`` that is a
    local cluster (for that line).
    """
    say = echo or (lambda _s: None)
    store = StudyStore(out)
    todo, already = _select(plan, store, address, rrd, limit, retry_failed, say)
    invocation = time.strftime("%Y%m%dT%H%M%S", time.gmtime()) + "-" + uuid.uuid4().hex[:6]
    report = StudyReport(Path(out), invocation, len(plan.runs), already)
    t0 = time.perf_counter()
    persist = _persister(store, report, on_row)
    kw = {"rrd": "all" if rrd == "compare" else rrd, "runs_dir": str(store.runs_dir) if rrd != "none" else None,
          "ts_rate": plan.spec.analysis.timeseries_rate, "ts_columns": list(plan.spec.analysis.timeseries_columns),
          "run_fn": run_fn,
          "trace_stats": [t.model_dump() for t in plan.spec.analysis.trace_stats],
          "extras": list(plan.spec.analysis.extras)}
    local = not serial and client is None and address is None
    announce = bool(todo) and progress  # with the progress bar: why it stays at 0 for a while
    if announce and (serial or local):  # before the workers start (a remote scheduler: once it answered)
        say(starting_line(len(todo), already, workers if local else None))
    selected = store.done_keys()
    with contextlib.ExitStack() as held:  # the writer's lock, from the first write to the last

        def hold() -> None:
            held.enter_context(writer_lock(store.root))
            store.reconcile_log()  # rows a killed invocation persisted but did not get to log

        with _progress(progress, len(todo), plan.spec.name) as advance:
            if not todo:
                hold()
                store.init(plan)
                store.log("start", invocation=invocation, todo=0, done_before=already)
            elif serial:
                hold()
                _run_serial(_still_missing(todo, store, selected), kw, persist, advance, store, report, plan)
            else:
                ctx = (contextlib.nullcontext(client) if client is not None
                       else open_client(workers, address, dashboard))
                with ctx as cl:
                    hold()  # once the address answered: nothing is written before
                    if announce and not local:
                        say(starting_line(len(todo), already, client_workers or "the cluster's"))
                    store.init(plan)
                    store.log("start", invocation=invocation, todo=len(todo), done_before=already,
                              backend=str(cl.scheduler.address) if hasattr(cl, "scheduler") else "dask")
                    _run_dask(cl, _still_missing(todo, store, selected), kw, persist, advance, store, report, plan)
        report.wall_time_s = time.perf_counter() - t0
        _finish(plan, store, report, rrd, analyse, say)
    return report


def _still_missing(todo: list[PlannedRun], store: StudyStore, selected: set[str]) -> list[PlannedRun]:
    """The runs of ``todo`` no other process has persisted since they were selected (``selected``: the keys
    with a row then), once this process holds the folder's writer lock."""
    new = store.done_keys() - selected
    return [r for r in todo if r.key not in new]


def starting_line(todo: int, already: int, workers: int | str | None) -> str:
    """What a study says in its first second, before any run has finished: how many runs it computes and
    where (``workers``: local worker processes, a cluster, or ``None`` for this process), and why the first
    result takes a while (each process builds or loads its solvers first)."""
    where = "in this process" if workers is None else f"on {workers} worker process{'es' if workers != 1 else ''}"
    done = f" ({already} done before)" if already else ""
    return (f"computing {todo} run(s){done} {where}; starting — each process builds or loads its solvers "
            "before its first run finishes")


def _select(plan: StudyPlan, store: StudyStore, address: str | None, rrd: str, limit: int | None,
            retry_failed: bool, say: Callable[[str], None]) -> tuple[list[PlannedRun], int]:
    """Check the output folder, the address and the ``rrd`` mode before anything is written, quarantine
    unreadable rows; the runs to compute (at most ``limit``) and the number already done."""
    store.check(plan)
    if address is not None:
        validate_address(address)
    if rrd not in ("none", "failures", "all", "compare"):
        raise BadInput(f"--rrd {rrd}: expected none, failures, all or compare")
    for bad in store.quarantine_corrupt():
        say(f"warning: unreadable row {bad.name} moved to {bad.parent}; its run is recomputed")
    missing = len(plan_todo(plan, store, retry_failed=retry_failed)[0])
    todo, already = plan_todo(plan, store, retry_failed=retry_failed, limit=limit)
    if limit is not None and len(todo) < missing:
        say(describe_selection(todo, plan.axis_columns, missing))
    return todo, already


def _persister(store: StudyStore, report: StudyReport,
               on_row: Callable[[dict[str, Any]], None] | None) -> Callable[[PlannedRun, dict[str, Any]], None]:
    """The callback that writes one finished run's row, logs it and counts it in ``report``."""
    def persist(run: PlannedRun, result: dict[str, Any]) -> None:
        row = make_row(run, result, report.invocation)
        store.write_row(run.key, row)
        store.log("run", invocation=report.invocation, run_key=run.key, run_index=run.index,
                  status=row.get("status"), worker=row.get("worker"))
        report.computed.append(run.key)
        if row.get("status") != "ok":
            report.failed.append(run.key)
        if row.get("status") == "unstable":
            report.unstable.append(run.key)
        kind = str(row.get("outcome") or "not judged")
        report.outcomes[kind] = report.outcomes.get(kind, 0) + 1
        if on_row is not None:
            on_row(row)

    return persist


@contextlib.contextmanager
def _interrupt_flag() -> Iterator[threading.Event]:
    """A Ctrl-C (SIGINT) sets the event as well as raising :class:`KeyboardInterrupt`: the raise lands wherever
    the main thread is, and where that is a finaliser or a callback the interpreter swallows it (measured: a fresh
    clone under load ran a whole study after the signal); the loops below check the event after every run, so the
    interrupt is acted upon at the next finished run at the latest. Outside the main thread nothing changes."""
    flag = threading.Event()

    def handler(signum: int, frame: Any) -> None:
        flag.set()
        raise KeyboardInterrupt

    try:
        old = signal.signal(signal.SIGINT, handler)
    except ValueError:  # not the main thread
        yield flag
        return
    try:
        yield flag
    finally:
        signal.signal(signal.SIGINT, old)


def _run_serial(todo: list[PlannedRun], kw: dict[str, Any], persist: Callable[..., None],
                advance: Callable[[], None], store: StudyStore, report: StudyReport, plan: StudyPlan) -> None:
    """Compute the runs one after the other in this process."""
    store.init(plan)
    store.log("start", invocation=report.invocation, todo=len(todo), done_before=report.already_done,
              backend="serial")
    try:
        with _interrupt_flag() as interrupted:
            for run in todo:
                persist(run, run_one(run.config, run.key, **kw))
                advance()
                if interrupted.is_set():
                    raise KeyboardInterrupt
    except KeyboardInterrupt:
        store.log("interrupted", invocation=report.invocation, computed=len(report.computed))
        raise StudyInterruptedError(_interrupted_msg(report, plan)) from None


def _finish(plan: StudyPlan, store: StudyStore, report: StudyReport, rrd: str, analyse: bool,
            say: Callable[[str], None]) -> None:
    """Log the end, collect ``results.parquet``, write the comparison recording and the summary."""
    with contextlib.suppress(OSError):  # the (empty) staging folder of --rrd failures
        (store.runs_dir / ".staging").rmdir()
    store.log("end", invocation=report.invocation, computed=len(report.computed), failed=len(report.failed),
              wall_time_s=report.wall_time_s, source=source_revision() if report.computed else None)
    report.results = store.collect(plan)
    if rrd == "compare" and report.results.height:
        cmp = write_study_comparison(plan, report.results, report.out / "compare.rrd")
        if cmp is not None:
            say(f"comparison of {cmp[1]} runs: {cmp[0]}")
    if analyse and report.results.height:
        from .analysis import analyse_study

        analyse_study(plan, report.results, report.out)


def _run_dask(client: Any, todo: list[PlannedRun], kw: dict[str, Any], persist: Callable[..., None],
              advance: Callable[[], None], store: StudyStore, report: StudyReport, plan: StudyPlan) -> None:
    from distributed import as_completed

    by_key: dict[str, PlannedRun] = {}
    futures = []
    for run in todo:
        fut = client.submit(run_one, run.config, run.key, pure=False, key=f"ftc-run-{run.key}-{report.invocation}",
                            **kw)
        by_key[fut.key] = run
        futures.append(fut)
    try:
        with _interrupt_flag() as interrupted:
            for fut in as_completed(futures):
                run = by_key[fut.key]
                try:
                    result = fut.result()
                except Exception as err:  # noqa: BLE001 - e.g. KilledWorker: recorded as a failed row
                    result = failed_result(f"{type(err).__name__}: {err}")
                persist(run, result)
                fut.release()
                advance()
                if interrupted.is_set():
                    raise KeyboardInterrupt
    except KeyboardInterrupt:
        for f in futures:
            f.cancel()
        store.log("interrupted", invocation=report.invocation, computed=len(report.computed))
        raise StudyInterruptedError(_interrupted_msg(report, plan)) from None


def write_study_comparison(plan: StudyPlan, results: pl.DataFrame, out: Path) -> tuple[Path, int] | None:
    """Overlay the study's runs that have a run folder in one recording (``out``), labelled by the axis
    values that vary (and the seed if there are several); at most the first
    :data:`~ftc_mj.rerun.overlay.MAX_RUNS` in covering order (:func:`covering_order`). None if fewer than
    two runs have a folder."""
    from ..rerun.overlay import MAX_RUNS, distinct_labels, write_comparison

    if "run_dir" not in results.columns:
        return None
    dirs = {r["run_key"]: r["run_dir"] for r in results.iter_rows(named=True) if r.get("run_dir")}
    runs = [r for r in covering_order(plan.runs, plan.axis_columns) if r.key in dirs][:MAX_RUNS]
    if len(runs) < 2:
        return None
    cols = [c for c in plan.axis_columns if len({json.dumps(r.labels.get(c), default=str) for r in runs}) > 1]
    seeds = len({r.seed for r in runs}) > 1
    labels = distinct_labels([" ".join([f"{c}={r.labels.get(c)}" for c in cols] + ([f"seed={r.seed}"] if seeds
                                                                                 else []))[:80] or r.key for r in runs])
    path = write_comparison([Path(dirs[r.key]) for r in runs], out, labels, recording_id=f"study-{plan.spec.name}")
    return path, len(runs)


def _interrupted_msg(report: StudyReport, plan: StudyPlan) -> str:
    done = len(StudyStore(report.out).done_keys() & {r.key for r in plan.runs})
    return (f"interrupted: {done} of {len(plan.runs)} runs persisted in {report.out}; "
            "re-run the same command to finish the rest")


@contextlib.contextmanager
def _progress(show: bool, total: int, name: str) -> Iterator[Callable[[], None]]:
    """A rich progress bar over runs (no-op when not shown)."""
    if not show or total == 0:
        yield lambda: None
        return
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    with Progress(TextColumn(f"[bold]{name}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  TimeRemainingColumn(), console=Console(stderr=True), transient=False) as bar:
        task = bar.add_task(name, total=total)
        yield lambda: bar.advance(task)
