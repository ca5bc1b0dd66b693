"""Reading a study's output folder for the published tables: the final ``results.parquet`` or, for a
study still running, the rows persisted so far; columns as float arrays (NaN for missing values)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl

from ...metrics.schema import upgrade_names


def read_results(out: Path) -> pl.DataFrame:
    """Rows of a study output folder (the final table, or the rows persisted so far; empty if none)."""
    res = Path(out) / "results.parquet"
    if res.is_file():
        return upgrade_names(pl.read_parquet(res))
    files = sorted((Path(out) / "rows").glob("*.parquet"))
    if not files:
        return pl.DataFrame()
    return upgrade_names(pl.concat([pl.read_parquet(f) for f in files], how="diagonal_relaxed"))


def float_column(df: pl.DataFrame, name: str) -> np.ndarray:
    """A column as floats, NaN where a run has no value."""
    return np.array([np.nan if v is None else float(v) for v in df[name].to_list()], dtype=float)


def worst(a: np.ndarray) -> float:
    """Largest finite value (NaN if none)."""
    return float(np.nanmax(a)) if np.isfinite(a).any() else float("nan")
