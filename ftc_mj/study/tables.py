"""Markdown tables of ``summary.md``: each metric by axis value (mean with its 95 % interval), the
isolation confusion matrix (true wheel × isolated wheel) and the filters' consistency (pooled
ANEES/ANIS with two-sided 95 % χ² bounds)."""

from __future__ import annotations

from typing import Any

import numpy as np
import polars as pl

from ..estimation.consistency import ChiSquareTest, combine
from ..markdown import cell, table
from .metrics import MetricDef, column_eq, estimate
from .stats import fmt_g


def axis_table(df: pl.DataFrame, column: str, values: list[Any], metrics: list[MetricDef]) -> str:
    """Markdown table: one row per axis value, one column per metric (mean ± CI)."""
    names = (cell(m.label) + (f" ({m.unit})" if m.unit else "") for m in metrics)
    rows = []
    for v in values:
        part = df.filter(column_eq(column, v))
        rows.append([cell(v), part.height, *(estimate(part, m).fmt("", m.rate) for m in metrics)])
    return "\n".join(table([column, "n", *names], rows))


def confusion(df: pl.DataFrame) -> tuple[list[str], list[str], np.ndarray]:
    """Confusion matrix true fault wheel × isolated wheel (``none`` = no fault / nothing isolated)."""
    if "true_fault_wheel" not in df.columns:
        return [], [], np.zeros((0, 0), dtype=int)
    true = [v or "none" for v in df["true_fault_wheel"].to_list()]
    iso_col = df["isolated_wheel"].to_list() if "isolated_wheel" in df.columns else [None] * df.height
    iso = [v or "none" for v in iso_col]
    order = ["none", "right", "left", "both"]
    rows = [w for w in order if w in true] + sorted(set(true) - set(order))
    cols = [w for w in order if w in iso or w in rows] + sorted(set(iso) - set(order))
    mat = np.zeros((len(rows), len(cols)), dtype=int)
    for a, b in zip(true, iso, strict=True):
        mat[rows.index(a), cols.index(b)] += 1
    return rows, cols, mat


def confusion_md(rows: list[str], cols: list[str], mat: np.ndarray) -> str:
    """Markdown table of a confusion matrix (rows: true wheel, columns: isolated wheel, cells: runs)."""
    body = ([r, *(int(x) for x in mat[i])] for i, r in enumerate(rows))
    return "\n".join(table(["true \\ isolated", *cols], body))


CONSISTENCY: tuple[tuple[str, str, bool], ...] = (
    ("nis", "ANIS per dimension (expected 1)", True),
    ("radius_nees", "radius ANEES (2 dof, expected 2)", False),
    ("nees", "ANEES (5 dof, expected 5)", False),
)
"""(metric prefix, label, averaged per degree of freedom) of the consistency statistics."""


def run_tests(df: pl.DataFrame, prefix: str) -> list[ChiSquareTest]:
    """Each run's time-averaged statistic ``<prefix>_mean`` with its ``<prefix>_test_*`` columns."""
    cols = [f"{prefix}_mean", *(f"{prefix}_test_{k}" for k in ("lo", "hi", "n_eff", "samples", "tau", "dof"))]
    if any(c not in df.columns for c in cols):
        return []
    out = []
    for r in df.select(cols).iter_rows():
        if any(v is None for v in r):
            continue
        v, lo, hi, n_eff, samples, tau, dof = (float(x) for x in r)
        out.append(ChiSquareTest(v, lo, hi, n_eff, int(samples), tau, dof))
    return out


def consistency_cell(test: ChiSquareTest) -> str:
    """``value [lo, hi]`` with ``inside``/``outside`` and the effective sample count."""
    if test.samples == 0:
        return "—"
    where = "inside" if test.inside else "**outside**"
    return f"{fmt_g(test.value)} [{fmt_g(test.lo)}, {fmt_g(test.hi)}] {where}, n_eff {test.n_eff:.0f}"


def consistency_table(df: pl.DataFrame, column: str, values: list[Any]) -> str:
    """Markdown table: per axis value, each consistency statistic pooled over the group's runs
    (:func:`~ftc_mj.estimation.consistency.combine`) with its two-sided 95 % χ² bounds."""
    rows = []
    for v in values:
        part = df.filter(column_eq(column, v))
        cells = [consistency_cell(combine(run_tests(part, p), per_dof=pd)) for p, _, pd in CONSISTENCY]
        rows.append([cell(v), part.height, *cells])
    return "\n".join(table([column, "runs", *(cell(label) for _, label, _ in CONSISTENCY)], rows))


CONSISTENCY_NOTE = (
    "Filter consistency: each run's NEES/NIS is averaged over its steps; the runs of a group are pooled "
    "(weighted by their samples) and the bounds are the two-sided 95 % χ² bounds for the pooled effective "
    "number of independent samples, n_eff = Σ samples / τ, τ being each run's integrated autocorrelation "
    "time of the statistic (successive NEES values are correlated; innovations of a consistent filter are "
    "not). The truth plant is not the filters' model, so *outside* is expected on the MuJoCo plant; the "
    "statistics test the filter only on in-model data."
)
