"""The reconfiguration-policy table of docs/findings.md from the built-in study ``reconfiguration``.

    ftc-mj study reconfiguration --workers 2          # the runs
    ftc-mj study reconfiguration --report             # the table, from runs/out/studies/reconfiguration

Scenarios 2–4 × speed / speed + yaw rate × policy none / direct / safe / truth, 10 seeds. Cells: the
mean over the seeds with the worst seed in brackets where the seeds differ; tip-overs as a count;
"lift-off" is wheel lift-off outside the 1 s puncture transients; the hand-over is the safe policy's
first hand-over after the onset ("never" when it never handed radii over).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl

from ... import markdown as md
from .results import float_column, read_results

POLICIES = ("none", "direct", "safe", "truth")


def mean_worst(a: np.ndarray, digits: str = ".3g") -> str:
    """Mean over the seeds with the worst seed in brackets where the seeds differ."""
    a = a[np.isfinite(a)]
    if a.size == 0:
        return "—"
    m, w = float(np.mean(a)), float(np.max(a))
    return f"{m:{digits}}" if np.isclose(m, w, rtol=1e-9, atol=1e-9) else f"{m:{digits}} ({w:{digits}})"


def row(d: pl.DataFrame, sc: str, sens: str, pol: str) -> str:
    """The table row of one scenario × sensing × policy cell."""
    final = np.abs(float_column(d, "cross_track_final"))
    tipped = int(np.sum(np.array(d["tipped"].to_list(), dtype=bool)))
    hand = float_column(d, "reconfig_handover_delay")
    hand_txt = ("never" if not np.isfinite(hand).any() else mean_worst(hand, ".2f")) if pol == "safe" else "—"
    at_limit = float(np.mean(float_column(d, "omega_at_limit_s")))
    rec = mean_worst(float_column(d, "cross_track_max_recovered"))
    return md.row([sc[1], sens.replace("+", " + "), pol, rec, f"{float(np.mean(final)):.3g}", f"{at_limit:.1f}",
                   f"{tipped}/{d.height}", mean_worst(float_column(d, "liftoff_time_post_transient_s"), ".2f"),
                   hand_txt])


def report(out: Path) -> str:
    """The published table (and its header line) from the study's output folder ``out``."""
    df = read_results(out)
    lines = [f"{df.height} runs ({df.filter(pl.col('status') != 'ok').height} not ok), seeds "
             f"{sorted(set(df['seed'].to_list()))}\n",
             *md.table(["scenario", "sensing", "policy", "max \\|cte\\| from onset + 5 s (m)", "final \\|cte\\| (m)",
                        "wheel at limit (s)", "tipped", "lift-off (s)", "hand-over after onset (s)"])]
    for sc in ("s2", "s3", "s4"):
        for sens in ("speed", "speed+yaw"):
            for pol in POLICIES:
                d = df.filter((pl.col("fault") == sc) & (pl.col("sensors") == sens) & (pl.col("policy") == pol))
                if d.height:
                    lines.append(row(d, sc, sens, pol))
    return "\n".join(lines) + "\n"
