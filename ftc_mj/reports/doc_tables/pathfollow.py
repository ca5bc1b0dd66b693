"""The tables and verdicts of docs/findings.md, "A path-following NMPC that degrades gracefully", from the
built-in study ``pathfollow`` (``ftc_mj/data/studies/pathfollow.toml``: time-parametrised NMPC vs path-following
NMPC; its output folder is ``runs/out/studies/pathfollow`` unless ``--out`` says otherwise).

    ftc-mj study pathfollow --workers 2
    ftc-mj study pathfollow --report

Means over the seeds with the Student-t 95 % interval (``mean ± half-width``), the worst seed in brackets;
tip-over counts with the Wilson 95 % interval; the acceptance verdicts state their rule and denominator.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl

from ... import markdown as md
from ...study.stats import mean_ci, rate_ci
from .results import float_column, read_results, worst

SCEN = ("s1", "s2", "s3", "s4")
POLICIES = ("none", "direct", "safe", "truth")
CONTROLLERS = ("nmpc", "pf-nmpc")


def sel(df: pl.DataFrame, **kw: str) -> pl.DataFrame:
    """The rows whose columns equal ``kw``, by seed."""
    for k, v in kw.items():
        df = df.filter(pl.col(k) == v)
    return df.sort("seed")


def cell(df: pl.DataFrame, name: str) -> str:
    """``mean ± half-width (worst)`` of a metric over the seeds."""
    a = float_column(df, name)
    if a.size == 0 or not np.isfinite(a).any():
        return "—"
    e = mean_ci(a)
    half = f" ± {e.half:.2g}" if np.isfinite(e.half) else ""
    return f"{e.mean:.3g}{half} ({worst(a):.3g})"


def tipped(df: pl.DataFrame) -> str:
    """Tip-overs as ``k/n``."""
    e = rate_ci(df["tipped"].to_list())
    return f"{int(round(e.mean * e.n))}/{e.n}" if e.n else "—"


def comparison_table(df: pl.DataFrame) -> str:
    """Every scenario × sensing × policy × controller cell."""
    lines = md.table(["scenario", "sensing", "policy", "controller", "max \\|e_c\\| from last onset + 5 s (m)",
                      "lift-off after transients (s)", "tipped", "wheel at limit (s)", "speed last 5 s / feasible"])
    for sc in SCEN:
        for sens in ("speed", "speed+yaw"):
            for pol in POLICIES:
                for ctl in CONTROLLERS:
                    d = sel(df, fault=sc, sensors=sens, policy=pol, controller=ctl)
                    if d.height == 0:
                        continue
                    lines.append(md.row([sc[1], sens, pol, ctl, cell(d, "contouring_max_recovered"),
                                         cell(d, "liftoff_time_post_transient_s"), tipped(d),
                                         cell(d, "omega_at_limit_s"), cell(d, "speed_ratio_final")]))
    return "\n".join(lines)


def count(mask: np.ndarray) -> str:
    """``true/total``."""
    return f"{int(np.sum(mask))}/{mask.size}"


def acceptance(df: pl.DataFrame, ctl: str) -> list[str]:
    """The acceptance checks for one controller (speed + yaw rate, safe policy; speed only for item 4)."""
    out = []
    for sc in ("s2", "s3"):
        d = sel(df, fault=sc, sensors="speed+yaw", policy="safe", controller=ctl)
        e, lift = float_column(d, "contouring_max_recovered"), float_column(d, "liftoff_time_post_transient_s")
        tip = np.array(d["tipped"].to_list(), dtype=bool)
        out.append(f"scenario {sc[1]}: max |e_c| from 5 s after the last onset ≤ 0.5 m in {count(e <= 0.5)} seeds "
                   f"(worst {worst(e):.2f} m); lift-off outside the 1 s transients ≤ 0.2 s in "
                   f"{count(lift <= 0.2)} (worst {worst(lift):.2f} s); tipped in {count(tip)}")
    d = sel(df, fault="s4", sensors="speed+yaw", policy="safe", controller=ctl)
    e, ratio = float_column(d, "cross_track_max"), float_column(d, "speed_ratio_final")
    tip = np.array(d["tipped"].to_list(), dtype=bool)
    out.append(f"scenario 4: within 1 m of the path for the whole run in {count(e <= 1.0)} seeds (worst "
               f"{worst(e):.2f} m); speed over the last 5 s within 15 % of the feasible speed in "
               f"{count(np.abs(ratio - 1) <= 0.15)} (ratio {-worst(-ratio):.3f}–{worst(ratio):.3f}); tipped in "
               f"{count(tip)}")
    d = sel(df, fault="s1", sensors="speed+yaw", policy="safe", controller=ctl)
    e, v = float_column(d, "cross_track_max_settled"), float_column(d, "speed_mean_after_fault")
    out.append(f"scenario 1: mean speed within 1 % of 10 m/s in {count(np.abs(v / 10 - 1) <= 0.01)} seeds "
               f"({-worst(-v):.3f}–{worst(v):.3f} m/s); max |e_c| after 5 s ≤ 0.1 m in {count(e <= 0.1)} "
               f"(worst {worst(e):.3f} m)")
    worse, pairs = [], 0
    for sc in ("s2", "s3", "s4"):
        a = sel(df, fault=sc, sensors="speed", policy="none", controller=ctl)
        b = sel(df, fault=sc, sensors="speed", policy="safe", controller=ctl)
        for m, tol in (("contouring_max_recovered", 0.05), ("liftoff_time_post_transient_s", 0.05),
                       ("omega_at_limit_s", 0.05)):
            x, y = float_column(a, m), float_column(b, m)
            pairs += x.size
            worse += [f"s{sc[1]} {m} seed {s}" for s, xi, yi in zip(a["seed"].to_list(), x, y, strict=True)
                      if yi > xi + tol]
    out.append(f"speed only: safe worse than none by more than 0.05 (m or s) in {len(worse)} of {pairs} paired "
               f"comparisons (max |e_c| after recovery, lift-off, wheel at limit; scenarios 2–4)"
               + (": " + ", ".join(worse) if worse else ""))
    return out


def with_cell_columns(df: pl.DataFrame) -> pl.DataFrame:
    """``df`` with the columns ``sensors``, ``policy`` and ``controller`` taken from a ``cell`` label
    ``"<sensing>/<policy>/<controller>"`` (the study zips them into one axis), if it has one."""
    if "cell" not in df.columns:
        return df
    part = pl.col("cell").str.split("/")
    return df.with_columns(part.list.get(0).alias("sensors"), part.list.get(1).alias("policy"),
                           part.list.get(2).alias("controller"))


def report(out: Path) -> str:
    """The comparison table and each controller's acceptance verdicts from the study's output folder."""
    df = with_cell_columns(read_results(out))
    ok = df.filter(pl.col("status") == "ok")
    lines = [f"{df.height} runs ({df.height - ok.height} failed), seeds {sorted(set(df['seed'].to_list()))}\n",
             comparison_table(df)]
    for ctl in CONTROLLERS:
        lines.append(f"\n{ctl}:")
        lines += [f"- {line}" for line in acceptance(df, ctl)]
    return "\n".join(lines) + "\n"
