"""What every recording of ftc-mj is written with: a recording stream of its own with a file sink
(atomic rename), the ``sim_time`` timeline in integer nanoseconds, series styles and Arrow-built
``LineStrips3D`` columns.

``sim_time`` is a duration timeline of integer nanoseconds (``timedelta64[ns]``): float seconds are
rounded differently by different Rerun calls (``set_time`` and ``TimeColumn`` gave 2050000000 and
2049999999 ns for 2.05 s), so every time column is converted once by :func:`seconds_to_ns`.
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from ftc_mj.io import atomic_path
from ftc_mj.telemetry import Event

PATH_RATE_HZ = 2.0
"""Rows per second of a growing path strip (Hz)."""
PATH_POINT_RATE_HZ = 10.0
"""Points per second kept in a growing path strip (Hz)."""

TEXT_LEVELS = {"info": rr.TextLogLevel.INFO, "warn": rr.TextLogLevel.WARN, "warning": rr.TextLogLevel.WARN,
               "error": rr.TextLogLevel.ERROR, "debug": rr.TextLogLevel.DEBUG}
"""Event level (lower case) → ``TextLog`` level; anything else is ``INFO``."""


@contextlib.contextmanager
def recording_file(path: Path, app_id: str, recording_id: str, blueprint: rrb.Blueprint
                   ) -> Iterator[rr.RecordingStream]:
    """A recording stream of its own with a file sink and ``blueprint``, writing a temporary file beside
    ``path`` (:func:`ftc_mj.io.atomic_path`) that is renamed onto ``path`` once the stream is flushed and
    closed; on any error nothing appears under ``path``.

    Never the global stream, so recordings written in parallel threads cannot mix.
    """
    with atomic_path(Path(path)) as tmp:
        rec = rr.RecordingStream(app_id, recording_id=recording_id)
        try:
            rec.save(tmp, default_blueprint=blueprint)
            yield rec
            rec.flush()
        finally:
            rec.disconnect()


def seconds_to_ns(t: np.ndarray) -> np.ndarray:
    """Seconds → ``timedelta64[ns]`` (integer ns, rounded once)."""
    return np.round(np.asarray(t, dtype=np.float64) * 1e9).astype(np.int64).astype("timedelta64[ns]")


def sim_time(t_ns: np.ndarray) -> rr.TimeColumn:
    """The ``sim_time`` column of times ``t_ns`` (``timedelta64[ns]``, from :func:`seconds_to_ns`)."""
    return rr.TimeColumn("sim_time", duration=t_ns)


@functools.lru_cache(maxsize=256)
def series_style(color: tuple[int, ...], name: str, width: float) -> rr.SeriesLines:
    """A ``SeriesLines`` style (RGB colour, legend name, line width in UI points), built once per process
    (the Arrow conversion is most of its cost)."""
    return rr.SeriesLines(colors=[list(color)], names=[name], widths=[width])


def send_series(rec: rr.RecordingStream, entity: str, indexes: Sequence[rr.TimeColumn], values: np.ndarray,
                color: Sequence[int], name: str, width: float) -> None:
    """One ``Scalars`` entity: its static style, then all its ``values`` (one per index row) in one call."""
    rec.log(entity, series_style(tuple(color), name, width), static=True)
    rec.send_columns(entity, indexes=indexes, columns=rr.Scalars.columns(scalars=values))


def send_events(rec: rr.RecordingStream, entity: str, indexes: Sequence[rr.TimeColumn], events: Sequence[Event],
                prefix: str = "") -> None:
    """A ``TextLog`` entity of ``events`` at ``indexes`` (one row per event), each text after ``prefix``;
    levels by :data:`TEXT_LEVELS`."""
    levels = [str(TEXT_LEVELS.get(e.level.strip().lower(), rr.TextLogLevel.INFO)) for e in events]
    rec.send_columns(entity, indexes=indexes,
                     columns=rr.TextLog.columns(text=[f"{prefix}{e.text}" for e in events], level=levels))


@functools.cache
def _strip_type() -> Any:
    """Arrow type of Rerun's ``LineStrip3D`` component, read off a one-strip batch (public API)."""
    from rerun.components import LineStrip3DBatch

    return LineStrip3DBatch([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]]).as_arrow_array().type


def strips_column(strips: list[np.ndarray]) -> rr.ComponentColumnList:
    """``LineStrips3D`` columns, one ``(k, 3)`` strip (m) per row, built as one Arrow array instead of
    letting Rerun convert a list of arrays strip by strip (the slow part of writing a path)."""
    import pyarrow as pa

    typ = _strip_type()
    flat = np.ascontiguousarray(np.concatenate(strips).astype(np.float32, copy=False).ravel())
    offsets = np.zeros(len(strips) + 1, dtype=np.int32)
    np.cumsum([len(s) for s in strips], out=offsets[1:])
    inner = pa.FixedSizeListArray.from_arrays(pa.array(flat, type=pa.float32()), type=typ.value_type)
    arr = pa.ListArray.from_arrays(pa.array(offsets), inner, type=typ)
    return rr.LineStrips3D.columns(strips=arr).partition(np.ones(len(strips), dtype=np.int64))


def growing_path(x: np.ndarray, y: np.ndarray, t: np.ndarray, z: float = 0.02) -> tuple[np.ndarray, list[np.ndarray]]:
    """The actual path as a growing strip: rows (trace indices) every ``1 / PATH_RATE_HZ`` s plus the last
    one, and for each the ``(k, 3)`` float32 points (m) up to it, decimated to ``PATH_POINT_RATE_HZ``,
    at height ``z`` (m)."""
    n = len(t)
    dt = float(np.median(np.diff(t))) if n > 1 else 0.01
    dt = dt if dt > 0 else 0.01
    pstep = max(1, int(round(1.0 / (PATH_POINT_RATE_HZ * dt))))
    rstep = max(1, int(round(1.0 / (PATH_RATE_HZ * dt))))
    rows = np.arange(0, n, rstep, dtype=np.int64)
    if rows[-1] != n - 1:
        rows = np.append(rows, n - 1)
    pts = np.stack([x, y, np.full(n, z)], axis=1).astype(np.float32)
    strips = []
    for i in rows:
        sel = np.arange(0, i + 1, pstep)
        if sel[-1] != i:
            sel = np.append(sel, i)
        strips.append(pts[sel])
    return rows, strips
