"""What a newcomer sees: the summary table (units, sign convention, true and estimated radii, the
note when the safe policy holds the nominal radii), ``-q``, ``--help`` with defaults and choices,
``--limit`` sampling across the axes, the message when a study folder holds another study, the coded
trace columns in the Parquet metadata, and ``metrics.json``'s ``feedback`` and hand-over delay."""

from __future__ import annotations

import json
import subprocess
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from ftc_mj.cli import app
from ftc_mj.config import load_config
from ftc_mj.sim.loop import SimResult
from ftc_mj.sim.run import RunOutcome, execute
from ftc_mj.sim.summary import print_run_summary
from ftc_mj.study.plan import plan_study
from ftc_mj.study.runner import covering_order, describe_selection, run_study

ROOT = Path(__file__).resolve().parents[2]


def outcome(metrics: dict[str, Any], split_std: float) -> RunOutcome:
    n = 10
    trace = {"R_R": np.full(n, 2.0), "R_L": np.full(n, 1.0), "R_R_hat": np.full(n, 2.6), "R_L_hat": np.full(n, 0.7),
             "R_R_model": np.full(n, 2.0), "R_L_model": np.full(n, 2.0), "radius_split_std": np.full(n, split_std)}
    return RunOutcome("r", metrics, SimResult(trace=trace), Path("runs/out/r"))


SAFE_HELD = {"status": "ok", "radius_final_error_R": 0.6, "radius_final_error_L": -0.3, "detection_time": 10.9,
             "isolated_wheel": "unknown", "policy": "safe", "reconfig_handovers": 0, "reconfig_holds": 1,
             "reconfig_reverts": 0, "cross_track_final": 1.9, "solve_time_ms": {"median": 1.5, "p95": 9.9, "max": 76.0}}


def test_summary_has_units_signs_radii_and_the_hold_note(capsys: pytest.CaptureFixture[str]) -> None:
    print_run_summary(outcome(SAFE_HELD, 0.55), max_sigma=0.1)
    text = capsys.readouterr().out
    assert "R_L final error (estimate − truth)" in text and "-0.3" in text
    assert "R_L at the end: truth / estimate /" in text and "1 / 0.7 / 2" in text
    assert "cross-track final (+ = left of the path)" in text
    assert "1.5 / 9.9 / 76 │ ms" in text and "hand-overs / holds / reverts" in text and "0 / 1 / 0" in text
    assert "The safe policy kept the nominal radii" in text and "σ of the split 0.55 m > 0.1 m" in text
    assert "written: runs/out/r" in text
    # no note when the radii were handed over, or with another policy
    for m in ({**SAFE_HELD, "reconfig_handovers": 1}, {**SAFE_HELD, "policy": "direct"}):
        print_run_summary(outcome(m, 0.55), max_sigma=0.1)
        assert "kept the nominal radii" not in capsys.readouterr().out


def test_nis_and_nees_carry_their_verdict(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "200")  # a table cell is not wrapped
    m = {**SAFE_HELD, "nis_mean": 0.8775, "nis_test": {"lo": 0.954, "hi": 1.047},
         "radius_nees_mean": 5.87, "radius_nees_test": {"lo": 1.456, "hi": 2.629}}
    print_run_summary(outcome(m, 0.05), max_sigma=0.1)
    text = " ".join(capsys.readouterr().out.split())
    assert "0.8775 (conservative: 95 % bounds 0.954–1.05)" in text
    assert "5.87 (overconfident: 95 % bounds 1.46–2.63)" in text


def test_times_are_rounded_to_the_sample(capsys: pytest.CaptureFixture[str]) -> None:
    m = {**SAFE_HELD, "detection_time": 10.950000000000001, "detection_delay": 0.9500000000000011,
         "onsets": [{"wheel": "left", "time": 10.0, "status": "in run", "detection_time": 10.950000000000001,
                     "detection_delay": 0.9500000000000011, "time_to_correct_isolation": 1.2300000000000004,
                     "false_isolations": 0, "missed_detection": False}]}
    print_run_summary(outcome(m, 0.05), max_sigma=0.1, sample_s=0.01)
    text = capsys.readouterr().out
    assert "0000000" not in text
    assert "10.95 │ s" in text
    assert "detection delay 0.95 s, correct isolation after 1.23 s" in text


def test_quiet_prints_the_run_folder(tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["run", "scenario1", "--duration", "0.3", "--controller", "open-loop", "--no-rrd",
                                   "--out", str(tmp_path), "-q"])
    assert res.exit_code == 0
    (run_dir,) = tmp_path.iterdir()
    assert res.stdout == f"{run_dir}\n" and res.stderr == ""


def test_run_help_shows_defaults_and_choices() -> None:
    text = " ".join(CliRunner().invoke(app, ["run", "--help"]).stdout.split())
    for s in ("<4|5>", "(none: nominal radii",
              "--plugin MODULE",
              "else ukf]", "[default: 4]", "else safe]", "[default: 0]", "else 40]", "runs/out]",
              "3 the physics became unstable"):
        assert s in text, s


STUDY = """
name = "lim"
scenario = "scenario1"
seeds = 5
[base]
duration = 0.5
[[axes]]
name = "sensors"
labels = ["speed", "speed+yaw"]
values = [{}, { "sensors.yaw_rate_sigma" = 0.01 }]
[[axes]]
key = "estimator.kind"
values = ["ekf", "ukf"]
"""


def test_limit_samples_across_the_axes(tmp_path: Path) -> None:
    p = tmp_path / "lim.toml"
    p.write_text(textwrap.dedent(STUDY))
    plan = plan_study(p)
    assert [r.seed for r in plan.runs[:5]] == [0, 1, 2, 3, 4]  # plan order: seeds innermost
    first4 = covering_order(plan.runs, plan.axis_columns)[:4]
    assert {(r.labels["sensors"], r.labels["estimator.kind"]) for r in first4} == {
        ("speed", "ekf"), ("speed", "ukf"), ("speed+yaw", "ekf"), ("speed+yaw", "ukf")}
    assert {r.seed for r in first4} == {0}
    first2 = covering_order(plan.runs, plan.axis_columns)[:2]
    assert {r.labels["sensors"] for r in first2} == {"speed", "speed+yaw"}
    assert {r.labels["estimator.kind"] for r in first2} == {"ekf", "ukf"}
    assert describe_selection(first2, plan.axis_columns, 20) == (
        "--limit: computing 2 of 20 missing runs, covering sensors speed, speed+yaw; estimator.kind ekf, ukf; "
        "seeds 0")


def test_reused_study_folder_says_what_differs(tmp_path: Path) -> None:
    p = tmp_path / "lim.toml"
    p.write_text(textwrap.dedent(STUDY))
    out = tmp_path / "out"

    def fake(cfg: Any, out_root: Any, rrd: bool) -> Any:
        from types import SimpleNamespace

        return SimpleNamespace(metrics={"status": "ok"}, result=SimpleNamespace(trace={}), run_dir=None)

    run_study(plan_study(p), out, serial=True, run_fn=fake, limit=1, analyse=False)
    res = CliRunner().invoke(app, ["study", str(p), "--out", str(out), "--seeds", "3", "--set", "duration=0.4"])
    assert res.exit_code == 2
    line = res.stderr.strip()
    assert "differs in --set duration: \"(unset)\" → 0.4; seeds: 5 → 3" in line and "\n" not in line


def test_trace_documents_its_coded_columns(tmp_path: Path) -> None:
    out = execute(load_config("scenario1", {"duration": 0.3, "controller.kind": "open-loop"}), tmp_path, rrd=False)
    assert out.run_dir is not None
    meta = pq.read_schema(out.run_dir / "trace.parquet").metadata
    cols = json.loads(meta[b"ftc_mj.columns"])
    assert "128 UNSTABLE" in cols["plant_flags"] and "1 LIFTOFF" in cols["plant_flags"]
    assert "2 handed over" in cols["reconfig_state"]
    outputs = (ROOT / "docs" / "usage.md").read_text()  # the outputs reference
    assert "plant_flags" in outputs and "128 UNSTABLE" in outputs and "3 reverted" in outputs


def test_feedback_and_handover_delay_for_direct() -> None:
    """``feedback`` says whether radii reached the controller; ``direct`` hands them over at every sample,
    so its hand-over delay is the time to the first controller sample at or after the onset."""
    ov = {"duration": 1.5, "faults.left": [[1.0, 2.0], [1.0, 1.0]], "plant.kind": "kinematic"}
    direct = execute(load_config("scenario2", {**ov, "reconfiguration.policy": "direct"})).metrics
    assert direct["feedback"] is True and direct["reconfig_handover_delay"] == pytest.approx(0.0, abs=1e-9)
    late = execute(load_config("scenario2", {**ov, "faults.left": [[1.05, 2.0], [1.05, 1.0]],
                                             "reconfiguration.policy": "direct"})).metrics
    assert late["reconfig_handover_delay"] == pytest.approx(0.05, abs=1e-9)  # next sample at 1.1 s
    safe = execute(load_config("scenario2", {**ov, "reconfiguration.policy": "safe"})).metrics
    assert safe["feedback"] is False and safe["reconfig_handover_delay"] is None  # nothing handed over in 0.5 s
    assert execute(load_config("scenario2", {**ov, "reconfiguration.policy": "none"})).metrics["feedback"] is False


def test_screenshot_script_usage() -> None:
    script = ROOT / "docs" / "screenshot.sh"
    assert subprocess.run(["bash", "-n", str(script)], check=False).returncode == 0
    res = subprocess.run(["bash", str(script)], capture_output=True, text=True, check=False)
    assert res.returncode == 2 and "usage:" in res.stderr and "--install" in res.stderr
    text = script.read_text()
    assert "xvfb" in text and "mesa-vulkan-drivers" in text and "system-wide" in text
