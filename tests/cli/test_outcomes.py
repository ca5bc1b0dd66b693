"""Outcomes first: a run's physical outcome (on the path / off the path / tipped over) is decided by a
stated rule, recorded in metrics.json, printed in the summary's first line beside the simulation
status (never a plain ``ok`` for a robot that fell over), and counted by a study."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pytest

from ftc_mj.cli import outcome_counts
from ftc_mj.config import RunConfig
from ftc_mj.metrics.outcome import OFF_PATH_M, physical_outcome
from ftc_mj.sim.loop import SimResult
from ftc_mj.sim.run import RunOutcome
from ftc_mj.sim.summary import print_run_summary
from ftc_mj.study.plan import plan_study
from ftc_mj.study.runner import run_study
from tests.support.fake_runs import FakeOutcome, FakeResult

FAULT = {"status": "ok", "tipped": False, "cross_track_max_recovered": 0.3, "liftoff_time_post_transient_s": 0.0}


@pytest.mark.parametrize(("metrics", "outcome", "rule"), [
    (FAULT, "on the path", "max |cross-track| 0.30 m from 5 s after the fault <= 0.5 m"),
    ({**FAULT, "cross_track_max_recovered": OFF_PATH_M + 0.01}, "off the path",
     "0.51 m from 5 s after the fault > 0.5"),
    ({**FAULT, "tipped": True, "cross_track_max_recovered": 0.1}, "tipped over", "tipped_limit_deg"),
    ({"status": "ok", "tipped": False, "cross_track_max_settled": 0.02}, "on the path", "after the settling time"),
    ({**FAULT, "status": "unstable"}, "not judged", "status unstable"),
    ({**FAULT, "cross_track_max_recovered": float("nan")}, "not judged", "the run ended before"),
])
def test_outcome_rule(metrics: dict, outcome: str, rule: str) -> None:
    got = physical_outcome(metrics)
    assert got["outcome"] == outcome and rule in got["outcome_rule"], got


def test_wheel_lifted_is_reported_beside_the_outcome() -> None:
    got = physical_outcome({**FAULT, "liftoff_time_post_transient_s": 1.9})
    assert got["outcome"] == "on the path" and got["wheel_lifted"] is True


def test_a_tipped_run_says_so_first_and_never_a_plain_ok(capsys: pytest.CaptureFixture[str]) -> None:
    m = {**FAULT, "tipped": True, "cross_track_max_recovered": 103.7, "liftoff_time_post_transient_s": 24.4,
         "cross_track_final": -100.7}
    m.update(physical_outcome(m))
    trace = {c: np.full(3, 1.0) for c in ("R_R", "R_L", "R_R_hat", "R_L_hat", "R_R_model", "R_L_model")}
    print_run_summary(RunOutcome("r", m, SimResult(trace=trace), None))
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("OUTCOME: TIPPED OVER (")
    assert "wheel lifted off the ground for 24.4 s" in lines[1]
    assert lines[2].startswith("simulation status: ok (the simulation completed;")
    status_row = next(ln for ln in lines if "simulation status" in ln and "│" in ln)
    assert "ok (completed)" in status_row
    assert any("outcome (robot)" in ln and "tipped over" in ln for ln in lines)


def fake_run(cfg: RunConfig, out_root: Path | None, rrd: bool) -> FakeOutcome:
    """Seed 0 stays on the path, seed 1 leaves it, seed 2 tips over."""
    m = {"status": "ok", "tipped": cfg.seed == 2, "cross_track_max_recovered": [0.2, 3.0, 50.0][cfg.seed],
         "liftoff_time_post_transient_s": 0.0}
    m.update(physical_outcome(m))
    t = np.arange(10) / 10.0
    return FakeOutcome(m, FakeResult({"t": t, "cross_track_error": 0.0 * t}))


def test_a_study_says_what_it_starts_before_the_first_run_finishes(tmp_path: Path) -> None:
    (tmp_path / "s.toml").write_text('name = "start"\nscenario = "scenario2"\nseeds = 3\n[base]\nduration = 1.0\n')
    said: list[str] = []

    def fake(cfg: RunConfig, out_root: Path | None, rrd: bool) -> FakeOutcome:
        said.append(f"run {cfg.seed}")
        return fake_run(cfg, out_root, rrd)

    run_study(plan_study(tmp_path / "s.toml"), tmp_path / "out", serial=True, run_fn=fake, analyse=False,
              echo=said.append, progress=True)
    assert said[0] == ("computing 3 run(s) in this process; starting — each process builds or loads its solvers "
                       "before its first run finishes")
    assert said[1:4] == ["run 0", "run 1", "run 2"]


def test_a_study_counts_outcomes(tmp_path: Path) -> None:
    (tmp_path / "s.toml").write_text(textwrap.dedent("""
        name = "outcomes"
        scenario = "scenario2"
        seeds = 3
        [base]
        duration = 1.0
    """))
    rep = run_study(plan_study(tmp_path / "s.toml"), tmp_path / "out", serial=True, run_fn=fake_run, analyse=False)
    assert rep.outcomes == {"on the path": 1, "off the path": 1, "tipped over": 1}
    assert outcome_counts(rep.outcomes) == "1 on the path, 1 OFF THE PATH, 1 TIPPED OVER"
