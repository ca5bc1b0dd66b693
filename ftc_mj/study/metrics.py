"""The metrics a study summarises and their estimates per group of runs.

Every metric is grouped by each axis in turn (pooling the other axes and the Monte-Carlo seeds)
and reported as mean with its 95 % interval (:mod:`.stats`: Student t for continuous metrics,
Wilson for rates, 0/1 per run).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import polars as pl

from .plan import StudyPlan
from .stats import NO_DATA, Estimate, mean_ci, rate_ci


@dataclass(frozen=True)
class MetricDef:
    """A summarised metric: results column, label, unit, whether it is a rate (0/1 per run) and which
    direction is better."""

    column: str
    label: str
    unit: str = ""
    rate: bool = False
    lower_is_better: bool = True


CORE_METRICS: tuple[MetricDef, ...] = (
    MetricDef("detection_delay", "detection delay", "s"),
    MetricDef("false_alarm", "false-alarm rate", rate=True),
    MetricDef("missed_detection", "missed-detection rate", rate=True),
    MetricDef("isolation_correct", "isolation accuracy", rate=True, lower_is_better=False),
    MetricDef("time_to_correct_isolation", "time to correct isolation", "s"),
    MetricDef("isolation_correct_fraction", "time correctly isolated", "fraction", lower_is_better=False),
    MetricDef("false_isolations", "false isolations", "per run"),
    MetricDef("radius_rmse_R", "radius RMSE R", "m"),
    MetricDef("radius_rmse_L", "radius RMSE L", "m"),
    MetricDef("abs_radius_final_error_R", "final |R_R error|", "m"),
    MetricDef("abs_radius_final_error_L", "final |R_L error|", "m"),
    MetricDef("nis_mean", "mean NIS per dimension"),
    MetricDef("radius_nees_mean", "mean radius NEES (2 dof)"),
    MetricDef("nees_mean", "mean NEES (5 dof)"),
    MetricDef("innovation_in_2sigma", "innovations within 2σ", rate=False, lower_is_better=False),
    MetricDef("cross_track_rms", "cross-track RMS", "m"),
    MetricDef("cross_track_max", "cross-track max", "m"),
    MetricDef("omega_at_limit_fraction", "time at wheel-rate limit", "fraction"),
    MetricDef("solver_failures", "solver failures", "per run"),
    MetricDef("exceptions", "exceptions", "per run"),
    MetricDef("failed", "failed runs", rate=True),
)
METRIC_BY_COLUMN = {m.column: m for m in CORE_METRICS}


def metric_values(df: pl.DataFrame, mdef: MetricDef) -> list[Any]:
    """The metric's column as a list (floats for a continuous metric, None where missing)."""
    vals = df[mdef.column].to_list()
    return vals if mdef.rate else [float(v) if v is not None else None for v in vals]


def estimate(df: pl.DataFrame, mdef: MetricDef) -> Estimate:
    """The metric's estimate over the rows of ``df``."""
    if mdef.column not in df.columns or df.height == 0:
        return NO_DATA
    vals = metric_values(df, mdef)
    return rate_ci(vals) if mdef.rate else mean_ci(vals)


def prepare(results: pl.DataFrame) -> pl.DataFrame:
    """Add derived columns: absolute final errors (m) and the ``failed`` flag."""
    df = results
    extra = []
    for w in ("R", "L"):
        c = f"radius_final_error_{w}"
        if c in df.columns:
            extra.append(pl.col(c).cast(pl.Float64).abs().alias(f"abs_{c}"))
    if "cross_track_final" in df.columns:
        extra.append(pl.col("cross_track_final").cast(pl.Float64).abs().alias("abs_cross_track_final"))
    if "status" in df.columns:
        extra.append((pl.col("status") != "ok").alias("failed"))
    if extra:
        df = df.with_columns(extra)
    return df


def axis_values(df: pl.DataFrame, column: str, plan: StudyPlan | None = None) -> list[Any]:
    """Distinct labels of an axis present in ``df``, in plan order (first-seen order without a plan)."""
    if plan is not None:
        seen: list[Any] = []
        for r in plan.runs:
            v = r.labels.get(column)
            if v not in seen:
                seen.append(v)
        present = set(df[column].to_list()) if column in df.columns else set()
        return [v for v in seen if v in present]
    return list(dict.fromkeys(df[column].to_list()))


def column_eq(column: str, value: Any) -> pl.Expr:
    """Rows whose ``column`` equals ``value``."""
    return pl.col(column) == pl.lit(value)


def grouped(df: pl.DataFrame, column: str, values: list[Any], mdef: MetricDef) -> list[tuple[Any, Estimate]]:
    """The metric's estimate for each value of an axis."""
    return [(v, estimate(df.filter(column_eq(column, v)), mdef)) for v in values]
