"""Run a study plan on dask.distributed (or serially in-process), persisting each row as it arrives.

The client submits the missing runs, iterates ``as_completed`` and writes each result as
``OUT/rows/<key>.parquet`` atomically the moment it arrives, so an interruption (Ctrl-C, a killed
client, a lost worker) loses at most the runs in flight. Re-running the same command computes
only the runs without a row. ``results.parquet`` is collected at the end.

The local cluster listens on 127.0.0.1 only (scheduler and dashboard, unless another dashboard
address is asked for); its worker processes ignore Ctrl-C, which the client alone handles (it
cancels the runs in flight and closes the cluster, one line instead of every worker's traceback).
``--address`` must name a scheduler the user trusts (it receives the run configs, its workers run
this package's code); a scheduler that does not complete dask's handshake within
:data:`HANDSHAKE_TIMEOUT_S` is a bad address.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import math
import os
import re
import signal
import time
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import polars as pl

from ..errors import BadInput
from .spec import PlannedRun, StudyPlan
from .store import StudyStore
from .worker import RunFn, run_one

RrdMode = Literal["none", "failures", "all", "compare"]
ADDRESS_RE = re.compile(r"^tcp://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9]([A-Za-z0-9.\-]*[A-Za-z0-9])?):(\d{1,5})$")
CONNECT_TIMEOUT_S = 5.0
HANDSHAKE_TIMEOUT_S = 6.0
"""Time (s) a scheduler at ``--address`` gets to accept the connection and answer dask's handshake."""
DASHBOARD_RE = re.compile(r"^(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9]([A-Za-z0-9.\-]*[A-Za-z0-9])?)?:(\d{1,5})$")

WALL_COLUMNS_RE = re.compile(r"(wall|realtime|solve_time_ms|over_period|over_budget|rrd_write|^worker|^invocation$"
                             r"|^finished_at$|^run_dir$)")
"""Columns that depend on timing or on which worker/invocation computed a run."""


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
    wall_time_s: float = 0.0
    results: pl.DataFrame | None = None

    @property
    def runs_per_min(self) -> float:
        return 60.0 * len(self.computed) / self.wall_time_s if self.wall_time_s > 0 else float("nan")


def validate_address(address: str) -> str:
    """Check ``tcp://host:port`` (BadInput otherwise)."""
    m = ADDRESS_RE.match(address.strip())
    if not m or not (1 <= int(m.group(3)) <= 65535):
        raise BadInput(f"--address {address}: expected tcp://HOST:PORT (port 1-65535)")
    return address.strip()


def validate_dashboard(address: str) -> str:
    """Check ``HOST:PORT`` or ``:PORT`` of the dashboard (BadInput otherwise)."""
    m = DASHBOARD_RE.match(address.strip())
    if not m or int(m.group(3)) > 65535:
        raise BadInput(f"--dashboard {address}: expected HOST:PORT, e.g. 127.0.0.1:8787 (port 0 = any free port)")
    return address.strip()


def probe_scheduler(address: str, timeout: float = HANDSHAKE_TIMEOUT_S) -> None:
    """Connect to a dask scheduler and complete the comm handshake within ``timeout`` s, else
    :class:`BadInput`. (``distributed.Client`` bounds only the TCP connect: a listener that accepts and
    never answers would hold it for ever.)"""
    from distributed.comm import connect

    async def handshake() -> None:
        comm = await connect(address, timeout=CONNECT_TIMEOUT_S)
        await comm.close()

    try:
        asyncio.run(asyncio.wait_for(handshake(), timeout))
    except TimeoutError:
        raise BadInput(f"--address {address}: no dask scheduler answered within {timeout:g} s (the connection "
                       "was accepted, dask's handshake never came)") from None
    except Exception as err:  # noqa: BLE001 - refused, unresolvable, not dask: all the user's address
        msg = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise BadInput(f"--address {address}: cannot reach a dask scheduler within {timeout:g} s "
                       f"({msg[:120]})") from None


def wall_columns(columns: list[str]) -> list[str]:
    """The columns of a results table that legitimately differ between identical runs."""
    return [c for c in columns if WALL_COLUMNS_RE.search(c)]


# ---------------------------------------------------------------------------- rows
def flatten_metrics(metrics: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"solve_time_ms": {"median": 1}}`` → ``{"solve_time_ms_median": 1}``; lists become JSON;
    non-finite floats become None."""
    out: dict[str, Any] = {}
    for k, v in metrics.items():
        name = f"{prefix}_{k}" if prefix else str(k)
        if isinstance(v, dict):
            out.update(flatten_metrics(v, name))
        elif isinstance(v, (list, tuple)):
            out[name] = json.dumps(v, default=str)
        elif hasattr(v, "item") and not isinstance(v, (str, bytes)):
            out[name] = _clean(v.item())
        else:
            out[name] = _clean(v)
    return out


def _clean(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, Path):
        return str(v)
    return v


def make_row(run: PlannedRun, result: dict[str, Any], invocation: str) -> dict[str, Any]:
    """One results row: run identity, axis labels, flattened metrics, compact time series."""
    metrics = flatten_metrics(result.get("metrics", {}))
    metrics.setdefault("status", "failed")
    metrics.setdefault("error", None)
    row: dict[str, Any] = {"run_key": run.key, "run_index": run.index}
    for k, v in metrics.items():
        row[f"m_{k}" if k in run.labels or k in ("run_key", "run_index") else k] = v
    row.update(run.labels)
    row["seed"] = run.seed
    info = result.get("info", {})
    row["worker"] = info.get("worker")
    row["worker_run_number"] = info.get("worker_run_number")
    for k, v in (info.get("cache") or {}).items():
        row[f"worker_{k}"] = v  # cumulative per worker process, e.g. worker_controller_builds
    row["task_wall_s"] = info.get("task_wall_s")
    row["run_dir"] = info.get("run_dir")
    row["invocation"] = invocation
    row["finished_at"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    for k, v in result.get("timeseries", {}).items():
        row[k] = [None if (isinstance(x, float) and not math.isfinite(x)) else x for x in v]
    return row


def failed_result(error: str) -> dict[str, Any]:
    """The result recorded for a run whose task itself failed (e.g. its worker was lost)."""
    return {"metrics": {"status": "failed", "error": error}, "timeseries": {}, "info": {}}


# ---------------------------------------------------------------------------- cluster
@contextlib.contextmanager
def open_client(workers: int, address: str | None, dashboard: str = "127.0.0.1:0") -> Iterator[Any]:
    """A dask Client: connected to ``address`` (handshake within :data:`HANDSHAKE_TIMEOUT_S`) or to a
    fresh LocalCluster of ``workers`` single-threaded worker processes on 127.0.0.1, its dashboard at
    ``dashboard``. BadInput if the scheduler cannot be reached."""
    from distributed import Client, LocalCluster

    os.environ.setdefault("OMP_NUM_THREADS", "1")  # inherited by local workers: IPOPT must not spin
    if address is not None:
        address = validate_address(address)
        probe_scheduler(address)
        try:
            client = Client(address, timeout=CONNECT_TIMEOUT_S)
        except Exception as err:  # noqa: BLE001 - any failure to connect is the user's address
            msg = str(err).splitlines()[0] if str(err) else type(err).__name__
            raise BadInput(f"--address {address}: cannot reach a dask scheduler within "
                           f"{CONNECT_TIMEOUT_S:g} s ({msg[:120]})") from None
        try:
            yield client
        finally:
            client.close()
        return
    if workers < 1:
        raise BadInput("--workers: must be >= 1")
    with _sigint_ignored_by_children():
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                               dashboard_address=validate_dashboard(dashboard), silence_logs=logging.ERROR)
    client = Client(cluster)
    try:
        yield client
    finally:
        with _quiet_distributed():
            client.close()
            cluster.close()


@contextlib.contextmanager
def _sigint_ignored_by_children() -> Iterator[None]:
    """Ignore SIGINT while worker processes are started: they inherit the disposition (Python keeps an
    inherited SIG_IGN), so a Ctrl-C in the terminal reaches only this process."""
    try:
        old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread: nothing to change
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


@contextlib.contextmanager
def _quiet_distributed() -> Iterator[None]:
    """Silence distributed's and tornado's log lines while the cluster is torn down (closing comms of
    cancelled runs are expected)."""
    loggers = [logging.getLogger(n) for n in ("distributed", "tornado", "asyncio")]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        for lg, lv in zip(loggers, levels, strict=True):
            lg.setLevel(lv)


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
) -> StudyReport:
    """Compute the plan's missing runs into ``out`` and collect/analyse the results.

    Execution: ``serial`` runs in this process (no dask); else ``client`` if given (left open),
    else a connection to ``address``, else a LocalCluster of ``workers`` processes (dashboard at
    ``dashboard``). Validation of the output folder and of the address happens before anything is
    written. ``rrd = "compare"`` keeps every run's folder (like ``all``) and writes
    ``OUT/compare.rrd`` overlaying them (:func:`write_study_comparison`). ``echo`` receives one-line
    notes: quarantined rows, what a ``limit`` took.
    """
    say = echo or (lambda _s: None)
    store = StudyStore(out)
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
    invocation = time.strftime("%Y%m%dT%H%M%S", time.gmtime()) + "-" + uuid.uuid4().hex[:6]
    report = StudyReport(Path(out), invocation, len(plan.runs), already)
    t0 = time.perf_counter()

    def persist(run: PlannedRun, result: dict[str, Any]) -> None:
        row = make_row(run, result, invocation)
        store.write_row(run.key, row)
        store.log("run", invocation=invocation, run_key=run.key, run_index=run.index, status=row.get("status"),
                  worker=row.get("worker"))
        report.computed.append(run.key)
        if row.get("status") != "ok":
            report.failed.append(run.key)
        if row.get("status") == "unstable":
            report.unstable.append(run.key)
        if on_row is not None:
            on_row(row)

    store.reconcile_log()  # rows a killed invocation persisted but did not get to log
    kw = {"rrd": "all" if rrd == "compare" else rrd, "runs_dir": str(store.runs_dir) if rrd != "none" else None,
          "ts_rate": plan.spec.analysis.timeseries_rate, "run_fn": run_fn}
    with _progress(progress, len(todo), plan.spec.name) as advance:
        if not todo:
            store.init(plan)
            store.log("start", invocation=invocation, todo=0, done_before=already)
        elif serial:
            store.init(plan)
            store.log("start", invocation=invocation, todo=len(todo), done_before=already, backend="serial")
            try:
                for run in todo:
                    persist(run, run_one(run.config, run.key, **kw))
                    advance()
            except KeyboardInterrupt:
                store.log("interrupted", invocation=invocation, computed=len(report.computed))
                raise StudyInterruptedError(_interrupted_msg(report, plan)) from None
        else:
            ctx = (contextlib.nullcontext(client) if client is not None
                   else open_client(workers, address, dashboard))
            with ctx as cl:
                store.init(plan)
                store.log("start", invocation=invocation, todo=len(todo), done_before=already,
                          backend=str(cl.scheduler.address) if hasattr(cl, "scheduler") else "dask")
                _run_dask(cl, todo, kw, persist, advance, store, report, plan)
    report.wall_time_s = time.perf_counter() - t0
    with contextlib.suppress(OSError):  # the (empty) staging folder of --rrd failures
        (store.runs_dir / ".staging").rmdir()
    store.log("end", invocation=invocation, computed=len(report.computed), failed=len(report.failed),
              wall_time_s=report.wall_time_s)
    report.results = store.collect(plan)
    if rrd == "compare" and report.results.height:
        cmp = write_study_comparison(plan, report.results, Path(out) / "compare.rrd")
        if cmp is not None:
            say(f"comparison of {cmp[1]} runs: {cmp[0]}")
    if analyse and report.results.height:
        from .analysis import analyse_study

        analyse_study(plan, report.results, Path(out))
    return report


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
        for fut in as_completed(futures):
            run = by_key[fut.key]
            try:
                result = fut.result()
            except Exception as err:  # noqa: BLE001 - e.g. KilledWorker: recorded as a failed row
                result = failed_result(f"{type(err).__name__}: {err}")
            persist(run, result)
            fut.release()
            advance()
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
