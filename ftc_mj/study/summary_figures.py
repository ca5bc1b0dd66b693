"""Figures of ``summary.md``: each metric per axis value (mean and its percentile-bootstrap 95 %
interval), radius errors and the fault declaration over time, and the isolation confusion matrices."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from .metrics import MetricDef, column_eq, metric_values
from .plotting import pyplot, save_figure
from .series import indicated_wheel, series_time, stack_series
from .stats import NO_DATA, Estimate, bootstrap_mean_ci, rate_ci, ts_bootstrap_band


def _interval(part: pl.DataFrame, mdef: MetricDef) -> Estimate:
    """The interval drawn for one metric over ``part`` (see :func:`fig_axis_metrics`)."""
    if mdef.column not in part.columns or part.height == 0:
        return NO_DATA
    vals = metric_values(part, mdef)
    return rate_ci(vals) if mdef.rate else bootstrap_mean_ci(vals)


def fig_axis_metrics(df: pl.DataFrame, column: str, values: list[Any], metrics: list[MetricDef], path: Path) -> None:
    """Error-bar panels: each metric's mean and 95 % interval per value of one axis (Wilson for a rate,
    percentile bootstrap of the mean otherwise: the bars never leave the range of the runs' values)."""
    plt = pyplot()
    k = len(metrics)
    ncol = min(4, k)
    nrow = math.ceil(k / ncol)
    fig, axs = plt.subplots(nrow, ncol, figsize=(3.4 * ncol, 2.7 * nrow), squeeze=False)
    x = np.arange(len(values))
    for ax, m in zip(axs.flat, metrics, strict=False):
        ests = [_interval(df.filter(column_eq(column, v)), m) for v in values]
        mean = np.array([e.mean for e in ests])
        lo = np.array([e.mean - e.lo if math.isfinite(e.lo) else 0.0 for e in ests])
        hi = np.array([e.hi - e.mean if math.isfinite(e.hi) else 0.0 for e in ests])
        ax.errorbar(x, mean, yerr=[lo, hi], fmt="o", capsize=3)
        ax.set_xticks(x, [str(v) for v in values], rotation=30 if len(values) > 4 else 0, fontsize=7)
        ax.set_title(m.label + (f" ({m.unit})" if m.unit else ""), fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    for ax in list(axs.flat)[k:]:
        ax.set_visible(False)
    fig.suptitle(f"by {column} (mean, 95 % CI)", fontsize=9)
    fig.tight_layout()
    save_figure(fig, path)


def fig_timeseries(df: pl.DataFrame, column: str, values: list[Any], path: Path) -> None:
    """Over time, per axis value: |radius errors| (mean, percentile-bootstrap 95 % band over the runs),
    fraction of runs that
    declared a fault, and fraction whose estimates point to the true wheel."""
    plt = pyplot()
    fig, axs = plt.subplots(1, 4, figsize=(15, 3.2))
    for v in values:
        part = df.filter(column_eq(column, v))
        t = series_time(part)
        if t.size == 0:
            continue
        for ax, w in zip(axs[:2], ("R", "L"), strict=True):
            e = np.abs(stack_series(part, f"ts_R_{w}_hat") - stack_series(part, f"ts_R_{w}"))
            if e.size == 0:
                continue
            m, lo, hi = ts_bootstrap_band(e)
            ax.plot(t[: m.size], m, label=str(v))
            ax.fill_between(t[: m.size], np.where(np.isfinite(lo), lo, m), np.where(np.isfinite(hi), hi, m), alpha=0.2)
        det = stack_series(part, "ts_fault_detected")
        if det.size:
            axs[2].plot(t[: det.shape[1]], np.nanmean(det > 0.5, axis=0), label=str(v))
        ind = indicated_wheel(part)
        if ind.size:
            cnt = np.sum(np.isfinite(ind), axis=0)
            frac = np.where(cnt > 0, np.nansum(ind, axis=0) / np.maximum(cnt, 1), np.nan)
            axs[3].plot(t[: ind.shape[1]], frac, label=str(v))
    for ax, title in zip(axs, ("|R_R error| (m)", "|R_L error| (m)", "fault declared (fraction)",
                               "declared wheel = true faulty set"), strict=True):
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("t (s)")
        ax.grid(alpha=0.3)
    if axs[0].get_legend_handles_labels()[0]:  # no series when every run of the group is excluded
        axs[0].legend(title=column, fontsize=7)
    fig.tight_layout()
    save_figure(fig, path)


def fig_confusion(mats: list[tuple[str, list[str], list[str], np.ndarray]], path: Path) -> None:
    """One panel per (title, true wheels, isolated wheels, counts) confusion matrix."""
    plt = pyplot()
    k = len(mats)
    fig, axs = plt.subplots(1, k, figsize=(3.2 * k, 3.0), squeeze=False)
    for ax, (title, rows, cols, mat) in zip(axs.flat, mats, strict=True):
        ax.imshow(mat, cmap="Blues")
        ax.set_xticks(range(len(cols)), cols, fontsize=7)
        ax.set_yticks(range(len(rows)), rows, fontsize=7)
        for i in range(len(rows)):
            for j in range(len(cols)):
                ax.text(j, i, str(int(mat[i, j])), ha="center", va="center", fontsize=8)
        ax.set_xlabel("isolated", fontsize=8)
        ax.set_ylabel("true", fontsize=8)
        ax.set_title(title, fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)
