"""Figures of ``ftc-mj fdi-curves``: delay against mean time between false alarms (with Lorden's
bound), detection within the horizon against false alarm in a window (ROC), isolation accuracy, and
radius RMSE over time against the posterior Cramér–Rao bound.

Layout: one figure per combination of the cell axes but the last (e.g. plant × sensors); its rows
are the values of the last cell axis (e.g. the filter), its columns the severities.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from ..plotting import pyplot, save_figure
from ..series import series_time, stack_series
from ..stats import Estimate, log_scale_interval, ts_mean
from .cells import Cell
from .curves import RuleCurves, lorden_curve

COLOURS = {"sigma": "tab:blue", "mode": "tab:green", "cusum": "tab:orange", "glr": "tab:red"}


def _groups(curves: list[RuleCurves], keys: list[str]) -> dict[tuple, dict[Any, list[RuleCurves]]]:
    """Figure key (all cell keys but the last) → row value (last key) → that cell's rule curves."""
    out: dict[tuple, dict[Any, list[RuleCurves]]] = {}
    for rc in curves:
        vals = [rc.cell.key[k] for k in keys]
        out.setdefault(tuple(vals[:-1]), {}).setdefault(vals[-1] if vals else "", []).append(rc)
    return out


def arl0_axis(points: list[Any]) -> tuple[np.ndarray, np.ndarray]:
    """x of each point on an ARL0 axis: the estimate; where no false alarm was seen only the first such
    point (lowest threshold) is kept, at the fault-free seconds observed — ARL0 is only known to be
    of that order or more — and drawn as an open marker; higher thresholds add nothing (NaN)."""
    x = np.array([p.arl0.mean for p in points])
    censored = ~np.isfinite(x)
    first = int(np.argmax(censored)) if censored.any() else -1
    x = np.where(censored, np.nan, x)
    if first >= 0:
        x[first] = points[first].exposure
    return x, censored


def _band(ax: Any, x: np.ndarray, m: np.ndarray, lo: np.ndarray, hi: np.ndarray, colour: str, label: str,
          censored: np.ndarray | None = None) -> None:
    """A rule's mean line with its interval band (no band where the interval is undefined) and open markers
    at the censored points."""
    ok = np.isfinite(x) & np.isfinite(m) & (x > 0)
    if not ok.any():
        return
    order = np.argsort(x[ok])
    xs, ms = x[ok][order], m[ok][order]
    ax.plot(xs, ms, color=colour, label=label, lw=1.2)
    los, his = lo[ok][order], hi[ok][order]
    ax.fill_between(xs, np.where(np.isfinite(los), los, ms), np.where(np.isfinite(his), his, ms),
                    color=colour, alpha=0.15, lw=0)
    if censored is not None and (censored & ok).any():
        c = censored & ok
        ax.plot(x[c], m[c], "o", mfc="none", color=colour, ms=4)


def _rule_band(ax: Any, rc: RuleCurves, ests: list[Estimate], lo: np.ndarray, hi: np.ndarray) -> None:
    """One rule's estimates over its swept points against their ARL0 (:func:`arl0_axis`), band ``[lo, hi]``."""
    x, cens = arl0_axis(rc.points)
    _band(ax, x, np.array([e.mean for e in ests]), lo, hi, COLOURS[rc.rule], rc.rule, cens)


def _log(ax: Any, x: bool = True, y: bool = True) -> None:
    """Log scales on the axes that have positive finite data (an empty panel stays linear)."""
    def has(get: str) -> bool:
        for ln in ax.lines:
            v = np.asarray(getattr(ln, get)(), float)
            if np.any(np.isfinite(v) & (v > 0)):
                return True
        return False

    if x and has("get_xdata"):
        ax.set_xscale("log")
    if y and has("get_ydata"):
        ax.set_yscale("log")


def _legend(fig: Any, rows: dict[Any, list[RuleCurves]], lorden: bool = False) -> None:
    """One legend for the figure, below the panels (where it covers neither a panel nor the title): every
    rule drawn in it (and Lorden's bound), in as many columns as fit the figure's width."""
    from matplotlib.lines import Line2D

    rules = [r for r in COLOURS if any(rc.rule == r for rcs in rows.values() for rc in rcs)]
    handles = [Line2D([], [], color=COLOURS[r], lw=1.5, label=r) for r in rules]
    if lorden:
        handles.append(Line2D([], [], color="k", ls="--", lw=1, label="Lorden bound"))
    ncol = max(1, min(len(handles), int(fig.get_figwidth() / 1.1)))
    fig.legend(handles=handles, loc="lower center", fontsize=7, ncol=ncol, frameon=False)


def _finish(fig: Any, text: str, legend_rows: int) -> None:
    """Title ``text`` wrapped to the figure's width (about 16 characters per inch at 8 pt), above the
    panels, and the layout fitted between it and the legend's ``legend_rows`` rows below."""
    import textwrap

    width = max(30, int(16 * fig.get_figwidth()))
    lines = [ln for part in text.split("\n") for ln in textwrap.wrap(part, width)]
    fig.suptitle("\n".join(lines), fontsize=8, x=0.02, ha="left")
    title_in, legend_in = 0.13 * len(lines) + 0.05, 0.2 * legend_rows + 0.05
    h = fig.get_figheight() + title_in + legend_in  # the panels keep their height
    fig.set_figheight(h)
    fig.tight_layout(rect=(0, legend_in / h, 1, 1.0 - title_in / h))


def _legend_rows(fig: Any, rows: dict[Any, list[RuleCurves]], lorden: bool = False) -> int:
    """Rows the legend of :func:`_legend` takes."""
    n = sum(1 for r in COLOURS if any(rc.rule == r for rcs in rows.values() for rc in rcs)) + int(lorden)
    return math.ceil(n / max(1, min(n, int(fig.get_figwidth() / 1.1))))


def _grid(rows: dict[Any, list[RuleCurves]], plt: Any) -> tuple[Any, Any, list[Any]]:
    sevs = sorted({s for rcs in rows.values() for rc in rcs for s in rc.design.delay}, key=str)
    fig, axs = plt.subplots(len(rows), len(sevs), figsize=(3.3 * len(sevs), 2.6 * len(rows)), squeeze=False)
    return fig, axs, sevs


def _panel(ax: Any, title: str, last_row: bool, first_col: bool, xlabel: str, ylabel: str,
           which: str = "both") -> None:
    """Title, ticks and grid of one panel of a rows × severities grid; axis labels on the outer panels."""
    ax.set_title(title, fontsize=8)
    ax.tick_params(labelsize=7)
    ax.grid(alpha=0.3, which=which)
    if last_row:
        ax.set_xlabel(xlabel, fontsize=7)
    if first_col:
        ax.set_ylabel(ylabel, fontsize=7)


def _panels(rows: dict[Any, list[RuleCurves]], axs: Any,
            sevs: list[Any]) -> Iterator[tuple[Any, Any, Any, list[RuleCurves], bool, bool]]:
    """Each panel of a rows × severities grid: ``(axes, row value, severity, the row's curves with that
    severity, last row, first column)``."""
    for i, (rv, rcs) in enumerate(rows.items()):
        for j, sev in enumerate(sevs):
            yield axs[i, j], rv, sev, [r for r in rcs if sev in r.design.delay], i == len(rows) - 1, j == 0


def fig_delay(rows: dict[Any, list[RuleCurves]], title: str, path: Path) -> None:
    """Mean conditional delay (s) against measured ARL0 (s), per rule, with Lorden's bound; the band is the
    95 % interval of the mean on the log scale (:func:`~ftc_mj.study.stats.log_scale_interval`: positive,
    as the log axis needs)."""
    plt = pyplot()
    fig, axs, sevs = _grid(rows, plt)
    for ax, rv, sev, rcs, last_row, first_col in _panels(rows, axs, sevs):
        for rc in rcs:
            d = [p.delay[sev] for p in rc.points]
            lo, hi = np.array([log_scale_interval(e) for e in d]).reshape(-1, 2).T
            _rule_band(ax, rc, d, lo, hi)
            dp = rc.design
            xd, cd = arl0_axis([dp])
            if sev in dp.delay and math.isfinite(xd[0]) and math.isfinite(dp.delay[sev].mean):
                ax.plot(xd, [dp.delay[sev].mean], "o", color=COLOURS[rc.rule], ms=5,
                        mfc="none" if cd[0] else COLOURS[rc.rule], mew=1.5)
        cell = rows[rv][0].cell
        la, lb = lorden_curve(cell, sev) if sev in cell.faults else (np.zeros(0), np.zeros(0))
        ax.plot(la, lb, "k--", lw=1)
        _log(ax)
        _panel(ax, f"{rv}, severity {sev}", last_row, first_col,
               "ARL0: mean time between false alarms (s)", "detection delay (s)")
    _legend(fig, rows, lorden=True)
    _finish(fig, f"{title}: delay against mean time between false alarms\n(filled dots: design thresholds; open: "
                 "no false alarm in the fault-free seconds observed, drawn there)", _legend_rows(fig, rows, True))
    save_figure(fig, path)


def fig_roc(rows: dict[Any, list[RuleCurves]], title: str, horizon: float, path: Path) -> None:
    """Detection within the horizon against false alarm in a window of the same length."""
    plt = pyplot()
    fig, axs, sevs = _grid(rows, plt)
    for ax, rv, sev, rcs, last_row, first_col in _panels(rows, axs, sevs):
        for rc in rcs:
            x = np.array([p.pfa.mean for p in rc.points])
            y = np.array([p.pd[sev].mean for p in rc.points])
            order = np.argsort(x)
            ax.plot(x[order], y[order], ".-", color=COLOURS[rc.rule], label=rc.rule, lw=1, ms=3)
        ax.plot([0, 1], [0, 1], color="0.7", lw=0.8)
        ax.set_xlim(-0.02, 1.02)
        ax.set_ylim(-0.02, 1.02)
        _panel(ax, f"{rv}, severity {sev}", last_row, first_col,
               f"P(false alarm within {horizon:g} s)", f"P(detection within {horizon:g} s)", which="major")
    _legend(fig, rows)
    _finish(fig, f"{title}: ROC (runs without an earlier alarm)", _legend_rows(fig, rows))
    save_figure(fig, path)


def fig_isolation(rows: dict[Any, list[RuleCurves]], title: str, path: Path) -> None:
    """Fraction of detections isolating the true wheel against measured ARL0."""
    plt = pyplot()
    fig, axs, sevs = _grid(rows, plt)
    for ax, rv, sev, rcs, last_row, first_col in _panels(rows, axs, sevs):
        for rc in rcs:
            e = [p.iso[sev] for p in rc.points]
            if e:
                _rule_band(ax, rc, e, np.array([v.lo for v in e]), np.array([v.hi for v in e]))
        _log(ax, y=False)
        ax.set_ylim(-0.02, 1.02)
        _panel(ax, f"{rv}, severity {sev}", last_row, first_col, "ARL0 (s)", "isolated the true wheel")
    _legend(fig, rows)
    _finish(fig, f"{title}: isolation accuracy of the detections", _legend_rows(fig, rows))
    save_figure(fig, path)


def fig_rmse(df: pl.DataFrame, keys: list[str], severity_of: dict[str, Any], path: Path) -> None:
    """Left-radius RMSE over seeds against time and the bound's σ, per cell of all keys but the last (panels)
    and the last key (lines); no-fault runs in the first row, each severity in the next."""
    plt = pyplot()
    ok = df.filter(pl.col("status") == "ok")
    panels = list(dict.fromkeys(tuple(r[k] for k in keys[:-1]) for r in ok.iter_rows(named=True)))
    sevs = list(dict.fromkeys(severity_of.values()))
    fig, axs = plt.subplots(len(sevs), len(panels), figsize=(3.6 * len(panels), 2.6 * len(sevs)), squeeze=False)
    for j, pk in enumerate(panels):
        sub = ok
        for k, v in zip(keys[:-1], pk, strict=True):
            sub = sub.filter(pl.col(k) == v)
        for i, sev in enumerate(sevs):
            ax = axs[i, j]
            part_s = sub.filter(pl.col("run_key").is_in([k for k, s in severity_of.items() if s == sev]))
            for lv, part in part_s.group_by(keys[-1], maintain_order=True):
                t = series_time(part)
                e = stack_series(part, "ts_R_L_hat") - stack_series(part, "ts_R_L")
                rmse = np.sqrt(np.nanmean(e * e, axis=0))
                line = ax.plot(t, rmse, lw=1, label=str(lv[0]))
                b = ts_mean(stack_series(part, "ts_R_L_pcrb_std"))
                ax.plot(t, b, "--", lw=0.8, color=line[0].get_color())
                c = ts_mean(stack_series(part, "ts_R_L_pcrb_const_std"))
                if c.size:
                    ax.plot(t[: c.size], c, ":", lw=1.0, color=line[0].get_color())
            _log(ax, x=False)
            ax.set_title(f"{', '.join(map(str, pk))}; severity {sev}", fontsize=8)
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3, which="both")
            if j == 0:
                ax.set_ylabel("R_L RMSE (—) and bounds' σ (m)", fontsize=7)
            if i == len(sevs) - 1:
                ax.set_xlabel("t (s)", fontsize=7)
    axs[0, 0].legend(fontsize=6)
    _finish(fig, "left-radius RMSE over seeds against the posterior Cramér–Rao bounds of the filters' random-walk "
                 "model (--) and of the model that made the data, radii constant between changes (··)", 0)
    save_figure(fig, path)


def draw_all(curves: list[RuleCurves], cells: list[Cell], keys: list[str], df: pl.DataFrame, out: Path,
             horizon: float) -> list[str]:
    """Draw every figure into ``out``; returns Markdown lines linking them."""
    out.mkdir(parents=True, exist_ok=True)
    links = []
    for fk, rows in _groups(curves, keys).items():
        if not any(rc.design.delay for rcs in rows.values() for rc in rcs):
            continue  # no fault runs: nothing to draw against the false-alarm rate
        name = "_".join(str(v) for v in fk).replace("+", "-").replace(" ", "") or "all"
        title = ", ".join(str(v) for v in fk) or "all cells"
        for kind, fn in (("delay", lambda p, r=rows, t=title: fig_delay(r, t, p)),
                         ("roc", lambda p, r=rows, t=title: fig_roc(r, t, horizon, p)),
                         ("isolation", lambda p, r=rows, t=title: fig_isolation(r, t, p))):
            path = out / f"{kind}_{name}.png"
            fn(path)
            links.append(f"![{kind} {title}](figures/{path.name})")
    severity_of = {}
    for cell in cells:
        for r in cell.nofault:
            severity_of[r.key] = "no fault"
        for sev, runs in cell.faults.items():
            for r in runs:
                severity_of[r.key] = sev
    fig_rmse(df, keys, severity_of, out / "rmse_pcrb.png")
    links.append("![radius RMSE against the PCRB](figures/rmse_pcrb.png)")
    return links
