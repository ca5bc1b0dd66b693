"""The table of docs/findings.md, "the paper's loop on a physical plant", from the built-in study
``physical_plant`` (scenario 2, UKF, NMPC, 40 s, seed 0: plant × sensing × NMPC cost × feedback; the
kinematic plant only with the paper's cost).

    ftc-mj study physical_plant --workers 2
    ftc-mj study physical_plant --report

The radius means, the largest cross-track error after 15 s and the yaw-rate standard deviation before
the fault are the study's ``[[analysis.trace_stats]]`` (computed from each run's full trace).
"""

from __future__ import annotations

import itertools
from pathlib import Path

import polars as pl

from ... import markdown as md
from .results import read_results

HEAD = "\n".join(md.table(["plant", "sensors", "NMPC cost", "feedback", "R̂_L mean 15–40 s (m)", "R̂_R mean 15–40 s (m)",
                            "max \\|cross-track\\| after 15 s (m)", "yaw-rate std 1–10 s (rad/s)",
                            "detection delay (s)", "isolated", "command TV (rad/s²)", "rows out of domain"]))


def row(m: dict, plant: str, yaw: bool, rp: float, fb: bool) -> str:
    """The table row of one run (its results row ``m``)."""
    dd = m.get("detection_delay")
    return md.row([plant, "speed+yaw" if yaw else "speed", "rate penalty 1" if rp else "paper", "on" if fb else "off",
                   f"{m['R_L_hat_mean_15_40']:.2f}", f"{m['R_R_hat_mean_15_40']:.2f}",
                   f"{m['cross_track_max_abs_after_15']:.2f}", f"{m['yaw_rate_std_1_10']:.3f}",
                   "—" if dd is None else f"{dd:.2f}", m.get("isolated_wheel") or "—",
                   f"{m['command_total_variation_per_s']:.1f}", f"{m['plant_out_of_domain_fraction']:.0%}"])


def report(out: Path) -> str:
    """The published table from the study's output folder (the seed-0 run of each cell)."""
    df = read_results(out).filter(pl.col("seed") == 0)
    lines = [HEAD]
    for plant, yaw, rp, fb in itertools.product(("mujoco", "kinematic"), (False, True), (0.0, 1.0), (False, True)):
        if plant == "kinematic" and rp > 0:
            continue
        d = df.filter((pl.col("plant") == plant) & (pl.col("sensors") == ("speed+yaw" if yaw else "speed"))
                      & (pl.col("cost") == rp) & (pl.col("feedback") == fb))
        lines += [row(m, plant, yaw, rp, fb) for m in d.iter_rows(named=True)]
    return "\n".join(lines) + "\n"
