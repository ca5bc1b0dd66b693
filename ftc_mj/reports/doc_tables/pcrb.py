"""The tables of docs/fdi.md built on the posterior Cramér–Rao bound, from the built-in study ``pcrb``.

    ftc-mj study pcrb
    ftc-mj study pcrb --report

First table: per plant and sensing, the σ of the bound along the radius split at several times after
the puncture and the first time it is at most 0.15 m (the sigma rule's ``max_split_sigma``: isolation),
for the filters' own model (radii a random walk) and for radii known to stay constant after the
puncture (:func:`ftc_mj.study.extras.pcrb_split`).

Second table, the nominal circle (10 m/s, 50 m) without a fault, computed here (no run): the
steady-state radius σ of the filters' model (their Riccati recursion: the PCRB of that model), the error
σ the same gains give when the radii are in truth constant (the Lyapunov recursion of the estimation
error with no radius noise), and their ratio.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl

from ...config import RunConfig
from ...estimation.calibration import nominal_point
from ...sim.record import build_record
from ...study.extras import ISOLATED_SPLIT_M, PCRB_MODELS, PCRB_TIMES, time_tag
from .results import read_results

BOUND_NAMES = {"model": "filters' model", "constant": "radii constant"}
"""Row label of each bound."""
LYAPUNOV_STEPS = 20000
"""Iterations of the covariance recursions (steady state)."""


def split_table(df: pl.DataFrame) -> list[str]:
    """The first table: one row per plant × sensing × bound."""
    lines = ["| plant | sensors | bound | ω_L/ω_R at 9.9 → 12 s | "
             + " | ".join(f"split σ at {t:g} s (m)" for t in PCRB_TIMES)
             + f" | first t with split σ ≤ {ISOLATED_SPLIT_M:g} m |",
             "|---|---|---|---|" + "---|" * len(PCRB_TIMES) + "---|"]
    for plant in ("kinematic", "mujoco"):
        for sensors in ("speed", "speed+yaw"):
            for m in df.filter((pl.col("plant") == plant) & (pl.col("sensors") == sensors)).iter_rows(named=True):
                for tag, _ in PCRB_MODELS:
                    at = [m[f"pcrb_split_{tag}_{time_tag(x)}"] for x in PCRB_TIMES]
                    first = m[f"pcrb_split_{tag}_isolated_s"]
                    lines.append(f"| {plant} | {sensors} | {BOUND_NAMES[tag]} | {m['omega_ratio_9_9']:.2f} → "
                                 f"{m['omega_ratio_12']:.2f} | " + " | ".join(f"{v:.3f}" for v in at)
                                 + f" | {'never' if first is None else f'{first:.2f} s'} |")
    return lines


def _steady_sigmas(gyro: float | None) -> tuple[dict[str, dict[str, float]], list[str]]:
    """Per recursion (``own``, ``constant``) the steady-state σ (m) along each direction, and the directions
    (with speed only the split is a random walk nothing observes: only ``w`` is shown)."""
    cfg = RunConfig.model_validate({"sensors": {"yaw_rate_sigma": gyro}})
    record = build_record(cfg)  # the record of a run of the nominal circle (no run needed: only its setup)
    setup = record.setup
    p = nominal_point(setup, *record.reference_rates)  # the filters' own gains (not the residual generator's)
    m = p.m
    H, K = np.array(p.H).reshape(m, 5), np.array(p.K).reshape(5, m)
    F = np.array(p.F).reshape(5, 5)
    R = np.diag([setup.speed_sigma ** 2, *([setup.yaw_rate_sigma ** 2] if gyro is not None else [])])
    q_sd = np.sqrt(np.diag(setup.Q))
    A = np.eye(5) - K @ H
    w = H[0, 3:5] / np.linalg.norm(H[0, 3:5])  # the speed row: ∝ [ω_R, ω_L]
    dirs = {"R_R": np.array([1.0, 0.0]), "R_L": np.array([0.0, 1.0]), "observed w": w,
            "split d": np.array([w[1], -w[0]])}
    if gyro is None:
        dirs = {"observed w": w}
    sig = {}
    for name, q in (("own", np.square(q_sd)), ("constant", np.square([*q_sd[:3], 0.0, 0.0]))):
        S = np.zeros((5, 5))
        for _ in range(LYAPUNOV_STEPS):
            S = A @ (F @ S @ F.T + np.diag(q)) @ A.T + K @ R @ K.T
        sig[name] = {d: float(np.sqrt(v @ S[3:5, 3:5] @ v)) for d, v in dirs.items()}
    return sig, list(dirs)


def constant_truth_table() -> list[str]:
    """The second table: the filters' steady-state σ (the bound of their model) against the σ their gains
    give with constant radii, per wheel, along the observed combination ``w ∝ [ω_R, ω_L]`` and the split
    ``d ⊥ w``."""
    lines = ["| sensors | direction | filters' model σ = PCRB (m) | σ with constant radii (m) | ratio |",
             "|---|---|---|---|---|"]
    for gyro in (0.01, None):
        sig, dirs = _steady_sigmas(gyro)
        for d in dirs:
            lines.append(f"| {'speed+yaw' if gyro else 'speed'} | {d} | {sig['own'][d]:.4f} | "
                         f"{sig['constant'][d]:.4f} | {sig['constant'][d] / sig['own'][d]:.3f} |")
    return lines


def report(out: Path) -> str:
    """Both tables (the first from the study's output folder)."""
    return "\n".join([*split_table(read_results(out)), "", *constant_truth_table()]) + "\n"
