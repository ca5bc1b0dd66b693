"""The passive / active / hybrid FTC table of docs/findings.md from the two robust-FTC studies.

``ftc-mj study robust_ftc --report`` (or ``robust_ftc_fixed --report``) after ``ftc-mj study robust_ftc`` and
``ftc-mj study robust_ftc_fixed``: one table from both output folders (siblings, e.g.
``runs/out/studies/robust_ftc`` and ``runs/out/studies/robust_ftc_fixed``). Reads ``results.parquet`` or,
for a study still running, the rows persisted so far (``n`` says how many seeds each cell has).
Seed-dependent cells: mean over the seeds with a 95 % Student-t interval and the worst
seed; the strategies that never see a sensor (nominal, passive, passive-left, oracle) are one run
(checked identical over their seeds), shown once for both sensings.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl

from ... import markdown as md
from ...errors import BadInput
from ...study.stats import mean_ci
from .results import read_results

STUDIES = ("robust_ftc", "robust_ftc_fixed")
"""The two studies whose rows make the table (their output folders are siblings)."""
FIXED = ("nominal", "passive", "passive-left", "oracle")
ORDER = {s: i for i, s in enumerate(("nominal", "passive", "passive-left", "safe", "direct", "hybrid", "oracle"))}


def cell(v: np.ndarray, fixed: bool) -> str:
    """``mean [lo, hi] (worst)`` over seeds, or the single value of a seed-independent strategy."""
    v = v[np.isfinite(v)]
    if v.size == 0:
        return "—"
    if fixed or v.size == 1:
        return f"{v[0]:.2f}"
    e = mean_ci(v)
    return f"{e.mean:.2f} [{max(e.lo, 0):.2f}, {e.hi:.2f}] ({v.max():.2f})"


def table(df: pl.DataFrame) -> str:
    """The published table from the rows of both studies."""
    ok = df.filter(pl.col("status") == "ok")
    lines = md.table(["scenario", "plant", "sensing", "strategy", "n", "max \\|cte\\| from onset + 5 s (m)",
                      "final \\|cte\\| (m)", "RMS \\|cte\\| from 5 s (m)", "tipped", "solver fallbacks"])
    keys = ok.select("fault", "plant", "sensing", "strategy").unique().rows()
    keys = sorted(keys, key=lambda k: (k[0], k[1], k[2] if k[3] not in FIXED else "", ORDER.get(k[3], 99)))
    seen = set()
    for fault, plant, sensing, strategy in keys:
        fixed = strategy in FIXED
        if fixed and (fault, plant, strategy) in seen:
            continue
        seen.add((fault, plant, strategy))
        c = ok.filter((pl.col("fault") == fault) & (pl.col("plant") == plant) & (pl.col("strategy") == strategy))
        if not fixed:
            c = c.filter(pl.col("sensing") == sensing)
        rec = c["cross_track_max_recovered"].cast(pl.Float64).to_numpy()
        if fixed and np.ptp(c["cross_track_rms"].to_numpy()) > 0:
            raise BadInput(f"{fault}/{plant}/{strategy}: runs of a seed-independent strategy differ between seeds")
        fin = np.abs(c["cross_track_final"].to_numpy())
        rms = c["cross_track_rms_settled"].to_numpy()
        n_tip = int(c["tipped"].sum())
        n = 1 if fixed else c.height
        lines.append(md.row([fault[1:], plant, "any" if fixed else sensing, strategy, n, cell(rec, fixed),
                             cell(fin, fixed), cell(rms, fixed), f"{n_tip if not fixed else int(n_tip > 0)}/{n}",
                             int(c["solver_failures"].max())]))
    return "\n".join(lines)


def report(out: Path) -> str:
    """The published table from ``out`` and its sibling folders of :data:`STUDIES` that exist."""
    folders = [Path(out).parent / name for name in STUDIES if (Path(out).parent / name).is_dir()]
    frames = [read_results(f) for f in dict.fromkeys([Path(out), *folders])]
    df = pl.concat([f for f in frames if f.height], how="diagonal_relaxed")
    return table(df) + "\n"
