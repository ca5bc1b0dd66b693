"""The old and the new input-rate formulation side by side (docs/findings.md, "The input-rate bound"),
from the built-in study ``rate_bound``.

    ftc-mj study rate_bound --workers 2
    ftc-mj study rate_bound --report

Per run: the yaw-rate standard deviation over 1–10 s (before the fault: the limit cycle), the command's
total variation per second, the time a wheel command moved at the rate limit, the largest command step
between two samples and the largest |cross-track error| after 15 s. The seed-0 table, then the means over
the seeds with Student-t 95 % intervals (``mean ± half-width``), old / new in each cell.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import polars as pl

from ... import markdown as md
from ...study.stats import mean_ci
from .results import read_results

CONFIGS = list(itertools.product((False, True), (0.0, 1.0), (False, True)))
"""(yaw-rate gyro, rate penalty, feedback) of each row."""
COLUMNS = {"yaw_rate_std_1_10": "yaw-rate std 1–10 s (rad/s)", "command_total_variation_per_s": "command TV (rad/s²)",
           "command_at_rate_limit_s": "at rate limit (s)", "command_step_max": "largest step (rad/s)",
           "cross_track_max_abs_after_15": "max \\|cte\\| after 15 s (m)"}
"""Results column → table heading."""


def label(cfg: tuple[bool, float, bool]) -> list[str]:
    """The sensors, cost and feedback cells of a row."""
    yaw, rp, fb = cfg
    return ["speed+yaw" if yaw else "speed", "rate penalty 1" if rp else "paper", "on" if fb else "off"]


def header(title: str) -> str:
    """A table's title and heading (blank line before)."""
    cols = (f"{c}: old / new" for c in COLUMNS.values())
    return f"\n{title}\n\n" + "\n".join(md.table(["sensors", "NMPC cost", "feedback", *cols]))


def values(df: pl.DataFrame, cfg: tuple[bool, float, bool], formulation: str, column: str) -> np.ndarray:
    """A column over the seeds (by seed) of one row and formulation."""
    yaw, rp, fb = cfg
    d = df.filter((pl.col("sensors") == ("speed+yaw" if yaw else "speed")) & (pl.col("cost") == rp)
                  & (pl.col("feedback") == fb) & (pl.col("formulation") == formulation)).sort("seed")
    return np.array([float(v) for v in d[column].to_list()])


def report(out: Path) -> str:
    """Both tables from the study's output folder."""
    df = read_results(out)
    seeds = sorted(set(df["seed"].to_list()))
    lines = [header("Seed 0:")]
    first = df.filter(pl.col("seed") == 0)
    for cfg in CONFIGS:
        cells = [f"{values(first, cfg, 'old', c)[0]:.3g} / {values(first, cfg, 'new', c)[0]:.3g}" for c in COLUMNS]
        lines.append(md.row([*label(cfg), *cells]))
    lines.append(header(f"Means over seeds 0–{len(seeds) - 1} (± Student-t 95 % half-width):"))
    for cfg in CONFIGS:
        cells = []
        for c in COLUMNS:
            e = [mean_ci(values(df, cfg, f, c)) for f in ("old", "new")]
            cells.append(" / ".join(f"{x.mean:.3g} ± {x.half:.2g}" for x in e))
        lines.append(md.row([*label(cfg), *cells]))
    return "\n".join(lines) + "\n"
