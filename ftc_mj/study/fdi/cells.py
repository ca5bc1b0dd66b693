"""The runs of a finished FDI study grouped into cells: runs sharing every axis value but the fault
axis (e.g. plant × sensors × filter), each with its no-fault runs, its fault runs per severity and
its resolved configuration (rebuilt from the study file copy in the output folder)."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from ...config import RunConfig, validate_config
from ...errors import BadInput
from ...metrics.schema import upgrade_names
from ..plan import plan_study

RULES: tuple[str, ...] = ("sigma", "mode", "cusum", "glr")
"""The decision rules whose statistics every run records (``fdi_records_<rule>``)."""


@dataclass
class Run:
    """What the sweep needs of one run (one results row)."""

    key: str
    seed: int
    severity: Any
    onset: float | None
    wheel: str | None
    duration: float
    records: dict[str, np.ndarray]
    """Per rule, (k, columns) record rows ``[t, g, …]``."""
    kl: np.ndarray | None = None
    """Cumulative information of the fault from the onset row (nats per row)."""


@dataclass
class Cell:
    """Runs sharing every axis value but the fault axis."""

    key: dict[str, Any]
    nofault: list[Run] = field(default_factory=list)
    faults: dict[Any, list[Run]] = field(default_factory=dict)
    config: RunConfig | None = None

    @property
    def label(self) -> str:
        return ", ".join(f"{v}" for v in self.key.values())


# ---------------------------------------------------------------------------- loading
def _json(v: Any) -> Any:
    return json.loads(v) if isinstance(v, str) else v


def load_cells(study_dir: Path, fault_axis: str) -> tuple[list[Cell], list[str]]:
    """The study's ok runs grouped into cells (see the module docstring) and the axis columns of the cells."""
    res = Path(study_dir) / "results.parquet"
    if not res.is_file():
        raise BadInput(f"STUDY_DIR: {study_dir} has no results.parquet (run `ftc-mj study` first)")
    df = upgrade_names(pl.read_parquet(res))
    plan = json.loads((Path(study_dir) / "plan.json").read_text())
    axes = list(plan.get("axis_columns", []))
    if fault_axis not in axes:
        raise BadInput(f"--fault-axis: the study has no axis {fault_axis!r} (axes: {', '.join(axes) or 'none'})")
    if not any(c.startswith("fdi_records_") for c in df.columns):
        raise BadInput(f"STUDY_DIR: {study_dir} has no fdi_records_* columns (runs without FDI statistics)")
    df = df.filter(pl.col("status") == "ok")
    keys = [a for a in axes if a != fault_axis]
    configs = _configs(Path(study_dir), plan)
    cells: dict[tuple, Cell] = {}
    for row in df.iter_rows(named=True):
        ck = tuple(row[a] for a in keys)
        cell = cells.setdefault(ck, Cell(dict(zip(keys, ck, strict=True))))
        if cell.config is None:
            cell.config = configs.get(row["run_key"])
        run = _run(row, fault_axis)
        if run.onset is None:
            cell.nofault.append(run)
        else:
            cell.faults.setdefault(run.severity, []).append(run)
    for cell in cells.values():
        if not cell.nofault:
            raise BadInput(f"STUDY_DIR: cell ({cell.label}) has no no-fault runs: false alarms cannot be measured")
        if cell.config is None:
            raise BadInput(f"STUDY_DIR: cannot rebuild the configuration of cell ({cell.label}) from study.toml")
    return list(cells.values()), keys


def _run(row: dict[str, Any], fault_axis: str) -> Run:
    recs = {}
    for r in RULES:
        v = _json(row.get(f"fdi_records_{r}"))
        recs[r] = np.asarray(v if v else np.zeros((0, 3)), float)
    run = Run(key=str(row["run_key"]), seed=int(row["seed"]), severity=row[fault_axis],
              onset=row.get("fault_onset_time"), wheel=row.get("true_fault_wheel"),
              duration=float(row["sim_time_s"]), records=recs)
    kl = _json(row.get("fdi_cumulative_kl"))
    run.kl = np.asarray(kl, float) if kl else None
    return run


def _configs(study_dir: Path, plan: dict[str, Any]) -> dict[str, RunConfig]:
    """Run key → resolved config, rebuilt from the study file copy and the plan's extra overrides."""
    seeds = sorted({int(r["seed"]) for r in plan.get("runs", [])})
    n = len(seeds) if seeds == list(range(len(seeds))) else None
    rebuilt = plan_study(study_dir / "study.toml", extra_overrides=plan.get("extra_overrides") or {}, seeds=n)
    return {r.key: validate_config(r.config) for r in rebuilt.runs}
