"""``ftc-mj fdi-curves STUDY_DIR``: the operating characteristics of every filter × rule as a Markdown
table, a CSV of the curves and figures (:mod:`.curves` defines every number; :mod:`.figures`
draws them), plus the filters' radius RMSE against the posterior Cramér–Rao bounds of their own
random-walk model and of the model that made the data (radii constant between the truth's changes).

RMSE against the bound (no-fault runs, from ``settle`` seconds on): the RMSE over seeds and time of
the radius estimate — each wheel, and along the observed combination and the split
(:mod:`ftc_mj.estimation.observability`) — over the RMS of the bound's σ, with a 95 % bootstrap
interval over seeds (2000 resamples of the runs).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from ...io import atomic_path
from ...markdown import row as md_row
from ...markdown import table
from ...metrics.schema import upgrade_names
from ..series import stack_series
from ..stats import fmt_g
from .cells import load_cells
from .curves import Point, RuleCurves, sweep
from .figures import draw_all


# ---------------------------------------------------------------------------- tables
def _f(e: Any, pct: bool = False, unit: str = "") -> str:
    return e.fmt(unit, pct=pct) if e is not None else "—"


def _range(e: Any, unit: str = "s") -> str:
    """Mean and its (asymmetric, percentile-bootstrap) 95 % interval: ``m [lo, hi] unit``."""
    if e is None or e.n == 0 or not math.isfinite(e.mean):
        return "—"
    if not math.isfinite(e.lo):
        return f"{fmt_g(e.mean)} {unit}"
    return f"{fmt_g(e.mean)} [{fmt_g(e.lo)}, {fmt_g(e.hi)}] {unit}"


def _arl(e: Any) -> str:
    if e.n == 0 and not math.isfinite(e.mean):
        lo = f"> {e.lo:.0f}" if math.isfinite(e.lo) else "—"
        return f"no alarm ({lo} s)"
    hi = "∞" if not math.isfinite(e.hi) else f"{e.hi:.3g}"
    return f"{e.mean:.3g} [{e.lo:.3g}, {hi}] ({e.n})"


def point_rows(rc: RuleCurves, p: Point, keys: list[str]) -> list[str]:
    """Markdown rows (one per severity) of an operating point."""
    lines = []
    for sev in sorted(p.delay, key=str):
        cells = [str(rc.cell.key[k]) for k in keys] + [rc.rule, f"{p.h:.3g}", _arl(p.arl0), str(sev),
                                                       _f(p.early[sev], pct=True), _range(p.delay[sev]),
                                                       f"{p.delay[sev].n}", _f(p.pd[sev], pct=True),
                                                       _f(p.iso[sev], pct=True), _f(p.unknown[sev], pct=True)]
        lines.append(md_row(cells))
    return lines


def points_table(curves: list[RuleCurves], keys: list[str], which: str, horizon: float) -> list[str]:
    head = [*keys, "rule", "threshold", "ARL0 s [95 %] (alarms)", "severity", "early alarm", "delay",
            "n", f"detected ≤ {horizon:g} s", "isolated right", "unknown"]
    lines = table(head)
    for rc in curves:
        p = rc.design if which == "design" else rc.matched
        if p is not None:
            lines += point_rows(rc, p, keys)
    return lines


def false_alarm_table(curves: list[RuleCurves], keys: list[str]) -> list[str]:
    """No-fault runs at the design thresholds: alarms, exposure, measured ARL0 and, for the calibrated rules,
    the measured rate over the target ``1/decision.arl0`` with its 95 % interval."""
    head = [*keys, "rule", "threshold", "runs", "alarms", "exposure (s)", "ARL0 s [95 %]",
            "rate / target [95 %]"]
    lines = table(head)
    for rc in curves:
        p, cfg = rc.design, rc.cell.config
        assert cfg is not None
        target = f"{p.rate.mean * cfg.estimator.decision.arl0:.2f} [{p.rate.lo * cfg.estimator.decision.arl0:.2f}, " \
                 f"{p.rate.hi * cfg.estimator.decision.arl0:.2f}]" if rc.rule in ("cusum", "glr") else "—"
        row = [*(str(rc.cell.key[k]) for k in keys), rc.rule, f"{p.h:.3g}", str(len(rc.cell.nofault)), str(p.rate.n),
               f"{p.exposure:.0f}", _arl(p.arl0), target]
        lines.append(md_row(row))
    return lines


def best_rules(curves: list[RuleCurves], keys: list[str], levels: tuple[float, ...]) -> list[str]:
    """Per cell and severity, the rules ordered by their shortest mean delay at a threshold whose ARL0 reaches
    each level with 95 % confidence (lower bound of its interval) and that detects at least half of the runs
    within the horizon there."""
    by_cell: dict[tuple, list[RuleCurves]] = {}
    for rc in curves:
        by_cell.setdefault(tuple(rc.cell.key.values()), []).append(rc)
    head = [*keys, "severity", *[f"ARL0 ≥ {lv:g} s: rule delay (s)" for lv in levels]]
    lines = table(head)
    for ck, rcs in by_cell.items():
        sevs = sorted({s for rc in rcs for s in rc.design.delay}, key=str)
        for sev in sevs:
            row = [str(v) for v in ck] + [str(sev)]
            for lv in levels:
                cand = []
                for rc in rcs:
                    ok = [p for p in rc.points if p.arl0.lo >= lv and sev in p.pd and p.pd[sev].mean >= 0.5
                          and math.isfinite(p.delay[sev].mean)]
                    if ok:
                        best = min(ok, key=lambda p, s=sev: p.delay[s].mean)
                        cand.append((best.delay[sev].mean, rc.rule))
                cand.sort()
                row.append(", ".join(f"{r} {d:.3g}" for d, r in cand) if cand else "none")
            lines.append(md_row(row))
    return lines


# ---------------------------------------------------------------------------- RMSE against the bound
def direction_errors(part: pl.DataFrame) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per direction — each wheel, the observed combination ``w ∝ [ω_R, ω_L]`` and the split ``d ⊥ w`` —
    the radius errors and the bound's σ (runs, samples) from the compact time series. The bound along
    ``w`` follows from ``σ_w² = σ_R² + σ_L² - σ_d²`` (the trace of the 2x2 block is invariant)."""
    eR = stack_series(part, "ts_R_R_hat") - stack_series(part, "ts_R_R")
    eL = stack_series(part, "ts_R_L_hat") - stack_series(part, "ts_R_L")
    bR, bL = stack_series(part, "ts_R_R_pcrb_std"), stack_series(part, "ts_R_L_pcrb_std")
    bd = stack_series(part, "ts_radius_split_pcrb_std")
    wR, wL = stack_series(part, "ts_omega_R"), stack_series(part, "ts_omega_L")
    n = np.hypot(wR, wL)
    wR, wL = wR / n, wL / n
    bw = np.sqrt(np.maximum(bR * bR + bL * bL - bd * bd, 0.0))
    return {"R_R": (eR, bR), "R_L": (eL, bL), "observed": (wR * eR + wL * eL, bw), "split": (wL * eR - wR * eL, bd)}


def rmse_over_pcrb(e: np.ndarray, b: np.ndarray, late: np.ndarray,
                   rng: np.random.Generator) -> tuple[float, float, float]:
    """Pooled RMSE over the RMS bound, with a 95 % bootstrap interval over runs (see the module docstring)."""
    if not (e.size and b.size):
        return math.nan, math.nan, math.nan
    e2 = np.where(late, e * e, np.nan)
    b2 = np.where(late, b * b, np.nan)

    def ratio(idx: np.ndarray) -> float:
        return math.sqrt(np.nanmean(e2[idx]) / np.nanmean(b2[idx]))

    n = e.shape[0]
    boots = [ratio(rng.integers(0, n, n)) for _ in range(2000)]
    return ratio(np.arange(n)), float(np.percentile(boots, 2.5)), float(np.percentile(boots, 97.5))


def _ratio_table(df: pl.DataFrame, keys: list[str], settle: float, needed: str, columns: list[str],
                 pairs: Callable[[pl.DataFrame], list[tuple[np.ndarray, np.ndarray]]]) -> list[str]:
    """A table of ``RMSE / RMS bound [95 %] (RMS bound)`` per cell of the no-fault runs (samples from ``settle``
    s on, bootstrap over runs): one column per ``(error, bound)`` pair that ``pairs(part)`` gives, titled by
    ``columns``; cells without the column ``needed`` are left out."""
    nof = df.filter(pl.col("fault_onset_time").is_null() & (pl.col("status") == "ok"))
    head = [*keys, "runs", *columns]
    lines = table(head)
    rng = np.random.default_rng(0)
    for ck, part in nof.group_by(keys, maintain_order=True):
        if needed not in part.columns:
            continue
        late = stack_series(part, "ts_t") >= settle
        vals = []
        for e, b in pairs(part):
            r, lo, hi = rmse_over_pcrb(e, b, late, rng)
            rms_b = math.sqrt(np.nanmean(np.where(late, b * b, np.nan)))
            vals.append(f"{r:.3g} [{lo:.3g}, {hi:.3g}] ({rms_b:.3g})")
        lines.append(md_row([*ck, part.height, *vals]))
    return lines


def rmse_table(df: pl.DataFrame, keys: list[str], settle: float) -> list[str]:
    """The filters' own PCRB (random-walk radii): RMSE over it per wheel, along the observed direction and
    across it (the split), no-fault runs."""
    dirs = ("R_R", "R_L", "observed", "split")
    return _ratio_table(df, keys, settle, "ts_omega_R", [f"{d}: RMSE / PCRB [95 %] (PCRB σ m)" for d in dirs],
                        lambda part: list(direction_errors(part).values()))


def rmse_const_table(df: pl.DataFrame, keys: list[str], settle: float) -> list[str]:
    """Each wheel's RMSE over the RMS of the bound of the model that made the data (radii constant between
    the truth's changes, ``*_pcrb_const_std``), no-fault runs, with its 95 % bootstrap interval over runs:
    no estimator is below 1 in expectation over that model's prior."""
    wheels = ("R_R", "R_L")
    return _ratio_table(
        df, keys, settle, "ts_R_R_pcrb_const_std", [f"{w}: RMSE / bound [95 %] (bound σ m)" for w in wheels],
        lambda part: [(stack_series(part, f"ts_{w}_hat") - stack_series(part, f"ts_{w}"),
                       stack_series(part, f"ts_{w}_pcrb_const_std")) for w in wheels])


# ---------------------------------------------------------------------------- output
def write_csv(curves: list[RuleCurves], keys: list[str], path: Path) -> None:
    """Every swept point: cell keys, rule, threshold, ARL0 and per-severity statistics."""
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow([*keys, "rule", "threshold", "arl0_s", "arl0_lo", "arl0_hi", "false_alarm_window",
                    "severity", "delay_s", "delay_lo", "delay_hi", "detected_runs", "p_detect_horizon",
                    "early_alarm", "isolation_correct", "isolation_unknown"])
        for rc in curves:
            for p in rc.points:
                for sev in p.delay:
                    d = p.delay[sev]
                    w.writerow([*(rc.cell.key[k] for k in keys), rc.rule, p.h, p.arl0.mean, p.arl0.lo, p.arl0.hi,
                                p.pfa.mean, sev, d.mean, d.lo, d.hi, d.n, p.pd[sev].mean, p.early[sev].mean,
                                p.iso[sev].mean, p.unknown[sev].mean])


def fdi_curves(study_dir: Path, out: Path | None = None, *, fault_axis: str = "severity", horizon: float = 2.0,
               arl0: float = 100.0, settle: float = 10.0, figures: bool = True) -> Path:
    """Write ``OUT/fdi.md``, ``OUT/fdi_curves.csv`` and ``OUT/figures/`` (default OUT: ``STUDY_DIR/fdi``)."""
    study_dir = Path(study_dir)
    out = Path(out) if out is not None else study_dir / "fdi"
    cells, keys = load_cells(study_dir, fault_axis)
    curves = sweep(cells, horizon, arl0)
    df = upgrade_names(pl.read_parquet(study_dir / "results.parquet"))
    out.mkdir(parents=True, exist_ok=True)
    write_csv(curves, keys, out / "fdi_curves.csv")
    lines = [f"# FDI operating characteristics: `{study_dir.name}`", "",
             f"Cells: {len(cells)} ({', '.join(f'`{k}`' for k in keys)}); fault axis `{fault_axis}`; "
             f"detection horizon {horizon:g} s. Definitions: `ftc_mj/study/fdi/curves.py`.", "",
             "## False alarms at the design thresholds (no-fault runs)", "",
             "sigma: `k_sigma`; mode: `mode_threshold`; cusum, glr: calibrated for the configured `decision.arl0`.",
             "", *false_alarm_table(curves, keys), "",
             "## Detection at the design thresholds", "", *points_table(curves, keys, "design", horizon), "",
             f"## At ARL0 = {arl0:g} s matched on development seeds (< 1000), judged on held-out seeds (≥ 1000)",
             "", "Empty when the study lacks either set or 3.69 × ARL0 of alarm-free development exposure per cell.",
             "",
             *points_table(curves, keys, "matched", horizon), "",
             "## Shortest delay at a given mean time between false alarms", "",
             *best_rules(curves, keys, (10.0, 30.0, 100.0)), "",
             f"## Radius RMSE over the posterior Cramér–Rao bound (no-fault runs, t ≥ {settle:g} s)", "",
             *rmse_table(df, keys, settle), "",
             f"## Radius RMSE over the bound of the model that made the data (radii constant; no-fault runs, "
             f"t ≥ {settle:g} s)", "", *rmse_const_table(df, keys, settle), ""]
    if figures:
        lines += ["## Figures", "", *draw_all(curves, cells, keys, df, out / "figures", horizon), ""]
    with atomic_path(out / "fdi.md") as tmp:
        tmp.write_text("\n".join(lines))
    return out
