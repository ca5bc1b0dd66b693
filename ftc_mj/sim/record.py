"""The resolved run record, built once in the loop's wiring (:func:`build_record`), written beside the
metrics as ``record.json`` (:func:`write_record`) and read back (:func:`read_record`).

The record (:class:`~ftc_mj.metrics.record.RunRecord`) holds what the metrics, the benchmark's scorer
and the studies would otherwise rebuild from the application config: the filter setup (the one the
run's filter was built with, so the posterior Cramér–Rao bound describes the filter that ran), the run
context, the reference's rates and path curvature, the scheduled fault onsets and the decision's bounds
settings.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from ..config import RunConfig, run_context
from ..estimation.setup import FilterSetup
from ..identity import run_id
from ..io import write_json
from ..metrics.record import RunRecord
from ..plant.faults import schedule_onset
from ..wiring.control import build_reference
from ..wiring.decision import reference_rates
from ..wiring.estimation import setup_from_config

RECORD_FILE = "record.json"
"""The record's file in a run folder."""
PATH_SAMPLE_M = 0.5
"""Arc-length step (m) at which the reference path's curvature is sampled."""
PATH_SPAN_M = 400.0
"""Arc length (m) sampled on a path without a period (a line)."""


def fault_onsets(cfg: RunConfig) -> dict[str, float | None]:
    """First time (s) each wheel's scheduled radius departs from nominal
    (:func:`~ftc_mj.plant.faults.schedule_onset`, the one home of that rule); None = no fault."""
    R0 = cfg.plant_wheel_radius
    return {"right": schedule_onset(cfg.faults.right, R0), "left": schedule_onset(cfg.faults.left, R0)}


def path_curvatures(reference: Any) -> tuple[float, ...]:
    """The distinct curvatures (1/m) of ``reference``'s path every :data:`PATH_SAMPLE_M` over one period
    (its ``length``) or :data:`PATH_SPAN_M`."""
    length = float(getattr(reference, "length", PATH_SPAN_M))
    k = reference.geometry(np.linspace(0.0, length, int(length / PATH_SAMPLE_M) + 1)).curvature
    return tuple(float(v) for v in np.unique(k))


def build_record(cfg: RunConfig, *, reference: Any = None, estimator: Any = None) -> RunRecord:
    """The record of the run ``cfg``: ``reference`` is the run's reference path (built when not given),
    ``estimator`` its filter, whose setup (a :class:`FilterSetup` attribute ``setup``) is taken as it is;
    without one the setup is resolved from the config (:func:`setup_from_config`)."""
    setup = getattr(estimator, "setup", None)
    if not isinstance(setup, FilterSetup):
        setup = setup_from_config(cfg)
    ref = build_reference(cfg) if reference is None else reference
    d = cfg.estimator.decision
    return RunRecord(
        run_id=run_id(cfg), context=run_context(cfg), setup=setup, estimator=cfg.estimator.kind,
        onsets=fault_onsets(cfg), reference_rates=reference_rates(cfg), reference_speed=cfg.reference.speed,
        path_curvatures=path_curvatures(ref), plant_half_track=cfg.plant_half_track,
        omega_rate_max=getattr(cfg.controller, "omega_rate_max", None),  # the open loop has no rate bound
        max_split_sigma=d.max_split_sigma, arl0=d.arl0)


def write_record(run_dir: Path, record: RunRecord) -> None:
    """Write ``run_dir/record.json`` atomically."""
    write_json(Path(run_dir) / RECORD_FILE, record.to_json())


def read_record(run_dir: Path) -> RunRecord:
    """The record of the run folder ``run_dir`` (``FileNotFoundError`` for a run written before records)."""
    return RunRecord.from_json(json.loads((Path(run_dir) / RECORD_FILE).read_text()))
