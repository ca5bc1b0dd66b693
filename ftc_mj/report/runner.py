"""Running the matrix: one :func:`~ftc_mj.sim.run.execute` per entry, in parallel worker processes.

Workers come from a ``forkserver`` (else ``spawn``) context, never ``fork``: each builds its own
MuJoCo model, filters and solvers, with ``OMP_NUM_THREADS=1`` so IPOPT does not claim a second
core. A run whose ``metrics.json`` (status ok) already exists under ``runs/<run-id>`` is reused
instead of recomputed, unless ``fresh``. A worker never raises: a failure becomes a row with
``status = failed`` and the reason.
"""

from __future__ import annotations

import json
import multiprocessing as mp
import os
import re
import time
import traceback
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .derived import read_trace, report_metrics
from .matrix import MatrixEntry, make_label
from .summary import flatten

if TYPE_CHECKING:
    from ..config import RunConfig

THREAD_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}

#: Relative cost of a run by estimator (for scheduling the slow ones first).
COST = {"ekf": 1.0, "ukf": 1.2, "imm-ekf": 2.5, "imm-ukf": 3.0}


@dataclass(frozen=True)
class RunTask:
    """One matrix entry to execute, with everything a worker needs (picklable)."""

    label: str
    scenario: str
    overrides: dict[str, Any]
    runs_dir: str
    extra: bool = False
    rrd: bool = True
    fresh: bool = False
    identity: dict[str, Any] = field(default_factory=dict)

    @staticmethod
    def of(entry: MatrixEntry, runs_dir: Path, duration: float | None = None, rrd: bool = True,
           fresh: bool = False) -> RunTask:
        ov = dict(entry.overrides)
        if duration is not None:
            ov["duration"] = float(duration)
        ident = {"label": entry.label, "scenario": entry.scenario, "estimator": entry.estimator,
                 "imm_models": entry.imm_models, "imm_variant": entry.imm_variant, "feedback": entry.feedback,
                 "policy": entry.policy, "sensing": entry.sensing, "rate_penalty": entry.rate_penalty,
                 "controller": entry.controller, "extra": entry.extra}
        return RunTask(entry.label, entry.scenario, ov, str(runs_dir), entry.extra, rrd, fresh, ident)

    @property
    def cost(self) -> float:
        est = str(self.overrides.get("estimator.kind", "ukf"))
        c = COST.get(est, 1.0)
        if est.startswith("imm") and int(self.overrides.get("estimator.imm_models", 4)) == 5:
            c *= 1.25
        return c


def _set_thread_env() -> None:
    for k, v in THREAD_ENV.items():
        os.environ[k] = v


def existing_run(runs_dir: Path, run_id: str) -> Path | None:
    """The newest finished directory for ``run_id`` (``<id>`` or ``<id>-N``) with status ok, if any."""
    if not runs_dir.is_dir():
        return None
    pat = re.compile(re.escape(run_id) + r"(-\d+)?$")
    found: list[tuple[float, Path]] = []
    for d in runs_dir.iterdir():
        if not d.is_dir() or not pat.fullmatch(d.name):
            continue
        mp_ = d / "metrics.json"
        if not (mp_.is_file() and (d / "trace.parquet").is_file()):
            continue
        try:
            status = json.loads(mp_.read_text()).get("status")
        except (OSError, ValueError):
            continue
        if status == "ok":
            found.append((mp_.stat().st_mtime, d))
    return max(found)[1] if found else None


def row_from_run_dir(task: RunTask, run_dir: Path, reused: bool) -> dict[str, Any]:
    """A summary row from a finished run directory (metrics.json + derived metrics from the trace)."""
    from ..config import read_toml, validate_config

    metrics = json.loads((run_dir / "metrics.json").read_text())
    cfg = validate_config(read_toml(run_dir / "config.toml"))
    return _row(task, metrics, cfg, read_trace(run_dir / "trace.parquet"), run_dir, reused)


def _row(task: RunTask, metrics: dict[str, Any], cfg: RunConfig, trace: Any, run_dir: Path | None,
         reused: bool) -> dict[str, Any]:
    row: dict[str, Any] = dict(task.identity)
    flat = flatten(metrics)
    for k in ("scenario", "estimator", "imm_models", "imm_variant", "feedback", "controller", "policy", "sensing",
              "rate_penalty"):
        flat.pop(k, None)  # the identity columns come from the matrix entry
    row.update(flat)
    row.update(report_metrics(cfg, trace))
    row["run_dir"] = str(run_dir) if run_dir is not None else None
    row["reused"] = reused
    return row


def execute_task(task: RunTask) -> dict[str, Any]:
    """Run (or reuse) one task and return its summary row. Never raises."""
    _set_thread_env()
    t0 = time.perf_counter()
    try:
        from ..config import load_config
        from ..sim.run import execute, run_id_for

        cfg = load_config(task.scenario, task.overrides)
        runs_dir = Path(task.runs_dir)
        if not task.fresh:
            prev = existing_run(runs_dir, run_id_for(cfg))
            if prev is not None:
                return row_from_run_dir(task, prev, reused=True)
        outcome = execute(cfg, runs_dir, rrd=task.rrd)
        row = _row(task, outcome.metrics, cfg, outcome.result.trace, outcome.run_dir, False)
    except Exception as exc:  # noqa: BLE001 - one broken run must not stop the matrix
        row = dict(task.identity)
        row.update(status="failed", error=f"{type(exc).__name__}: {exc}", traceback=traceback.format_exc(limit=5))
    row["task_wall_s"] = time.perf_counter() - t0
    return row


def _failed_row(task: RunTask, err: BaseException) -> dict[str, Any]:
    row = dict(task.identity)
    row.update(status="failed", error=f"{type(err).__name__}: {err}")
    return row


def run_tasks(tasks: Sequence[RunTask], jobs: int = 1,
              on_done: Callable[[dict[str, Any], int, int], None] | None = None) -> list[dict[str, Any]]:
    """Execute ``tasks`` over ``jobs`` worker processes (in this process when ``jobs == 1``).

    Returns the rows in the order of ``tasks``; ``on_done(row, n_done, n_total)`` is called as each
    finishes.
    """
    _set_thread_env()  # inherited by the workers before they import anything heavy
    n = len(tasks)
    rows: list[dict[str, Any] | None] = [None] * n
    done = 0
    if jobs <= 1 or n <= 1:
        for i, task in enumerate(tasks):
            rows[i] = execute_task(task)
            done += 1
            if on_done:
                on_done(rows[i], done, n)  # type: ignore[arg-type]
        return [r for r in rows if r is not None]
    try:
        ctx = mp.get_context("forkserver")
        ctx.set_forkserver_preload(["ftc_mj.report.runner"])
    except ValueError:  # pragma: no cover - platforms without forkserver
        ctx = mp.get_context("spawn")
    order = sorted(range(n), key=lambda i: -tasks[i].cost)
    before = {p.pid for p in mp.active_children()}
    pool = ProcessPoolExecutor(max_workers=min(jobs, n), mp_context=ctx)
    try:
        futs: dict[Future[dict[str, Any]], int] = {pool.submit(execute_task, tasks[i]): i for i in order}
        for fut in as_completed(futs):
            i = futs[fut]
            try:
                rows[i] = fut.result()
            except Exception as exc:  # noqa: BLE001 - e.g. a worker killed by the OS
                rows[i] = _failed_row(tasks[i], exc)
            done += 1
            if on_done:
                on_done(rows[i], done, n)  # type: ignore[arg-type]
    except BaseException:
        # Ctrl-C (or any error here): drop the queue and stop our workers now instead of waiting for
        # their runs to finish; finished runs stay on disk (atomic) and are reused next time.
        for proc in mp.active_children():  # this process's children: the pool's workers are the new ones
            if proc.pid not in before:
                proc.terminate()
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown(wait=True)
    return [r if r is not None else _failed_row(t, RuntimeError("not run")) for r, t in zip(rows, tasks, strict=True)]


def label_of_run(run_dir: Path) -> str | None:
    """The matrix label of a finished run directory, from its ``metrics.json`` identity."""
    import json

    try:
        m = json.loads((run_dir / "metrics.json").read_text())
    except (OSError, ValueError):
        return None
    est = m.get("estimator")
    if not isinstance(est, str) or not isinstance(m.get("scenario"), str):
        return None
    policy = m.get("policy") or ("direct" if m.get("feedback") else "none")
    return make_label(m["scenario"], est, str(policy), str(m.get("controller")),
                      int(m.get("imm_models") or 4), str(m.get("imm_variant") or "hypothesis"),
                      str(m.get("sensing") or "speed"), float(m.get("rate_penalty") or 0.0))


def collect_existing(runs_dir: Path, tasks: list[RunTask]) -> list[dict[str, Any]]:
    """Rows for ``tasks`` from the newest finished run of each label found in ``runs_dir`` (whatever its
    config hash); labels without a run get a row with status ``missing``."""
    newest: dict[str, tuple[float, Path]] = {}
    if runs_dir.is_dir():
        for d in runs_dir.iterdir():
            if d.is_dir() and (d / "metrics.json").is_file() and (d / "trace.parquet").is_file():
                lb = label_of_run(d)
                if lb is not None:
                    mt = (d / "metrics.json").stat().st_mtime
                    if lb not in newest or mt > newest[lb][0]:
                        newest[lb] = (mt, d)
    rows = []
    for task in tasks:
        if task.label in newest:
            rows.append(row_from_run_dir(task, newest[task.label][1], reused=True))
        else:
            rows.append(dict(task.identity, status="missing", error="no finished run in " + str(runs_dir)))
    return rows
