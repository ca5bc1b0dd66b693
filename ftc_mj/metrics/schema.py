"""The unit and one-line meaning of every key ``metrics.json`` can hold (the table is the data file
``ftc_mj/data/metrics.toml``): printed by ``ftc-mj metrics`` and written beside each run's
``metrics.json`` as ``metrics.schema.json``.

A unit is SI (``m``, ``s``, ``m/s``, ``rad/s``, ``°`` for the roll read by people), ``1`` for a
dimensionless number, ``fraction`` for a share in [0, 1], ``count`` for an integer count and ``""``
for text, flags and nested records (whose fields the meaning names). Times are from the start of the
run; "the onset" is the first scheduled fault onset in the run. ``None`` (JSON ``null``) marks a
value that does not apply to the run.
"""

from __future__ import annotations

import tomllib
from typing import Any


def _load() -> dict[str, tuple[str, str]]:
    """The table shipped as ``ftc_mj/data/metrics.toml`` (data, in the order a reader meets the keys)."""
    from ..resources import resource_path

    with open(resource_path("metrics.toml"), "rb") as fh:
        table = tomllib.load(fh)
    return {k: (str(v["unit"]), str(v["meaning"])) for k, v in table.items()}


METRICS: dict[str, tuple[str, str]] = _load()
"""metric key -> (unit, one-line meaning)."""


def undocumented(keys: Any) -> list[str]:
    """The keys of ``keys`` that :data:`METRICS` does not document."""
    return sorted(k for k in keys if k not in METRICS)


def schema() -> dict[str, dict[str, str]]:
    """``metrics.schema.json``: ``{key: {"unit": …, "meaning": …}}`` for every metric."""
    return {k: {"unit": u, "meaning": d} for k, (u, d) in METRICS.items()}


def schema_lines() -> list[str]:
    """``ftc-mj metrics``: one line per key, ``key  [unit]  meaning``."""
    width = max(map(len, METRICS))
    return [f"{k:<{width}}  {'[' + u + ']' if u else '':<10}  {d}" for k, (u, d) in METRICS.items()]
