"""One results row of a study: run identity, axis labels, the run's metrics flattened to columns
(``m_`` prefix where a metric's name is an axis), worker information and the compact time series."""

from __future__ import annotations

import json
import math
import re
import time
from pathlib import Path
from typing import Any

from .plan import PlannedRun

WALL_COLUMNS_RE = re.compile(r"(wall|realtime|solve_time_ms|over_period|over_budget|rrd_write|^worker|^invocation$"
                             r"|^finished_at$|^run_dir$)")
"""Columns that depend on timing or on which worker/invocation computed a run."""


def wall_columns(columns: list[str]) -> list[str]:
    """The columns of a results table that legitimately differ between identical runs."""
    return [c for c in columns if WALL_COLUMNS_RE.search(c)]


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
