"""Study analysis: ``summary.md`` and its figures from ``results.parquet``.

Every metric is grouped by each axis in turn (pooling the other axes and the Monte-Carlo seeds)
and reported as mean ± half-width of the 95 % confidence interval (Student t for continuous
metrics, Wilson score interval for rates; :mod:`.metrics`). Filter consistency is reported as the
Monte-Carlo ANEES and ANIS of each group with their two-sided 95 % χ² bounds (:mod:`.tables`). The
study file's ``[[analysis.findings]]`` turn into sentences with numbers generated from the data
(:mod:`.findings`); nothing in the summary is written by hand.
"""

from __future__ import annotations

import json
from pathlib import Path

import polars as pl

from ..io import atomic_path
from .findings import finding_text
from .metrics import CORE_METRICS, axis_values, column_eq, prepare
from .plan import StudyPlan
from .summary_figures import fig_axis_metrics, fig_confusion, fig_timeseries
from .tables import CONSISTENCY, CONSISTENCY_NOTE, axis_table, confusion, confusion_md, consistency_table, run_tests


def analyse_study(plan: StudyPlan, results: pl.DataFrame, out: Path, *, figures: bool = True) -> str:
    """Write ``out/summary.md`` (and ``out/figures/*.png`` unless ``figures`` or the study's
    ``[analysis] figures`` is false); return the markdown."""
    out = Path(out)
    figures = figures and plan.spec.analysis.figures
    df = prepare(results)
    spec = plan.spec
    # runs whose physics blew up describe a frozen robot: counted apart, never averaged
    unstable = df.filter(pl.col("status") == "unstable") if "status" in df.columns else df.clear()
    df = df.filter(pl.col("status") != "unstable") if unstable.height else df
    metrics = [m for m in CORE_METRICS if m.column in df.columns and df[m.column].null_count() < df.height]
    n_ok = int((df["status"] == "ok").sum()) if "status" in df.columns else 0
    lines = [f"# Study `{spec.name}`", ""]
    if spec.description:
        lines += [spec.description.strip(), ""]
    lines += [f"Runs: {df.height + unstable.height} of {len(plan.runs)} planned have results ({n_ok} ok, "
              f"{df.height - n_ok} failed, {unstable.height} with unstable physics, excluded from every statistic). "
              f"Axes: {', '.join(f'`{c}`' for c in plan.axis_columns) or 'none'}; seeds per combination: "
              f"{_n_seeds(plan)}.", ""]
    if plan.extra_overrides:
        lines += ["Reduced/overridden for this output: " + ", ".join(f"`{k} = {json.dumps(v)}`"
                                                                     for k, v in plan.extra_overrides.items()), ""]
    lines += ["Values are mean ± half-width of the 95 % confidence interval over the runs of each group "
              "(Student t); rates are given as % [Wilson 95 % interval]. Each table pools all other axes "
              "and the seeds.", "", CONSISTENCY_NOTE, ""]
    if spec.analysis.findings:
        lines += ["## Findings", ""]
        for f in spec.analysis.findings:
            lines += finding_text(df, f, plan)
        lines.append("")
    fig_dir = out / "figures"
    for col in plan.axis_columns:
        vals = axis_values(df, col, plan)
        if not vals:
            continue
        lines += [f"## By `{col}`", ""]
        for chunk in (metrics[:8], metrics[8:]):
            if chunk:
                lines += [axis_table(df, col, vals, chunk), ""]
        if figures and metrics:
            fig_axis_metrics(df, col, vals, metrics, fig_dir / f"by_{_safe(col)}.png")
            lines += [f"![metrics by {col}](figures/by_{_safe(col)}.png)", ""]
            if "ts_t" in df.columns and len(vals) <= 10:
                fig_timeseries(df, col, vals, fig_dir / f"time_{_safe(col)}.png")
                lines += [f"![over time by {col}](figures/time_{_safe(col)}.png)", ""]
        if any(run_tests(df, p) for p, _, _ in CONSISTENCY):
            lines += [f"Filter consistency by `{col}`:", "", consistency_table(df, col, vals), ""]
    rows, cols, mat = confusion(df)
    if mat.size:
        lines += ["## Isolation: confusion matrix (true wheel × isolated wheel)", "", "All runs:", "",
                  confusion_md(rows, cols, mat), ""]
        mats = [("all runs", rows, cols, mat)]
        for col in spec.analysis.confusion_by:
            for v in axis_values(df, col, plan):
                r2, c2, m2 = confusion(df.filter(column_eq(col, v)))
                lines += [f"{col} = {v}:", "", confusion_md(r2, c2, m2), ""]
                mats.append((f"{col} = {v}", r2, c2, m2))
        if figures:
            fig_confusion(mats, fig_dir / "confusion.png")
            lines += ["![confusion](figures/confusion.png)", ""]
    if "status" in df.columns and df.height - n_ok + unstable.height:
        lines += ["## Failed runs", ""]
        bad = pl.concat([df.filter(pl.col("status") != "ok"), unstable], how="diagonal_relaxed")
        for r in bad.head(20).iter_rows(named=True):
            labs = ", ".join(f"{c}={r.get(c)}" for c in plan.axis_columns)
            lines.append(f"- `{r['run_key']}` ({labs}, seed {r.get('seed')}): {r.get('error')}")
        lines.append("")
    text = "\n".join(lines)
    with atomic_path(out / "summary.md") as tmp:
        tmp.write_text(text)
    return text


def _n_seeds(plan: StudyPlan) -> int:
    s = plan.spec.seeds
    return len(s) if isinstance(s, list) else (s or 1)


def _safe(name: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in name)
