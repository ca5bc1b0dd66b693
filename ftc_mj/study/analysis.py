"""Study analysis: ``summary.md`` and figures from ``results.parquet``.

Every metric is grouped by each axis in turn (pooling the other axes and the Monte-Carlo seeds)
and reported as mean ± half-width of the 95 % confidence interval (Student t for continuous
metrics, Wilson score interval for rates). Filter consistency is reported as the Monte-Carlo ANEES
and ANIS of each group with their two-sided 95 % χ² bounds (:func:`consistency_table`). The study
file's ``[[analysis.findings]]`` turn into sentences with numbers generated from the data; nothing
in the summary is written by hand.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from ..estimation.consistency import ChiSquareTest, combine
from ..io import atomic_path
from .spec import FindingSpec, StudyPlan


@dataclass(frozen=True)
class MetricDef:
    """A summarised metric: column, label, unit, and whether it is a rate (0/1 per run)."""

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
Z95 = 1.959963984540054


# ---------------------------------------------------------------------------- statistics
def t_crit(n: int) -> float:
    """Two-sided 95 % Student-t critical value for ``n`` samples (n - 1 dof)."""
    if n < 2:
        return float("nan")
    from scipy.stats import t

    return float(t.ppf(0.975, n - 1))


@dataclass(frozen=True)
class Estimate:
    """Mean and 95 % CI of a metric over a group of runs."""

    mean: float
    lo: float
    hi: float
    n: int

    @property
    def half(self) -> float:
        return (self.hi - self.lo) / 2.0

    def fmt(self, unit: str = "", pct: bool = False) -> str:
        if self.n == 0 or not math.isfinite(self.mean):
            return "—"
        if pct:
            return f"{100 * self.mean:.0f} % [{100 * self.lo:.0f}, {100 * self.hi:.0f}]"
        u = f" {unit}" if unit and unit not in ("fraction", "per run") else ""
        if not math.isfinite(self.half):
            return f"{_g(self.mean)}{u}"
        return f"{_g(self.mean)} ± {_g(self.half)}{u}"


def _g(x: float) -> str:
    if x == 0 or not math.isfinite(x):
        return f"{x:g}"
    return f"{x:.3g}" if 1e-3 <= abs(x) < 1e5 else f"{x:.2e}"


def mean_ci(values: Sequence[float] | np.ndarray) -> Estimate:
    """Mean with a Student-t 95 % CI (non-finite values dropped)."""
    a = np.asarray([v for v in values if v is not None], dtype=float)
    a = a[np.isfinite(a)]
    n = int(a.size)
    if n == 0:
        return Estimate(float("nan"), float("nan"), float("nan"), 0)
    m = float(a.mean())
    if n < 2:
        return Estimate(m, float("nan"), float("nan"), 1)
    h = t_crit(n) * float(a.std(ddof=1)) / math.sqrt(n)
    return Estimate(m, m - h, m + h, n)


def rate_ci(values: Sequence[Any] | np.ndarray) -> Estimate:
    """Proportion of true values with the Wilson 95 % interval (None values dropped)."""
    a = [bool(v) for v in values if v is not None and not (isinstance(v, float) and math.isnan(v))]
    n = len(a)
    if n == 0:
        return Estimate(float("nan"), float("nan"), float("nan"), 0)
    p = sum(a) / n
    z2 = Z95**2
    centre = (p + z2 / (2 * n)) / (1 + z2 / n)
    half = Z95 * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / (1 + z2 / n)
    return Estimate(p, max(0.0, centre - half), min(1.0, centre + half), n)


def estimate(df: pl.DataFrame, mdef: MetricDef) -> Estimate:
    """The metric's estimate over the rows of ``df``."""
    if mdef.column not in df.columns or df.height == 0:
        return Estimate(float("nan"), float("nan"), float("nan"), 0)
    vals = df[mdef.column].to_list()
    return rate_ci(vals) if mdef.rate else mean_ci([float(v) if v is not None else None for v in vals])


# ---------------------------------------------------------------------------- data
def prepare(results: pl.DataFrame) -> pl.DataFrame:
    """Add derived columns (absolute final errors, failed flag)."""
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
    # a detection delay only means something when a fault was injected and detected
    return df


def axis_values(df: pl.DataFrame, column: str, plan: StudyPlan | None = None) -> list[Any]:
    """Distinct labels of an axis in plan order."""
    if plan is not None:
        seen: list[Any] = []
        for r in plan.runs:
            v = r.labels.get(column)
            if v not in seen:
                seen.append(v)
        present = set(df[column].to_list()) if column in df.columns else set()
        return [v for v in seen if v in present]
    return list(dict.fromkeys(df[column].to_list()))


def _eq(column: str, value: Any) -> pl.Expr:
    return pl.col(column) == pl.lit(value)


def grouped(df: pl.DataFrame, column: str, values: list[Any], mdef: MetricDef) -> list[tuple[Any, Estimate]]:
    return [(v, estimate(df.filter(_eq(column, v)), mdef)) for v in values]


# ---------------------------------------------------------------------------- findings
def finding_text(df: pl.DataFrame, f: FindingSpec, plan: StudyPlan | None) -> list[str]:
    """Sentences stating one finding with numbers from the data."""
    sub = df
    for k, v in f.where.items():
        if k in sub.columns:
            sub = sub.filter(_eq(k, v))
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
        splits = [(f" ({f.by} = {b})", sub.filter(_eq(f.by, b))) for b in axis_values(sub, f.by, plan)]
    lines = []
    for suffix, part in splits:
        if len(vals) > 3:  # many values: list them all, then compare the extremes
            ests = [(v, estimate(part.filter(_eq(f.axis, v)), mdef)) for v in vals]
            listing = "; ".join(f"{v}: {e.fmt(mdef.unit, mdef.rate)}" for v, e in ests)
            (v0, e0), (v1, e1) = ests[0], ests[-1]
            lines.append(f"- {title}{suffix}, by {f.axis}: {listing}. "
                         + _sentence(_compare(f.axis, v0, v1, e0, e1, mdef, title)) + ".")
            lines.extend(_paired_lines(part, f, mdef, base, vals, plan))
            continue
        eb = estimate(part.filter(_eq(f.axis, base)), mdef)
        phrases = []
        for v in vals:
            if v == base:
                continue
            ev = estimate(part.filter(_eq(f.axis, v)), mdef)
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
    a = df.filter(_eq(axis, base)).select([*keys, pl.col(col).cast(pl.Float64).alias("_b")])
    b = df.filter(_eq(axis, v)).select([*keys, pl.col(col).cast(pl.Float64).alias("_v")])
    j = a.join(b, on=keys, how="inner").drop_nulls(["_b", "_v"])
    if j.height == 0:
        return f"paired, {axis} = {v} vs {base}: no matching runs"
    d = (j["_v"] - j["_b"]).to_numpy()
    worse = d > tolerance if mdef.lower_is_better else d < -tolerance
    excess = float(np.max(d) if mdef.lower_is_better else -np.min(d))
    u = f" {mdef.unit}" if mdef.unit else ""
    return (f"paired, {axis} = {v} vs {base}: worse by more than {tolerance:g}{u} in {int(worse.sum())} of "
            f"{j.height} matched runs (largest excess {_g(excess)}{u}; worst {axis} = {v}: "
            f"{_g(float(np.max(j['_v'].to_numpy()) if mdef.lower_is_better else np.min(j['_v'].to_numpy())))}{u}, "
            f"worst {axis} = {base}: "
            f"{_g(float(np.max(j['_b'].to_numpy()) if mdef.lower_is_better else np.min(j['_b'].to_numpy())))}{u})")


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


# ---------------------------------------------------------------------------- tables
def axis_table(df: pl.DataFrame, column: str, values: list[Any], metrics: list[MetricDef]) -> str:
    """Markdown table: one row per axis value, one column per metric (mean ± CI)."""
    head = f"| {column} | n | " + " | ".join(_md(m.label) + (f" ({m.unit})" if m.unit else "") for m in metrics) + " |"
    sep = "|" + "---|" * (len(metrics) + 2)
    lines = [head, sep]
    for v in values:
        part = df.filter(_eq(column, v))
        cells = [estimate(part, m).fmt("", m.rate) for m in metrics]
        lines.append(f"| {_md(str(v))} | {part.height} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _md(text: str) -> str:
    """Escape a table cell for markdown."""
    return text.replace("|", "\\|")


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
    lines = ["| true \\ isolated | " + " | ".join(cols) + " |", "|" + "---|" * (len(cols) + 1)]
    for i, r in enumerate(rows):
        lines.append(f"| {r} | " + " | ".join(str(int(x)) for x in mat[i]) + " |")
    return "\n".join(lines)


# ---------------------------------------------------------------------------- time series
def _stack(df: pl.DataFrame, column: str) -> np.ndarray:
    """Stack a list column into a (runs, samples) array, NaN-padded."""
    if column not in df.columns:
        return np.zeros((0, 0))
    lists = [x if x is not None else [] for x in df[column].to_list()]
    n = max((len(x) for x in lists), default=0)
    out = np.full((len(lists), n), np.nan)
    for i, x in enumerate(lists):
        out[i, : len(x)] = [np.nan if v is None else v for v in x]
    return out


def _ts_time(df: pl.DataFrame) -> np.ndarray:
    t = _stack(df, "ts_t")
    return np.nanmax(t, axis=0) if t.size else np.zeros(0)


def ts_mean_ci(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-sample mean and CI half-width across runs (rows)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        n = np.sum(np.isfinite(a), axis=0)
        m = np.nanmean(np.where(np.isfinite(a), a, np.nan), axis=0) if a.size else np.zeros(0)
        s = np.nanstd(a, axis=0, ddof=1) if a.shape[0] > 1 else np.full(a.shape[1], np.nan)
        tc = np.array([t_crit(int(k)) if k >= 2 else np.nan for k in n])
        return m, tc * s / np.sqrt(np.maximum(n, 1))


def indicated_wheel(df: pl.DataFrame) -> np.ndarray:
    """Per run and sample: 1 if the declared wheel equals the true faulty set at that time, 0 if not
    (NaN where the run has no sample), over the samples with a fault in the plant (NaN elsewhere).

    The faulty set comes from the true radii (a wheel is faulty once its radius has left its initial
    value), the declared wheel from ``declared_wheel``. Results without that column (older studies)
    fall back to the estimates: the wheel whose estimate dropped more below nominal (``both`` if both
    dropped by over 25 %), while a fault is declared."""
    det = _stack(df, "ts_fault_detected")
    rR, rL = _stack(df, "ts_R_R"), _stack(df, "ts_R_L")
    if not (det.size and rR.size and rL.size):
        return np.zeros((0, 0))
    fR, fL = np.abs(rR - rR[:, :1]) > 1e-9, np.abs(rL - rL[:, :1]) > 1e-9
    truth = np.where(fR & fL, 3, np.where(fR, 1, np.where(fL, 2, 0)))
    code = _stack(df, "ts_declared_wheel")
    if code.size:
        ind = np.where(det > 0.5, code, 0)
    else:
        eR, eL = _stack(df, "ts_R_R_hat"), _stack(df, "ts_R_L_hat")
        dropR, dropL = (rR[:, :1] - eR) / rR[:, :1], (rL[:, :1] - eL) / rL[:, :1]
        ind = np.where(det > 0.5, np.where((dropR > 0.25) & (dropL > 0.25), 3, np.where(dropL > dropR, 2, 1)), 0)
    ok = (ind == truth).astype(float)
    return np.where(np.isfinite(det) & (truth > 0), ok, np.nan)


# ---------------------------------------------------------------------------- consistency
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
    return f"{_g(test.value)} [{_g(test.lo)}, {_g(test.hi)}] {where}, n_eff {test.n_eff:.0f}"


def consistency_table(df: pl.DataFrame, column: str, values: list[Any]) -> str:
    """Markdown table: per axis value, each consistency statistic pooled over the group's runs
    (:func:`~ftc_mj.estimation.consistency.combine`) with its two-sided 95 % χ² bounds."""
    head = f"| {column} | runs | " + " | ".join(_md(label) for _, label, _ in CONSISTENCY) + " |"
    lines = [head, "|" + "---|" * (len(CONSISTENCY) + 2)]
    for v in values:
        part = df.filter(_eq(column, v))
        cells = [consistency_cell(combine(run_tests(part, p), per_dof=pd)) for p, _, pd in CONSISTENCY]
        lines.append(f"| {_md(str(v))} | {part.height} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


CONSISTENCY_NOTE = (
    "Filter consistency: each run's NEES/NIS is averaged over its steps; the runs of a group are pooled "
    "(weighted by their samples) and the bounds are the two-sided 95 % χ² bounds for the pooled effective "
    "number of independent samples, n_eff = Σ samples / τ, τ being each run's integrated autocorrelation "
    "time of the statistic (successive NEES values are correlated; innovations of a consistent filter are "
    "not). The truth plant is not the filters' model, so *outside* is expected on the MuJoCo plant; the "
    "statistics test the filter only on in-model data."
)


# ---------------------------------------------------------------------------- figures
def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def fig_axis_metrics(df: pl.DataFrame, column: str, values: list[Any], metrics: list[MetricDef], path: Path) -> None:
    """Error-bar panels: each metric's mean and 95 % CI per value of one axis."""
    plt = _plt()
    k = len(metrics)
    ncol = min(4, k)
    nrow = math.ceil(k / ncol)
    fig, axs = plt.subplots(nrow, ncol, figsize=(3.4 * ncol, 2.7 * nrow), squeeze=False)
    x = np.arange(len(values))
    for ax, m in zip(axs.flat, metrics, strict=False):
        ests = [e for _, e in grouped(df, column, values, m)]
        mean = np.array([e.mean for e in ests])
        lo = np.clip([e.mean - e.lo if math.isfinite(e.lo) else 0.0 for e in ests], 0.0, None)
        hi = np.clip([e.hi - e.mean if math.isfinite(e.hi) else 0.0 for e in ests], 0.0, None)
        ax.errorbar(x, mean, yerr=[lo, hi], fmt="o", capsize=3)
        ax.set_xticks(x, [str(v) for v in values], rotation=30 if len(values) > 4 else 0, fontsize=7)
        ax.set_title(m.label + (f" ({m.unit})" if m.unit else ""), fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    for ax in list(axs.flat)[k:]:
        ax.set_visible(False)
    fig.suptitle(f"by {column} (mean, 95 % CI)", fontsize=9)
    fig.tight_layout()
    _save(fig, path)


def fig_timeseries(df: pl.DataFrame, column: str, values: list[Any], path: Path) -> None:
    """Over time, per axis value: |radius errors| (mean, 95 % CI band), fraction of runs that
    declared a fault, and fraction whose estimates point to the true wheel."""
    plt = _plt()
    fig, axs = plt.subplots(1, 4, figsize=(15, 3.2))
    for v in values:
        part = df.filter(_eq(column, v))
        t = _ts_time(part)
        if t.size == 0:
            continue
        for ax, w in zip(axs[:2], ("R", "L"), strict=True):
            e = np.abs(_stack(part, f"ts_R_{w}_hat") - _stack(part, f"ts_R_{w}"))
            if e.size == 0:
                continue
            m, h = ts_mean_ci(e)
            ax.plot(t[: m.size], m, label=str(v))
            ax.fill_between(t[: m.size], m - np.nan_to_num(h), m + np.nan_to_num(h), alpha=0.2)
        det = _stack(part, "ts_fault_detected")
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
    _save(fig, path)


def fig_confusion(mats: list[tuple[str, list[str], list[str], np.ndarray]], path: Path) -> None:
    plt = _plt()
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
    _save(fig, path)


def _save(fig: Any, path: Path) -> None:
    plt = _plt()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)


# ---------------------------------------------------------------------------- summary
def analyse_study(plan: StudyPlan, results: pl.DataFrame, out: Path, *, figures: bool = True) -> str:
    """Write ``out/summary.md`` (and ``out/figures/*.png``); return the markdown."""
    out = Path(out)
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
                r2, c2, m2 = confusion(df.filter(_eq(col, v)))
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
