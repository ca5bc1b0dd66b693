"""The figure of docs/findings.md, "A path-following NMPC that degrades gracefully" (docs/figures/pathfollow.png),
from the built-in study ``pathfollow_figure`` (``ftc_mj/data/studies/pathfollow_figure.toml``: scenarios 3 and 4
× nmpc / pf-nmpc, UKF, safe policy, speed + yaw rate, seed 1000, every trace row kept).

    ftc-mj study pathfollow_figure --workers 2
    ftc-mj study pathfollow_figure --report     # writes OUT/figures/pathfollow.png

Three panels, time-parametrised NMPC (orange) against path-following NMPC (blue): scenario 4 speed (m/s) with
the feasible speed of the true radii (dashed, :func:`~ftc_mj.model.kinematics.max_path_speed` capped at the
reference speed), scenario 4 cross-track error (m), scenario 3 lateral acceleration ``v · yaw rate`` (m/s²) with
the samples where the plant flags a wheel off the ground (:data:`~ftc_mj.plant.LIFTOFF`). The report also prints
one line per run of the numbers docs/findings.md quotes from the figure.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from ...config import load_config
from ...errors import BadInput
from ...paper.render import md_table
from ...study.plotting import pyplot, save_figure
from ...study.series import stack_series
from .results import read_results

COLORS = {"nmpc": "tab:orange", "pf-nmpc": "tab:blue"}
CONTROLLERS = ("nmpc", "pf-nmpc")
SCENARIOS = ("scenario3", "scenario4")
SERIES = ("t", "v", "yaw_rate", "plant_flags", "cross_track_error", "R_R", "R_L")
"""Trace columns the figure draws on (kept as ``ts_<column>`` by the study)."""
FIGURE = Path("figures") / "pathfollow.png"
"""Where the figure is written, relative to the study's output folder."""

Trace = dict[str, np.ndarray]


def run_traces(df: pl.DataFrame) -> tuple[int, dict[tuple[str, str], Trace], dict[tuple[str, str], str]]:
    """The seed drawn (the smallest in the results), and per ``(scenario, controller)`` the run's kept trace
    (arrays of :data:`SERIES`) and status. A missing run or column is a
    :class:`BadInput` naming it."""
    if df.height == 0 or not {"scenario", "controller", "seed"} <= set(df.columns):
        raise BadInput("--report: no pathfollow_figure runs in the output folder (run `ftc-mj study pathfollow_figure`"
                       " first)")
    seed = int(min(df["seed"].to_list()))
    missing = [f"ts_{c}" for c in SERIES if f"ts_{c}" not in df.columns]
    if missing:
        raise BadInput(f"--report: the results keep no {', '.join(missing)} (the study's [analysis] "
                       "timeseries_columns; run `ftc-mj study pathfollow_figure` into a fresh --out)")
    traces, status = {}, {}
    for sc in SCENARIOS:
        for ctl in CONTROLLERS:
            run = df.filter((pl.col("scenario") == sc) & (pl.col("controller") == ctl) & (pl.col("seed") == seed))
            if run.height == 0:
                raise BadInput(f"--report: no run of {sc}, {ctl}, seed {seed} in the results (run `ftc-mj study "
                               "pathfollow_figure` to the end)")
            traces[sc, ctl] = {c: stack_series(run.head(1), f"ts_{c}")[0] for c in SERIES}
            status[sc, ctl] = str(run["status"][0])
    return seed, traces, status


def lifted(flags: np.ndarray) -> np.ndarray:
    """True where the plant's flags (``plant_flags``, NaN = none) have the wheel lift-off bit
    (:data:`~ftc_mj.plant.LIFTOFF`)."""
    from ...plant import LIFTOFF

    return (np.nan_to_num(flags).astype(np.int64) & LIFTOFF) != 0


def figure_arrays(traces: dict[tuple[str, str], Trace], cfg: Any) -> dict[str, Trace]:
    """What each panel draws, per controller: scenario 4 ``t``, ``speed`` (m/s), ``cross_track`` (m) and, for
    pf-nmpc, ``feasible`` (m/s: the feasible speed on the reference circle for the true radii, capped at the
    reference speed; ``cfg`` gives the circle, the plant's half track and ω_max); scenario 3 ``t3``,
    ``lateral`` (``v · yaw rate``, m/s²) and ``lift`` (True where the plant flags a wheel off the ground)."""
    from ...model.kinematics import max_path_speed

    out: dict[str, Trace] = {}
    for ctl in CONTROLLERS:
        tr, tr3 = traces["scenario4", ctl], traces["scenario3", ctl]
        d = {"t": tr["t"], "speed": tr["v"], "cross_track": tr["cross_track_error"], "t3": tr3["t"],
             "lateral": tr3["v"] * tr3["yaw_rate"], "lift": lifted(tr3["plant_flags"])}
        if ctl == "pf-nmpc":
            d["feasible"] = np.minimum(max_path_speed(1.0 / cfg.reference.radius, tr["R_R"], tr["R_L"],
                                                      cfg.plant_half_track, cfg.robot.omega_max), cfg.reference.speed)
        out[ctl] = d
    return out


def draw(arrays: dict[str, Trace], seed: int, path: Path) -> None:
    """The three panels of :func:`figure_arrays` in one 9 × 9 in figure, written as a 110-dpi PNG at ``path``."""
    plt = pyplot()
    fig, ax = plt.subplots(3, 1, figsize=(9, 9), sharex=True)
    for ctl in CONTROLLERS:
        d = arrays[ctl]
        ax[0].plot(d["t"], d["speed"], color=COLORS[ctl], label=f"{ctl}: speed")
        ax[1].plot(d["t"], d["cross_track"], color=COLORS[ctl], label=ctl)
        if "feasible" in d:
            ax[0].plot(d["t"], d["feasible"], "k--", lw=1, label="feasible speed (true radii)")
        ax[2].plot(d["t3"], d["lateral"], color=COLORS[ctl], lw=1, label=f"{ctl}: lateral acceleration")
        ax[2].plot(d["t3"][d["lift"]], d["lateral"][d["lift"]], ".", color=COLORS[ctl], ms=3,
                   label=f"{ctl}: wheel off the ground")
    ax[0].set_ylabel("speed (m/s)")
    ax[0].set_title(f"scenario 4 (left tyre 2 → 0.1 m, 10–29 s), seed {seed}, UKF, safe, speed + yaw rate")
    ax[1].set_ylabel("cross-track error (m)")
    ax[2].set_ylabel("v · yaw rate (m/s²)")
    ax[2].set_title("scenario 3 (left then right tyre 2 → 1 m at 5 s and 10 s)")
    ax[2].set_xlabel("t (s)")
    for a_ in ax:
        a_.grid(alpha=0.3)
        a_.legend(fontsize=8, loc="best")
    fig.tight_layout()
    save_figure(fig, path)


def run_table(traces: dict[tuple[str, str], Trace], status: dict[tuple[str, str], str]) -> list[dict[str, Any]]:
    """Per run: the largest |cross-track error| (m) and when, the lowest speed (m/s), the time with a wheel
    off the ground (s: flagged rows × the row interval) and the largest |v · yaw rate| (m/s²)."""
    rows = []
    for (sc, ctl), tr in traces.items():
        e, t, lift = np.abs(tr["cross_track_error"]), tr["t"], lifted(tr["plant_flags"])
        dt = float(np.median(np.diff(t))) if t.size > 1 else float("nan")
        k = int(np.nanargmax(e)) if np.isfinite(e).any() else None
        rows.append({"scenario": sc, "controller": ctl, "status": status[sc, ctl], "rows": str(t.size),
                     "max |e_c| (m)": None if k is None else f"{e[k]:.2f} at {t[k]:.1f} s",
                     "lowest speed (m/s)": f"{np.nanmin(tr['v']):.2f}" if t.size else None,
                     "wheel off the ground (s)": f"{np.sum(lift) * dt:.2f}" if t.size > 1 else None,
                     "max |v · yaw rate| (m/s²)": f"{np.nanmax(np.abs(tr['v'] * tr['yaw_rate'])):.2f}"
                     if t.size else None})
    return rows


def _set_overrides(out: Path) -> dict[str, Any]:
    """The ``--set`` overrides the study was run with (``plan.json``; none without it)."""
    plan = Path(out) / "plan.json"
    return dict(json.loads(plan.read_text()).get("extra_overrides") or {}) if plan.is_file() else {}


def report(out: Path) -> str:
    """Draw the figure to ``OUT/figures/pathfollow.png`` from the study's output folder ``out``; a line naming
    it and the table of :func:`run_table`."""
    seed, traces, status = run_traces(read_results(out))
    cfg = load_config("scenario4", _set_overrides(out))
    path = Path(out) / FIGURE
    draw(figure_arrays(traces, cfg), seed, path)
    return f"figure: {path} (seed {seed})\n\n{md_table(run_table(traces, status))}"
