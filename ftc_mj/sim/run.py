"""One run from a resolved config to its output directory.

``DIR/<run-id>/`` receives ``config.toml`` (fully resolved), ``trace.parquet``, ``metrics.json`` and
``run.rrd``. The directory is assembled under a temporary name and renamed into place at the end,
so a killed run leaves no half-written output under its final name; an existing run directory is
never overwritten (a suffix is added).
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..config import RunConfig, config_to_toml_dict
from ..io import atomic_dir, unique_dir, write_json, write_parquet, write_toml
from .loop import SimResult, simulate
from .metrics import compute_metrics, fault_onsets


def config_hash(cfg: RunConfig) -> str:
    """Short stable hash of the resolved config (output settings excluded)."""
    d = config_to_toml_dict(cfg)
    d.pop("output", None)
    return hashlib.sha256(json.dumps(d, sort_keys=True, default=str).encode()).hexdigest()[:8]


def run_id_for(cfg: RunConfig) -> str:
    """``<name>_<estimator>[-M]_<controller>_<policy>_s<seed>_<hash>`` (policy: reconfiguration policy)."""
    est = cfg.estimator.kind
    if est.startswith("imm"):
        est += f"{cfg.estimator.imm_models}"
        if cfg.estimator.imm_variant == "paper":
            est += "p"
    return f"{cfg.name}_{est}_{cfg.controller.kind}_{cfg.reconfiguration.policy}_s{cfg.seed}_{config_hash(cfg)}"


@dataclass
class RunOutcome:
    run_id: str
    metrics: dict[str, Any]
    result: SimResult
    run_dir: Path | None


def run_metrics(cfg: RunConfig, res: SimResult) -> dict[str, Any]:
    """Metrics of a finished simulation plus its identity (scenario, filter, controller, …)."""
    m: dict[str, Any] = {
        "run_id": run_id_for(cfg),
        "scenario": cfg.name,
        "estimator": cfg.estimator.kind,
        "imm_models": cfg.estimator.imm_models if cfg.estimator.kind.startswith("imm") else None,
        "imm_variant": cfg.estimator.imm_variant if cfg.estimator.kind.startswith("imm") else None,
        "controller": cfg.controller.kind,
        "feedback": cfg.feedback,
        "policy": cfg.reconfiguration.policy,
        "sensing": "+".join(["speed"] + (["yaw"] if cfg.sensors.yaw_rate_sigma is not None else [])
                            + (["position"] if cfg.sensors.position_sigma is not None else [])),
        "rate_penalty": cfg.controller.rate_penalty,
        "seed": cfg.seed,
        "status": "failed" if res.error else "ok",
        "error": res.error,
        "error_where": res.error_where,
    }
    m.update(compute_metrics(cfg, res.trace, fault_onsets(cfg), res.counters))
    ds = res.decision
    if ds is not None:
        m["severity_R"] = getattr(ds, "severity_R", None)
        m["severity_L"] = getattr(ds, "severity_L", None)
    m["wall_time_s"] = res.wall_time
    m["realtime_factor"] = m["sim_time_s"] / res.wall_time if res.wall_time > 0 else float("nan")
    return m


def execute(
    cfg: RunConfig,
    out_root: Path | None = None,
    *,
    rrd: bool | None = None,
    progress: Callable[[float], None] | None = None,
    strict: bool | None = None,
) -> RunOutcome:
    """Simulate ``cfg``; if ``out_root`` is given, write ``out_root/<run-id>/`` atomically.

    ``rrd`` overrides ``cfg.output.rrd``; ``strict`` is :func:`~ftc_mj.sim.loop.simulate`'s. A failed
    run (a component raised; status ``failed``, ``error`` and ``error_where`` say what and where)
    still writes its metrics and its trace up to the failure.
    """
    res = simulate(cfg, progress, strict=strict)
    metrics = run_metrics(cfg, res)
    run_id = metrics["run_id"]
    if out_root is None:
        return RunOutcome(run_id, metrics, res, None)
    want_rrd = cfg.output.rrd if rrd is None else rrd
    final = unique_dir(Path(out_root), run_id)
    with atomic_dir(final) as tmp:
        write_toml(tmp / "config.toml", config_to_toml_dict(cfg))
        write_parquet(tmp / "trace.parquet", res.trace)
        if want_rrd:
            from ..recorder import write_rrd

            t0 = time.perf_counter()
            # the suspended chassis stays level at constant height, so the robot is drawn on the ground with
            # each wheel touching it (no ``z`` column: see RobotGeometry)
            drawn = {k: v for k, v in res.trace.items() if k != "z"}
            write_rrd(tmp / "run.rrd", drawn, run_id=final.name, solves=res.solves, events=res.events,
                      reference_path=res.reference_path, omega_max=cfg.robot.omega_max, n_modes=res.n_modes,
                      geometry=res.geometry)
            metrics["rrd_write_s"] = time.perf_counter() - t0
        metrics["total_wall_time_s"] = res.wall_time + metrics.get("rrd_write_s", 0.0)
        write_json(tmp / "metrics.json", metrics)
    return RunOutcome(run_id, metrics, res, final)
