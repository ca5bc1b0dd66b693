"""The one reader of a run directory (``OUT/<run-id>/``, as :func:`ftc_mj.sim.run.execute` writes it).

A run directory holds

- ``config.toml``: the fully resolved run configuration (:class:`~ftc_mj.config.RunConfig`);
- ``trace.parquet``: one row per estimator step (SI units, radians; columns in :mod:`ftc_mj.telemetry.columns`);
- ``metrics.json``: the run's metrics (keys in :mod:`ftc_mj.metrics`);
- ``events.json``: the events in time order (runs written before it existed: derived from the trace
  by :func:`trace_events`);
- ``run.rrd`` (optional): the Rerun recording, read by :mod:`ftc_mj.rerun.read`.

:func:`read_run` reads a complete run (:func:`ftc_mj.load_run`); the single readers serve callers that
need one file (:func:`read_trace` gives the trace as numpy columns, the comparison reads a trace with
optional metrics and config). Errors about a directory are :class:`~ftc_mj.errors.BadInput` naming
``RUN_DIR``.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import BadInput
from .telemetry import Event

if TYPE_CHECKING:
    import polars as pl

    from .config import RunConfig

CONFIG = "config.toml"
TRACE = "trace.parquet"
METRICS = "metrics.json"
EVENTS = "events.json"
RECORDING = "run.rrd"


def require(run_dir: Path, *names: str) -> None:
    """:class:`~ftc_mj.errors.BadInput` naming the first of the files ``names`` missing from ``run_dir``."""
    for name in names:
        if not (run_dir / name).is_file():
            raise BadInput(f"RUN_DIR: {run_dir} is not a run directory (no {name})")


def read_run(path: str | Path) -> tuple[RunConfig, dict[str, Any], pl.DataFrame, list[Event]]:
    """A complete run directory read back: ``(config, metrics, trace, events)``, the trace one row per
    estimator step with the types of the simulated run's (:func:`as_simulated`);
    :class:`~ftc_mj.errors.BadInput` if a file is missing or unreadable."""
    import polars as pl

    d = Path(path)
    require(d, CONFIG, TRACE, METRICS)
    try:
        cfg = read_config(d)
        metrics = read_metrics(d)
        trace = as_simulated(pl.read_parquet(d / TRACE))
    except (OSError, ValueError, tomllib.TOMLDecodeError) as err:
        raise BadInput(f"RUN_DIR: {d}: unreadable run ({str(err).splitlines()[0][:120]})") from None
    return cfg, metrics, trace, read_events(d, trace)


def as_simulated(trace: pl.DataFrame) -> pl.DataFrame:
    """A trace read from ``trace.parquet`` with the column types the simulation gives it: the codes and
    counts stored as integers with nulls (:data:`~ftc_mj.telemetry.columns.INTEGER_COLUMNS`) as floats
    with NaN for "no value", ``plant_flags`` an integer."""
    import polars as pl

    from .telemetry.columns import INTEGER_COLUMNS

    cols = [c for c in INTEGER_COLUMNS if c != "plant_flags" and c in trace.columns and trace[c].dtype.is_integer()]
    return trace.with_columns(pl.col(c).cast(pl.Float64).fill_null(float("nan")) for c in cols)


def read_config(run_dir: Path) -> RunConfig:
    """The run's resolved configuration, validated (``OSError``, ``tomllib.TOMLDecodeError`` or
    :class:`~ftc_mj.errors.BadInput` when it cannot be read)."""
    from .config import validate_config

    return validate_config(tomllib.loads((run_dir / CONFIG).read_text()))


def read_metrics(run_dir: Path) -> dict[str, Any]:
    """The run's ``metrics.json`` (``OSError``/``ValueError`` when it cannot be read), renamed metrics under
    their new names (:func:`ftc_mj.metrics.schema.upgrade_names`: run folders written before a rename)."""
    from .metrics.schema import upgrade_names

    return upgrade_names(json.loads((run_dir / METRICS).read_text()))


def read_trace(path: str | Path) -> dict[str, np.ndarray]:
    """A trace as numpy columns (float where the column converts, else as stored).

    ``path`` is a ``trace.parquet`` file or a run directory (its ``trace.parquet``); pyarrow's errors
    pass through (:func:`read_run_trace` turns them into one-line input errors).
    """
    import pyarrow.parquet as pq

    p = Path(path)
    table = pq.read_table(p / TRACE if p.is_dir() else p)
    out: dict[str, np.ndarray] = {}
    for name in table.column_names:
        arr = table.column(name).to_numpy(zero_copy_only=False)
        try:
            arr = np.asarray(arr, dtype=float)
        except (TypeError, ValueError):
            pass
        out[name] = arr
    return out


def read_run_trace(run_dir: str | Path, columns: tuple[str, ...] = ("t", "x", "y")) -> dict[str, np.ndarray]:
    """The numeric columns (float64) of a run directory's trace, which must have ``columns``;
    :class:`~ftc_mj.errors.BadInput` naming ``RUN_DIR`` for a missing, unreadable or foreign trace."""
    d = Path(run_dir)
    tp = d / TRACE
    if not tp.is_file():
        raise BadInput(f"RUN_DIR: {d} is not a run directory (no {TRACE})")
    try:
        trace = {k: v for k, v in read_trace(tp).items() if v.dtype.kind == "f"}
    except Exception as err:  # noqa: BLE001 - pyarrow raises several types for a damaged file
        raise BadInput(f"RUN_DIR: {tp}: not a readable Parquet file ({str(err).splitlines()[0][:100]})") from None
    for c in columns:
        if c not in trace:
            raise BadInput(f"RUN_DIR: {tp}: no column {c!r}; not a run trace")
    return trace


def read_events(run_dir: Path, trace: pl.DataFrame) -> list[Event]:
    """The run's events: ``events.json``, else (runs written before it existed) :func:`trace_events`."""
    p = run_dir / EVENTS
    if p.is_file():
        return [Event(float(e["t"]), str(e["level"]), str(e["text"])) for e in json.loads(p.read_text())]
    return trace_events({c: trace[c].to_numpy() for c in ("t", "fault_detected", "reconfig_state")
                         if c in trace.columns})


def trace_events(trace: dict[str, np.ndarray]) -> list[Event]:
    """Events read off the trace: each change of ``fault_detected`` and of ``reconfig_state`` (the
    fault-flag changes first, then the reconfiguration changes, each in time order)."""
    t = trace["t"]
    out: list[Event] = []
    names = {0: "nominal radii", 1: "hold", 2: "radii handed over", 3: "reverted"}
    for col, text in (("fault_detected", {1: "fault declared", 0: "fault withdrawn"}), ("reconfig_state", names)):
        if col not in trace:
            continue
        v = np.nan_to_num(trace[col], nan=-1.0).astype(np.int64)
        for i in np.flatnonzero(v[1:] != v[:-1]) + 1:
            if int(v[i]) in text:
                out.append(Event(float(t[i]), "info", f"{col}: {text[int(v[i])]}"))
    return out
