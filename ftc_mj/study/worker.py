"""What runs inside a worker process: one study run from plain config data to a plain dict.

Everything that crosses the process boundary is plain Python data (dicts, lists, floats, strings):
CasADi and MuJoCo objects never leave the worker. A run that raises becomes a result with
``status = "failed"`` and the error text; it never takes the worker down.

Worker processes live for the whole study, so everything that is built once per process is paid
once per worker, not per run: module imports, and the compiled MuJoCo plants and MPC solvers that
:mod:`ftc_mj.sim.cache` keeps per process (keyed by the config sections that change their
structure, ``reset()`` between runs). Each result reports that cache's counters.
"""

from __future__ import annotations

import math
import os
import shutil
import socket
import time
import traceback
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..config import RunConfig, validate_config
from .extras import run_extras

RunFn = Callable[[RunConfig, "Path | None", bool], Any]
"""``run_fn(cfg, out_root, rrd) -> RunOutcome``-like (``.metrics``, ``.result.trace``, ``.run_dir``)."""

TS_COLUMNS = ("R_R", "R_L", "R_R_hat", "R_L_hat", "R_R_std", "R_L_std", "fault_detected", "declared_wheel",
              "cross_track_error", "R_R_pcrb_std", "R_L_pcrb_std", "radius_split_pcrb_std",
              "R_R_pcrb_const_std", "R_L_pcrb_const_std", "omega_R", "omega_L")
"""Trace columns kept (down-sampled) per run for over-time figures."""

_STATE: dict[str, Any] = {"runs": 0}
"""Per-process bookkeeping: number of runs this worker process has executed."""


def cache_stats() -> dict[str, int]:
    """This process's build/reuse counters of the simulation's per-process cache
    (:mod:`ftc_mj.sim.cache`: compiled MuJoCo plants and MPC solvers, reset between runs)."""
    try:
        from ..sim import cache
    except ImportError:
        return {}
    return {k: int(v) for k, v in getattr(cache, "stats", {}).items()}


def _default_run_fn(cfg: RunConfig, out_root: Path | None, rrd: bool) -> Any:
    from ..sim.run import execute

    return execute(cfg, out_root, rrd=rrd)


def compact_timeseries(trace: dict[str, np.ndarray], est_rate: float, rate: float,
                       columns: Sequence[str] = ()) -> dict[str, list[float]]:
    """Down-sample the trace to ``rate`` Hz: ``ts_t`` plus ``ts_<column>`` lists (NaN kept) of
    :data:`TS_COLUMNS` and the extra ``columns`` the trace has.

    The trace has one row per estimator step (``est_rate``, Hz); every ``round(est_rate / rate)``-th row
    is kept from the first, so ``rate = est_rate`` keeps them all."""
    t = np.asarray(trace.get("t", []), dtype=float)
    if t.size == 0:
        return {}
    step = max(1, int(round(est_rate / rate)))
    idx = np.arange(0, t.size, step)
    out: dict[str, list[float]] = {"ts_t": t[idx].tolist()}
    for c in dict.fromkeys((*TS_COLUMNS, *columns)):
        if c in trace:
            out[f"ts_{c}"] = np.asarray(trace[c], dtype=float)[idx].tolist()
    return out


def window_stats(trace: dict[str, np.ndarray], specs: list[dict[str, Any]]) -> dict[str, float | None]:
    """Each :class:`~ftc_mj.study.spec.TraceStatSpec` (as a dict) of the full trace: ``mean``, ``std``
    (ddof 0) or ``max_abs`` of its column over its window, in the column's unit (None for an empty window)."""
    t = np.asarray(trace.get("t", []), dtype=float)
    out: dict[str, float | None] = {}
    for s in specs:
        end = math.inf if s.get("end") is None else float(s["end"])
        upper = t <= end if s.get("end_inclusive", True) else t < end
        x = np.asarray(trace[s["column"]])[(t >= float(s.get("start", 0.0))) & upper]
        if x.size == 0:
            out[s["name"]] = None
        elif s["stat"] == "mean":
            out[s["name"]] = float(np.mean(x))
        elif s["stat"] == "std":
            out[s["name"]] = float(np.std(x))
        else:
            out[s["name"]] = float(np.max(np.abs(x)))
    return out


def run_one(
    config: dict[str, Any],
    key: str,
    *,
    rrd: str = "none",
    runs_dir: str | None = None,
    ts_rate: float = 2.0,
    ts_columns: list[str] | None = None,
    run_fn: RunFn | None = None,
    trace_stats: list[dict[str, Any]] | None = None,
    extras: list[str] | None = None,
) -> dict[str, Any]:
    """Execute one run (in a worker) and return ``{"metrics", "timeseries", "info"}`` as plain data.

    ``rrd``: ``none`` (no recording), ``all`` (every run's folder under ``runs_dir``) or
    ``failures`` (the run folder is staged and kept only if the run failed). ``ts_rate`` (Hz) and
    ``ts_columns`` (extra trace columns): the compact time series (:func:`compact_timeseries`);
    ``trace_stats`` (:func:`window_stats`) and ``extras`` (:mod:`.extras`) add columns computed from the
    full trace.
    """
    t0 = time.perf_counter()
    fn = run_fn or _default_run_fn
    info: dict[str, Any] = {"worker": f"{socket.gethostname()}:{os.getpid()}", "run_dir": None,
                            "worker_run_number": _STATE["runs"] + 1}
    _STATE["runs"] += 1
    try:
        cfg = validate_config(config)
        if rrd == "none" or runs_dir is None:
            outcome = fn(cfg, None, False)
        elif rrd == "all":
            outcome = fn(cfg, _fresh(Path(runs_dir), cfg), True)
        else:
            staging = Path(runs_dir) / ".staging" / key
            shutil.rmtree(staging, ignore_errors=True)
            outcome = fn(cfg, staging, True)
            if outcome.metrics.get("status") != "ok" and outcome.run_dir is not None:
                final = _fresh(Path(runs_dir), cfg) / Path(outcome.run_dir).name
                os.replace(outcome.run_dir, final)
                outcome.run_dir = final
            elif outcome.run_dir is not None:
                shutil.rmtree(outcome.run_dir, ignore_errors=True)
                outcome.run_dir = None
            shutil.rmtree(staging, ignore_errors=True)
        metrics = dict(outcome.metrics)
        metrics.update(window_stats(outcome.result.trace, trace_stats or []))
        if extras:
            from ..sim.run import record_of

            metrics.update(run_extras(extras, record_of(cfg, outcome.result), outcome.result.trace))
        info["run_dir"] = str(outcome.run_dir) if outcome.run_dir is not None else None
        ts = compact_timeseries(outcome.result.trace, cfg.estimator.rate, ts_rate, ts_columns or ())
    except Exception as exc:  # noqa: BLE001 - a failing run becomes a row, never a crashed study
        tb = traceback.format_exc(limit=3).strip().splitlines()
        metrics = {"status": "failed", "error": f"{type(exc).__name__}: {exc}", "traceback_tail": tb[-1] if tb else ""}
        ts = {}
    info["task_wall_s"] = time.perf_counter() - t0
    info["cache"] = cache_stats() if run_fn is None else {}
    return {"metrics": metrics, "timeseries": ts, "info": info}


def _fresh(runs_dir: Path, cfg: RunConfig) -> Path:
    """``runs_dir`` with no leftover folder of this run (a run recomputed after an interruption
    replaces its own earlier recording instead of adding ``-2``)."""
    from ..sim.run import run_id_for

    runs_dir.mkdir(parents=True, exist_ok=True)
    old = runs_dir / run_id_for(cfg)
    if old.exists():
        shutil.rmtree(old, ignore_errors=True)
    return runs_dir
