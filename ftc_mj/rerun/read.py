"""Reading a recording back: one scalar series, the events log (tests, integration checks and the
multi-run comparison, which shows a run's recorded events)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
from rerun.chunk import RrdReader

from ftc_mj.telemetry import Event


def _time_s(rb: pa.RecordBatch) -> np.ndarray:
    """The ``sim_time`` column of a record batch as integer nanoseconds."""
    return rb.column("sim_time").cast(pa.int64()).to_numpy(zero_copy_only=False)


def read_scalar_series(path: Path, entity: str) -> tuple[np.ndarray, np.ndarray]:
    """Read one ``Scalars`` entity back from a ``.rrd``: ``(t, values)`` sorted by time.

    ``t`` is ``sim_time`` in seconds (float64). ``values`` is ``(n,)`` when every row holds one
    scalar, else ``(n, k)``. Static chunks are ignored. Raises ``KeyError`` if the entity has no
    ``Scalars`` data.
    """
    entity = "/" + entity.strip("/")
    chunks = (RrdReader(str(path)).stream()
              .filter(content=entity, components="Scalars:scalars", is_static=False).to_chunks())
    ts: list[np.ndarray] = []
    vs: list[list[list[float]]] = []
    for ch in chunks:
        if str(ch.entity_path) != entity:
            continue
        rb = ch.to_record_batch()
        if "Scalars:scalars" not in rb.schema.names:
            continue
        ts.append(_time_s(rb))
        vs.extend(rb.column("Scalars:scalars").to_pylist())
    if not ts:
        raise KeyError(f"no Scalars data for {entity} in {path}")
    t_ns = np.concatenate(ts)
    order = np.argsort(t_ns, kind="stable")
    widths = {len(v) for v in vs}
    if widths == {1}:
        values = np.array([v[0] for v in vs], dtype=np.float64)
    else:
        values = np.array(vs, dtype=np.float64)
    return t_ns[order] * 1e-9, values[order]


def read_events(path: Path, entity: str = "/events") -> list[Event]:
    """The ``TextLog`` lines of ``entity`` in a ``.rrd`` as events (time in s, level in lower case),
    sorted by time. Raises ``RuntimeError``/``OSError`` for an unreadable file."""
    out: list[Event] = []
    for ch in RrdReader(str(path)).stream().filter(content=entity, is_static=False).to_chunks():
        if str(ch.entity_path) != entity:
            continue
        rb = ch.to_record_batch()
        ts = _time_s(rb) * 1e-9
        for t, texts, levels in zip(ts, rb.column("TextLog:text").to_pylist(),
                                    rb.column("TextLog:level").to_pylist(), strict=True):
            for i, text in enumerate(texts or []):
                level = (levels or ["INFO"])[min(i, len(levels or [""]) - 1)] or "INFO"
                out.append(Event(float(t), str(level).lower(), str(text)))
    return sorted(out, key=lambda e: e.t)
