"""The study file's ``[[analysis.findings]]`` as sentences of ``summary.md`` with numbers from the data:
a metric compared across the values of an axis (means with 95 % intervals, whether the intervals
overlap), optionally run by run (``paired``); nothing in them is written by hand."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import polars as pl

from .metrics import METRIC_BY_COLUMN, MetricDef, axis_values, column_eq, estimate
from .plan import StudyPlan
from .spec import FindingSpec
from .stats import Estimate, fmt_g


def finding_text(df: pl.DataFrame, f: FindingSpec, plan: StudyPlan | None) -> list[str]:
    """Sentences stating one finding with numbers from the data."""
    sub = df
    for k, v in f.where.items():
        if k in sub.columns:
            sub = sub.filter(column_eq(k, v))
    mdef = METRIC_BY_COLUMN.get(f.metric, MetricDef(f.metric, f.title or f.metric, f.unit))
    if f.unit:
        mdef = MetricDef(mdef.column, mdef.label, f.unit, mdef.rate, mdef.lower_is_better)
    title = f.title or mdef.label
    if f.metric not in sub.columns:
        return [f"- {title}: metric `{f.metric}` is not in the results (no run produced it)."]
    vals = axis_values(sub, f.axis, plan)
    if not vals:
        return [f"- {title}: no runs."]
    base = f.baseline if f.baseline is not None and f.baseline in vals else vals[0]
    splits: list[tuple[str, pl.DataFrame]] = [("", sub)]
    if f.by is not None:
        splits = [(f" ({f.by} = {b})", sub.filter(column_eq(f.by, b))) for b in axis_values(sub, f.by, plan)]
    lines = []
    for suffix, part in splits:
        if len(vals) > 3:  # many values: list them all, then compare the extremes
            ests = [(v, estimate(part.filter(column_eq(f.axis, v)), mdef)) for v in vals]
            listing = "; ".join(f"{v}: {e.fmt(mdef.unit, mdef.rate)}" for v, e in ests)
            (v0, e0), (v1, e1) = ests[0], ests[-1]
            lines.append(f"- {title}{suffix}, by {f.axis}: {listing}. "
                         + _sentence(_compare(f.axis, v0, v1, e0, e1, mdef, title)) + ".")
            lines.extend(_paired_lines(part, f, mdef, base, vals, plan))
            continue
        eb = estimate(part.filter(column_eq(f.axis, base)), mdef)
        phrases = []
        for v in vals:
            if v == base:
                continue
            ev = estimate(part.filter(column_eq(f.axis, v)), mdef)
            phrases.append(_compare(f.axis, base, v, eb, ev, mdef, title))
        if not phrases:
            lines.append(f"- {title}{suffix}: {f.axis} = {base}: {eb.fmt(mdef.unit, mdef.rate)} (n = {eb.n}).")
        else:
            lines.append(f"- {title}{suffix}: " + "; ".join(phrases) + ".")
        lines.extend(_paired_lines(part, f, mdef, base, vals, plan))
    return lines


def _paired_lines(part: pl.DataFrame, f: FindingSpec, mdef: MetricDef, base: Any, vals: list[Any],
                  plan: StudyPlan | None) -> list[str]:
    """The run-by-run lines of a ``paired`` finding (none otherwise)."""
    if not f.paired:
        return []
    keys = [c for c in (plan.axis_columns if plan is not None else []) if c != f.axis] + ["seed"]
    return ["  - " + paired_text(part, f.axis, base, v, keys, mdef, f.tolerance) for v in vals if v != base]


def paired_text(df: pl.DataFrame, axis: str, base: Any, v: Any, keys: list[str], mdef: MetricDef,
                tolerance: float) -> str:
    """Run-by-run comparison of ``axis = v`` against ``axis = base`` (rows matched on ``keys``)."""
    keys = [k for k in keys if k in df.columns]
    col = mdef.column
    a = df.filter(column_eq(axis, base)).select([*keys, pl.col(col).cast(pl.Float64).alias("_b")])
    b = df.filter(column_eq(axis, v)).select([*keys, pl.col(col).cast(pl.Float64).alias("_v")])
    j = a.join(b, on=keys, how="inner").drop_nulls(["_b", "_v"])
    if j.height == 0:
        return f"paired, {axis} = {v} vs {base}: no matching runs"
    d = (j["_v"] - j["_b"]).to_numpy()
    worse = d > tolerance if mdef.lower_is_better else d < -tolerance
    excess = float(np.max(d) if mdef.lower_is_better else -np.min(d))
    worst = np.max if mdef.lower_is_better else np.min
    wv, wb = fmt_g(float(worst(j["_v"].to_numpy()))), fmt_g(float(worst(j["_b"].to_numpy())))
    u = f" {mdef.unit}" if mdef.unit else ""
    return (f"paired, {axis} = {v} vs {base}: worse by more than {tolerance:g}{u} in {int(worse.sum())} of "
            f"{j.height} matched runs (largest excess {fmt_g(excess)}{u}; worst {axis} = {v}: {wv}{u}, "
            f"worst {axis} = {base}: {wb}{u})")


def _sentence(text: str) -> str:
    return text[:1].upper() + text[1:]


def _compare(axis: str, base: Any, v: Any, eb: Estimate, ev: Estimate, mdef: MetricDef, title: str) -> str:
    fb, fv = eb.fmt(mdef.unit, mdef.rate), ev.fmt(mdef.unit, mdef.rate)
    if eb.n == 0 or ev.n == 0 or not (math.isfinite(eb.mean) and math.isfinite(ev.mean)):
        return f"{axis} = {v}: {fv} (n = {ev.n}) vs {axis} = {base}: {fb} (n = {eb.n})"
    if ev.mean == eb.mean:
        verb = "leaves it unchanged at"
    elif not mdef.rate and abs(ev.mean - eb.mean) <= 0.005 * max(abs(eb.mean), abs(ev.mean)):
        return f"{axis} = {v} matches {base} within 0.5 %: {fv} vs {fb} (n = {ev.n}, {eb.n})"
    else:
        verb = "reduces" if ev.mean < eb.mean else "raises"
    sig = ""
    if all(math.isfinite(x) for x in (eb.lo, eb.hi, ev.lo, ev.hi)):
        sig = " (95 % CIs do not overlap)" if (ev.hi < eb.lo or ev.lo > eb.hi) else " (95 % CIs overlap)"
    rel = ""
    if eb.mean != 0 and not mdef.rate:
        rel = f", {100 * (ev.mean - eb.mean) / abs(eb.mean):+.0f} %"
    if verb.startswith("leaves"):
        return f"{axis} = {v} {verb} {fv} (vs {base})"
    return f"{axis} = {v} {verb} it from {fb} ({base}, n = {eb.n}) to {fv} (n = {ev.n}{rel}){sig}"
