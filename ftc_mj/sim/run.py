"""One run from a resolved config to its output directory.

``DIR/<run-id>/`` receives ``config.toml`` (fully resolved), ``trace.parquet``, ``metrics.json`` (with
``metrics.schema.json``: each key's unit and meaning, :mod:`ftc_mj.metrics.schema`),
``events.json`` (the run's events: ``t`` in s, ``level``, ``text``), ``record.json`` (the run's resolved
record: filter setup, run context, reference rates, fault onsets, :mod:`ftc_mj.sim.record`) and
``run.rrd``. The directory is assembled under a temporary name and renamed into place at the end, so a
killed run leaves no half-written output under its final name; an existing run directory is never overwritten (a
suffix is added). Before simulating, :func:`~ftc_mj.sim.output.check_output_root` makes sure the folder can take the
run (a usage error otherwise); a write that still fails raises
:class:`~ftc_mj.errors.OutputError` and leaves nothing behind.

A run's ``status`` says whether the *simulation* completed; its ``outcome``
(:mod:`ftc_mj.metrics.outcome`) says what the robot did: on the path, off the path or tipped over.
A run's ``status`` is ``ok``, ``failed`` (an exception ended it; ``error`` says which) or
``unstable``: the physics blew up (plant flag ``UNSTABLE`` or ``NAN``, or a non-finite true pose) —
its metrics describe a frozen or reset robot and must not be read as results.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..config import RunConfig, config_to_toml_dict
from ..errors import OutputError
from ..estimation.imm import IMMSettings
from ..identity import run_id
from ..io import atomic_dir, remove_stale_temporaries, unique_dir, write_json, write_parquet, write_toml
from ..metrics.diagnosis import diagnosis_metrics
from ..metrics.fdi import fdi_sweep_metrics
from ..metrics.outcome import physical_outcome
from ..metrics.record import RunRecord
from ..metrics.run import compute_metrics
from ..metrics.schema import schema as metrics_schema
from ..plant import NAN, UNSTABLE
from ..plant.faults import fault_class, fault_list
from ..telemetry.columns import INTEGER_COLUMNS, trace_schema_metadata
from .loop import SimResult, simulate
from .output import check_output_root, output_bytes
from .record import build_record, write_record


def run_id_for(cfg: RunConfig) -> str:
    """The run's folder name (:func:`ftc_mj.identity.run_id`)."""
    return run_id(cfg)


@dataclass
class RunOutcome:
    run_id: str
    metrics: dict[str, Any]
    result: SimResult
    run_dir: Path | None


def record_of(cfg: RunConfig, res: SimResult) -> RunRecord:
    """The run's record: the one the loop built (a result made elsewhere without one: built from ``cfg``)."""
    record = getattr(res, "record", None)
    return record if record is not None else build_record(cfg)


def run_metrics(cfg: RunConfig, res: SimResult) -> dict[str, Any]:
    """Metrics of a finished simulation plus its identity (scenario, filter, controller, …)."""
    m: dict[str, Any] = {
        "run_id": run_id_for(cfg),
        "scenario": cfg.name,
        "estimator": cfg.estimator.kind,
        "imm_models": res.n_modes or None,
        "imm_variant": cfg.estimator.imm_variant if isinstance(cfg.estimator, IMMSettings) else None,
        "controller": cfg.controller.kind,
        "feedback": cfg.feedback,
        "policy": cfg.reconfiguration.policy,
        "sensing": "+".join(["speed"] + (["yaw"] if cfg.sensors.yaw_rate_sigma is not None else [])
                            + (["position"] if cfg.sensors.position_sigma is not None else [])),
        "rate_penalty": getattr(cfg.controller, "rate_penalty", None),  # None: the open loop has none
        "seed": cfg.seed,
        "status": "failed" if res.error else "ok",
        "error": res.error,
        "error_where": res.error_where,
    }
    record = record_of(cfg, res)
    faults = fault_list(cfg.faults, cfg.plant_wheel_radius)
    others = [f.onset for f in faults if not fault_class(f.fault_class).radius_fault]  # the tyres' are the record's
    m.update(compute_metrics(record, res.trace, res.counters, other_onsets=others))
    m.update(fdi_sweep_metrics(record, res.trace))
    m.update(diagnosis_metrics(res.trace, faults, cfg.sensors,
                               cfg.model_wheel_radius, res.events))
    # the radii the controller used departed from nominal at some sample (not just: a feeding policy)
    m["feedback"] = bool((m.get("reconfig_handed_fraction") or 0.0) > 0.0)
    t_bad = unstable_time(res.trace)
    m["physics_unstable_time"] = t_bad
    if t_bad is not None and not res.error:
        m["status"] = "unstable"
        m["error"] = (f"the physics became unstable at t = {t_bad:.3f} s (NaN, Inf or huge values in the "
                      "MuJoCo state); the plant froze there, so these metrics are not results")
    ds = res.decision
    if ds is not None:
        # the decision's severity at the last step: 1 - R_hat/R0 of the filter's radius estimate then
        m["radius_loss_estimate_final_R"] = getattr(ds, "severity_R", None)
        m["radius_loss_estimate_final_L"] = getattr(ds, "severity_L", None)
    m.update(physical_outcome(m))
    m["wall_time_s"] = res.wall_time
    m["realtime_factor"] = m["sim_time_s"] / res.wall_time if res.wall_time > 0 else float("nan")
    return m


def unstable_time(trace: dict[str, np.ndarray]) -> float | None:
    """First time (s) at which the plant flagged ``UNSTABLE``/``NAN`` or the true pose or speed is not
    finite; None if the physics stayed sound."""
    t = np.asarray(trace.get("t", []), dtype=float)
    if t.size == 0:
        return None
    flags = np.nan_to_num(np.asarray(trace["plant_flags"], dtype=float)).astype(np.int64)
    bad = (flags & (UNSTABLE | NAN)) != 0
    for c in ("x", "y", "psi", "v"):
        bad |= ~np.isfinite(np.asarray(trace[c], dtype=float))
    idx = np.flatnonzero(bad)
    return float(t[idx[0]]) if idx.size else None


def execute(
    cfg: RunConfig,
    out_root: Path | None = None,
    *,
    rrd: bool | None = None,
    progress: Callable[[float], None] | None = None,
    strict: bool | None = None,
) -> RunOutcome:
    """Simulate ``cfg``; if ``out_root`` is given, write ``out_root/<run-id>/`` atomically (:func:`write_outcome`).

    ``rrd`` overrides ``cfg.output.rrd``; ``strict`` is :func:`~ftc_mj.sim.loop.simulate`'s. A failed
    run (a component raised; status ``failed``, ``error`` and ``error_where`` say what and where)
    still writes its metrics and its trace up to the failure. ``out_root`` is checked before
    simulating (:func:`check_output_root`, :class:`BadInput`); if writing fails anyway,
    :class:`OutputError` and nothing is left (temporaries that killed runs left in ``out_root`` are
    removed first).
    """
    want_rrd = cfg.output.rrd if rrd is None else rrd
    if out_root is not None:
        check_output_root(out_root, run_id_for(cfg), output_bytes(cfg, want_rrd))
    res = simulate(cfg, progress, strict=strict)
    metrics = run_metrics(cfg, res)
    outcome = RunOutcome(metrics["run_id"], metrics, res, None)
    if out_root is None:
        return outcome
    return write_outcome(outcome, cfg, Path(out_root), want_rrd)


def write_outcome(outcome: RunOutcome, cfg: RunConfig, out_root: Path, rrd: bool) -> RunOutcome:
    """Write a simulated run to ``out_root/<run-id>/`` (a suffix if taken) atomically, with its Rerun
    recording if ``rrd``; the outcome with its ``run_dir``. The metrics gain the write times (s).
    :class:`OutputError` if writing fails (nothing is left; stale temporaries of killed runs in
    ``out_root`` are removed first)."""
    remove_stale_temporaries(out_root)
    final = unique_dir(out_root, outcome.run_id)
    try:
        _write_run(final, cfg, outcome.result, outcome.metrics, rrd)
    except OSError as err:
        raise OutputError(f"cannot write the run to {final.parent}: {err.strerror or err} (the simulation "
                          f"finished with status {outcome.metrics['status']}; nothing was kept)") from None
    return dataclasses.replace(outcome, run_dir=final)


def _write_run(final: Path, cfg: RunConfig, res: SimResult, metrics: dict[str, Any], want_rrd: bool) -> None:
    """Assemble the run directory under a temporary name and rename it to ``final``."""
    with atomic_dir(final) as tmp:
        write_toml(tmp / "config.toml", config_to_toml_dict(cfg))
        write_parquet(tmp / "trace.parquet", res.trace, metadata=trace_schema_metadata(), integers=INTEGER_COLUMNS)
        if want_rrd:
            from ..rerun.record import write_rrd

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
        write_json(tmp / "metrics.schema.json", metrics_schema())
        write_json(tmp / "events.json", [{"t": e.t, "level": e.level, "text": e.text} for e in res.events])
        write_record(tmp, record_of(cfg, res))
