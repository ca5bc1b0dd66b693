"""Small statistics of a trace column (one value per estimator step) shared by the metrics."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def nanstat(a: np.ndarray, fn: Callable[[np.ndarray], float]) -> float:
    """``fn`` of the finite values of ``a``; NaN if there are none."""
    a = np.asarray(a, dtype=float)
    a = a[np.isfinite(a)]
    return float(fn(a)) if a.size else float("nan")


def rms(a: np.ndarray) -> float:
    """Root mean square of the finite values of ``a`` (its unit); NaN if there are none."""
    return nanstat(a, lambda v: np.sqrt(np.mean(v**2)))


def first_time(mask: np.ndarray, t: np.ndarray) -> float | None:
    """The time ``t`` (s) of the first step where ``mask`` holds; None if it never does."""
    idx = np.flatnonzero(mask)
    return float(t[idx[0]]) if idx.size else None


def starts(mask: np.ndarray) -> np.ndarray:
    """Steps where ``mask`` becomes true (true at step 0 counts as a start)."""
    return mask & ~np.concatenate([[False], mask[:-1]])
