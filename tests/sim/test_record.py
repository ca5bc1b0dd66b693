"""The resolved run record (:mod:`ftc_mj.sim.record`): built once per run, written beside the metrics and
read back unchanged; the filter setup and the posterior Cramér–Rao bound are computed once per run, for
the run, its metrics and its scores."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import ftc_mj.estimation.pcrb as pcrb
from ftc_mj.benchmark.score import score_run
from ftc_mj.config import load_config
from ftc_mj.estimation.setup import FilterSetup
from ftc_mj.metrics.fdi import fdi_sweep_metrics
from ftc_mj.metrics.run import compute_metrics
from ftc_mj.sim.loop import ClosedLoop
from ftc_mj.sim.record import build_record, read_record
from ftc_mj.sim.run import execute

SHORT = {"duration": 2.0, "plant.kind": "kinematic", "faults.left": [[1.0, 2.0], [1.0, 1.5]],
         "sensors.yaw_rate_sigma": 0.01}
"""A short run with a puncture at 1 s (so the fault's information and both bounds have rows to cover)."""


def _counting(monkeypatch: pytest.MonkeyPatch) -> dict[str, int]:
    """Count the filter setups resolved (:meth:`FilterSetup.from_sections`, where every one is made) and the
    bound's computations (:func:`~ftc_mj.estimation.pcrb.linearise_trace`, which every bound of a trace starts
    with, and :func:`~ftc_mj.estimation.pcrb.trace_pcrb`)."""
    calls = {"setup": 0, "linearise": 0, "trace_pcrb": 0}
    make = FilterSetup.from_sections.__func__  # type: ignore[attr-defined]

    def counted(name: str, fn: Any) -> Any:
        def wrapper(*args: Any, **kw: Any) -> Any:
            calls[name] += 1
            return fn(*args, **kw)
        return wrapper

    monkeypatch.setattr(FilterSetup, "from_sections", classmethod(counted("setup", make)))
    monkeypatch.setattr(pcrb, "linearise_trace", counted("linearise", pcrb.linearise_trace))
    monkeypatch.setattr(pcrb, "trace_pcrb", counted("trace_pcrb", pcrb.trace_pcrb))
    return calls


@pytest.mark.parametrize(("estimator", "extra"), [
    ("ukf", {}), ("none", {}),
    ("ukf", {"estimator.decision.rule": "glr"}),  # the rule's threshold calibration and detectors use the setup
    ("ukf", {"estimator.decision.rule": "cusum", "estimator.decision.statistics": True}),
])
def test_the_filter_setup_and_the_bound_are_computed_once_per_run(
        estimator: str, extra: dict[str, Any], tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A run with its metrics, its written folder and its benchmark scores resolves the filter setup once
    (the filter's own, which the record keeps and the decision rules' calibration, detectors and statistics
    share) and computes the PCRB once (none without a filter)."""
    cfg = load_config("scenario2", {**SHORT, "estimator.kind": estimator, **extra})
    calls = _counting(monkeypatch)
    out = execute(cfg, tmp_path, rrd=False)
    res = out.result
    scores = score_run(cfg, res.trace, res.events, status=out.metrics["status"], record=res.record)
    assert out.metrics["status"] == "ok"
    assert calls == ({"setup": 1, "linearise": 1, "trace_pcrb": 1} if estimator == "ukf"
                     else {"setup": 1, "linearise": 0, "trace_pcrb": 0})
    if estimator == "ukf":  # the scorer reads the bound the run recorded, at its last row
        assert scores["radius_pcrb_L"] == float(res.trace["R_L_pcrb_const_std"][-1]) > 0.0
        assert res.record is not None and res.record.setup is not None
    else:
        assert scores["radius_pcrb_L"] is None


def test_the_record_is_written_and_reads_back_to_the_same_metrics(tmp_path: Path) -> None:
    """``record.json`` reads back to the record the loop built (same setup arrays, context, onsets), and the
    metrics computed from the record read back equal the run's bit for bit."""
    cfg = load_config("scenario2", SHORT)
    out = execute(cfg, tmp_path, rrd=False)
    assert out.run_dir is not None and out.result.record is not None
    mem, disk = out.result.record, read_record(out.run_dir)
    assert disk.onsets == mem.onsets == {"right": None, "left": 1.0}
    assert disk.context == mem.context and disk.run_id == mem.run_id == out.run_id
    assert disk.reference_rates == mem.reference_rates == (10.0, 10.0 / 50.0)
    for name in ("x0", "P0", "Q"):
        assert np.array_equal(getattr(disk.setup, name), getattr(mem.setup, name))
    assert disk.setup.model.b == mem.setup.model.b and disk.setup.yaw_rate_sigma == 0.01
    tr = out.result.trace
    again = {**compute_metrics(disk, tr, out.result.counters), **fdi_sweep_metrics(disk, tr)}
    def canonical(m: dict[str, Any]) -> str:  # NaN equal to NaN, floats by repr: bit for bit
        return json.dumps(m, sort_keys=True, default=repr)

    assert canonical({k: out.metrics[k] for k in again}) == canonical(again)
    assert again["fdi_cumulative_kl"]  # the fault's information from the record's onset and setup


def test_the_record_resolves_what_the_config_says() -> None:
    """The record of a config without a run: the filter setup resolved from the config, the onsets of each
    wheel's schedule, a line's zero yaw rate and a circle's single curvature."""
    circle = build_record(load_config("scenario3"))
    assert circle.onsets == {"right": 10.0, "left": 5.0} and circle.first_onset == 5.0
    assert circle.path_curvatures == (1.0 / 50.0,)
    assert circle.setup.nominal_radius == 2.0 and circle.estimator == "ukf"
    line = build_record(load_config("scenario1", {"reference.kind": "line"}))
    assert line.reference_rates == (10.0, 0.0) and line.path_curvatures == (0.0,)
    assert line.first_onset is None


def test_a_loop_asked_twice_for_its_result_computes_the_bound_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """An episode's score and its metrics each ask the loop for its result (:mod:`ftc_mj.envs`): the bound of
    the same rows is computed once; a new row computes it again, for the longer trace."""
    cfg = load_config("scenario2", SHORT)
    calls = _counting(monkeypatch)
    loop = ClosedLoop(cfg)
    for k in range(loop.n - 1):
        loop.step(k)
    first, again = loop.result(0.0), loop.result(0.0)
    assert calls["trace_pcrb"] == 1 and again.trace["R_L_pcrb_std"] is first.trace["R_L_pcrb_std"]
    loop.step(loop.n - 1)
    assert loop.result(0.0).trace["R_L_pcrb_std"].size == loop.n and calls["trace_pcrb"] == 2
