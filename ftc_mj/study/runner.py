"""Run a study plan on dask.distributed (or serially in-process), persisting each row as it arrives.

The client submits the missing runs, iterates ``as_completed`` and writes each result as
``OUT/rows/<key>.parquet`` atomically the moment it arrives, so an interruption (Ctrl-C, a killed
client, a lost worker) loses at most the runs in flight. Re-running the same command computes
only the runs without a row. ``results.parquet`` is collected at the end.
"""

from __future__ import annotations

import contextlib
import json
import logging
import math
import os
import re
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

RrdMode = Literal["none", "failures", "all"]
ADDRESS_RE = re.compile(r"^tcp://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9]([A-Za-z0-9.\-]*[A-Za-z0-9])?):(\d{1,5})$")
CONNECT_TIMEOUT_S = 5.0

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
def open_client(workers: int, address: str | None) -> Iterator[Any]:
    """A dask Client: connected to ``address`` (5 s timeout) or to a fresh LocalCluster of
    ``workers`` single-threaded worker processes. BadInput if the scheduler cannot be reached."""
    from distributed import Client, LocalCluster

    os.environ.setdefault("OMP_NUM_THREADS", "1")  # inherited by local workers: IPOPT must not spin
    if address is not None:
        address = validate_address(address)
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
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                           silence_logs=logging.ERROR)
    client = Client(cluster)
    try:
        yield client
    finally:
        client.close()
        cluster.close()


# ---------------------------------------------------------------------------- run
def plan_todo(plan: StudyPlan, store: StudyStore, *, retry_failed: bool = False,
              limit: int | None = None) -> tuple[list[PlannedRun], int]:
    """Runs still to compute (plan order) and how many of the plan are already done."""
    done = store.done_keys()
    if retry_failed:
        done -= store.failed_keys()
    todo = [r for r in plan.runs if r.key not in done]
    already = len(plan.runs) - len(todo)
    if limit is not None:
        todo = todo[: max(0, limit)]
    return todo, already


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
) -> StudyReport:
    """Compute the plan's missing runs into ``out`` and collect/analyse the results.

    Execution: ``serial`` runs in this process (no dask); else ``client`` if given (left open),
    else a connection to ``address``, else a LocalCluster of ``workers`` processes. Validation of
    the output folder and of the address happens before anything is written.
    """
    store = StudyStore(out)
    store.check(plan)
    if address is not None:
        validate_address(address)
    if rrd not in ("none", "failures", "all"):
        raise BadInput(f"--rrd {rrd}: expected none, failures or all")
    todo, already = plan_todo(plan, store, retry_failed=retry_failed, limit=limit)
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
        if on_row is not None:
            on_row(row)

    store.reconcile_log()  # rows a killed invocation persisted but did not get to log
    kw = {"rrd": rrd, "runs_dir": str(store.runs_dir) if rrd != "none" else None,
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
            ctx = contextlib.nullcontext(client) if client is not None else open_client(workers, address)
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


def _interrupted_msg(report: StudyReport, plan: StudyPlan) -> str:
    done = report.already_done + len(report.computed)
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
