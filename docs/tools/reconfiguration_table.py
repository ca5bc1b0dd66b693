"""The reconfiguration-policy table of docs/findings.md from the built-in study ``reconfiguration``.

    .venv/bin/ftc-mj study reconfiguration --workers 2
    .venv/bin/python docs/tools/reconfiguration_table.py [runs/out/studies/reconfiguration]

Scenarios 2–4 × speed / speed + yaw rate × policy none / direct / safe / truth, 10 seeds. Cells: the
mean over the seeds with the worst seed in brackets where the seeds differ; tip-overs as a count;
"lift-off" is wheel lift-off outside the 1 s puncture transients; the hand-over is the safe policy's
first hand-over after the onset ("never" when it never handed radii over).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import polars as pl

POLICIES = ("none", "direct", "safe", "truth")


def values(df: pl.DataFrame, col: str) -> np.ndarray:
    return np.array([np.nan if v is None else float(v) for v in df[col].to_list()], dtype=float)


def mean_worst(a: np.ndarray, digits: str = ".3g") -> str:
    a = a[np.isfinite(a)]
    if a.size == 0:
        return "—"
    m, w = float(np.mean(a)), float(np.max(a))
    return f"{m:{digits}}" if np.isclose(m, w, rtol=1e-9, atol=1e-9) else f"{m:{digits}} ({w:{digits}})"


def row(d: pl.DataFrame, sc: str, sens: str, pol: str) -> str:
    final = np.abs(values(d, "cross_track_final"))
    tipped = int(np.sum(np.array(d["tipped"].to_list(), dtype=bool)))
    hand = values(d, "reconfig_handover_delay")
    hand_txt = ("never" if not np.isfinite(hand).any() else mean_worst(hand, ".2f")) if pol == "safe" else "—"
    at_limit = float(np.mean(values(d, "omega_at_limit_s")))
    return (f"| {sc[1]} | {sens.replace('+', ' + ')} | {pol} | {mean_worst(values(d, 'cross_track_max_recovered'))} | "
            f"{float(np.mean(final)):.3g} | {at_limit:.1f} | {tipped}/{d.height} | "
            f"{mean_worst(values(d, 'liftoff_time_post_transient_s'), '.2f')} | {hand_txt} |")


def main(argv: list[str]) -> None:
    out = Path(argv[1] if len(argv) > 1 else "runs/out/studies/reconfiguration")
    df = pl.read_parquet(out / "results.parquet")
    print(f"{df.height} runs ({df.filter(pl.col('status') != 'ok').height} not ok), seeds "
          f"{sorted(set(df['seed'].to_list()))}\n")
    print("| scenario | sensing | policy | max \\|cte\\| from onset + 5 s (m) | final \\|cte\\| (m) "
          "| wheel at limit (s) | tipped | lift-off (s) | hand-over after onset (s) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for sc in ("s2", "s3", "s4"):
        for sens in ("speed", "speed+yaw"):
            for pol in POLICIES:
                d = df.filter((pl.col("fault") == sc) & (pl.col("sensors") == sens) & (pl.col("policy") == pol))
                if d.height:
                    print(row(d, sc, sens, pol))


if __name__ == "__main__":
    main(sys.argv)
