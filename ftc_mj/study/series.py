"""The compact time series of a results table (``ts_*`` list columns, one list per run, sampled at the
study's ``analysis.timeseries_rate``) as NaN-padded (runs, samples) arrays."""

from __future__ import annotations

import numpy as np
import polars as pl


def stack_series(df: pl.DataFrame, column: str) -> np.ndarray:
    """Stack a list column into a (runs, samples) array, NaN-padded (empty if the column is absent)."""
    if column not in df.columns:
        return np.zeros((0, 0))
    lists = [x if x is not None else [] for x in df[column].to_list()]
    n = max((len(x) for x in lists), default=0)
    out = np.full((len(lists), n), np.nan)
    for i, x in enumerate(lists):
        out[i, : len(x)] = [np.nan if v is None else v for v in x]
    return out


def series_time(df: pl.DataFrame) -> np.ndarray:
    """Sample times (s) of the longest run of ``df`` (the runs share their sampling)."""
    t = stack_series(df, "ts_t")
    return np.nanmax(t, axis=0) if t.size else np.zeros(0)


def indicated_wheel(df: pl.DataFrame) -> np.ndarray:
    """Per run and sample: 1 if the declared wheel equals the true faulty set at that time, 0 if not
    (NaN where the run has no sample), over the samples with a fault in the plant (NaN elsewhere).

    The faulty set comes from the true radii (a wheel is faulty once its radius has left its initial
    value), the declared wheel from ``declared_wheel``. Results without that column (older studies)
    fall back to the estimates: the wheel whose estimate dropped more below nominal (``both`` if both
    dropped by over 25 %), while a fault is declared."""
    det = stack_series(df, "ts_fault_detected")
    rR, rL = stack_series(df, "ts_R_R"), stack_series(df, "ts_R_L")
    if not (det.size and rR.size and rL.size):
        return np.zeros((0, 0))
    fR, fL = np.abs(rR - rR[:, :1]) > 1e-9, np.abs(rL - rL[:, :1]) > 1e-9
    truth = np.where(fR & fL, 3, np.where(fR, 1, np.where(fL, 2, 0)))
    code = stack_series(df, "ts_declared_wheel")
    if code.size:
        ind = np.where(det > 0.5, code, 0)
    else:
        eR, eL = stack_series(df, "ts_R_R_hat"), stack_series(df, "ts_R_L_hat")
        dropR, dropL = (rR[:, :1] - eR) / rR[:, :1], (rL[:, :1] - eL) / rL[:, :1]
        ind = np.where(det > 0.5, np.where((dropR > 0.25) & (dropL > 0.25), 3, np.where(dropL > dropR, 2, 1)), 0)
    ok = (ind == truth).astype(float)
    return np.where(np.isfinite(det) & (truth > 0), ok, np.nan)
