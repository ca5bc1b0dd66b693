"""Fake run directories for the figure and report tests: a kinematic robot with made-up filter
outputs, written like real runs (config.toml, trace.parquet, metrics.json)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ftc_mj.config import config_to_toml_dict, load_config
from ftc_mj.io import write_json, write_parquet, write_toml
from ftc_mj.paper.matrix import full_matrix


def fake_run(root: Path, label: str, duration: float = 12.0, seed: int = 0) -> Path:
    """A run directory with a plausible trace for matrix entry ``label``."""
    entry = next(e for e in full_matrix() if e.label == label)
    ov = dict(entry.overrides, duration=duration)
    cfg = load_config(entry.scenario, ov)
    cd = config_to_toml_dict(cfg)
    rng = np.random.default_rng(seed)
    dt = 0.01
    t = np.arange(0.0, duration, dt)
    n = t.size

    def sched(bps: list[Any]) -> np.ndarray:
        if not bps:
            return np.full(n, 2.0)
        ts = [0.0] + [b[0] for b in bps]
        rs = [2.0] + [b[1] for b in bps]
        out = np.interp(t, ts, rs)
        for i in range(1, len(ts)):
            if i + 1 < len(ts) and ts[i] == ts[i + 1]:
                out[t >= ts[i]] = rs[i + 1]
        return out

    RR, RL = sched(cd["faults"].get("right", [])), sched(cd["faults"].get("left", []))
    wR = np.full(n, 5.0) * 2.0 / RR * 1.01
    wL = np.full(n, 5.0) * 2.0 / RL * 0.99
    V = (RR * wR + RL * wL) / 2
    psid = (RR * wR - RL * wL) / 2
    psi = np.cumsum(psid) * dt
    x, y = np.cumsum(V * np.cos(psi)) * dt, np.cumsum(V * np.sin(psi)) * dt
    cte = 50.0 - np.hypot(x, y - 50.0)
    lag = np.exp(-np.maximum(t - 10.0, 0) / 0.5)
    tr: dict[str, np.ndarray] = {
        "t": t, "x": x, "y": y, "psi": psi, "v": V, "v_meas": V + rng.normal(0, 0.5, n), "R_R": RR, "R_L": RL,
        "R_R_hat": RR + 0.02 * rng.normal(size=n), "R_L_hat": RL + 0.3 * lag * (t >= 10) + 0.02 * rng.normal(size=n),
        "R_R_std": np.full(n, 0.05), "R_L_std": np.full(n, 0.05), "innovation": rng.normal(0, 0.5, n),
        "innovation_std": np.full(n, 0.52), "omega_R": wR, "omega_L": wL,
        "omega_R_cmd": np.repeat(wR[::10], 10)[:n], "omega_L_cmd": np.repeat(wL[::10], 10)[:n],
        "cross_track_error": cte, "R_R_model": np.full(n, 2.0), "R_L_model": np.full(n, 2.0),
        "fault_detected": (t > 10.3).astype(float), "nis": np.ones(n),
    }
    if entry.estimator.startswith("imm"):
        M = entry.imm_models or 4
        p = np.full((n, M), 0.02)
        p[:, 0] = 0.94
        if label.startswith(("s2", "s4")):
            k = 2 if label.startswith("s2") else M - 1
            p[t >= 10.2] = 0.02
            p[t >= 10.2, k] = 0.94
        for j in range(M):
            tr[f"mode_prob_{j + 1}"] = p[:, j]
    run_dir = root / f"{label}_fake"
    run_dir.mkdir(parents=True)
    write_toml(run_dir / "config.toml", cd)
    write_parquet(run_dir / "trace.parquet", tr)
    metrics = {"status": "ok", "run_id": run_dir.name, "radius_rmse_R": 0.02, "radius_rmse_L": 0.1,
               "innovation_in_2sigma": 0.95, "solve_time_ms": {"median": 4.0, "p95": 6.0, "max": 9.0},
               "detection_delay": 0.3 if label[:2] != "s1" else None, "wall_time_s": 1.0}
    write_json(run_dir / "metrics.json", metrics)
    return run_dir
