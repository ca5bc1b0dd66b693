"""End-to-end runs through the loop and the CLI: outputs, atomicity, determinism, exit codes."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from ftc_mj.cli import app
from ftc_mj.config import load_config, read_toml, validate_config
from ftc_mj.estimation.consistency import nees
from ftc_mj.sim import cache
from ftc_mj.sim.run import execute
from tests.support.shared_runs import SHARED_RUNS, SharedRuns


def test_cli_run_writes_all_outputs(tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["run", "scenario2", "--duration", "2", "--out", str(tmp_path), "-q"])
    assert res.exit_code == 0, res.output + res.stderr
    (run_dir,) = [p for p in tmp_path.iterdir()]
    assert sorted(p.name for p in run_dir.iterdir()) == ["config.toml", "events.json", "metrics.json",
                                                         "metrics.schema.json", "record.json", "run.rrd",
                                                         "trace.parquet"]
    # config.toml is the fully resolved config: it reloads to the same run
    cfg = validate_config(read_toml(run_dir / "config.toml"))
    assert cfg == load_config("scenario2", {"duration": 2.0})
    trace = pq.read_table(run_dir / "trace.parquet")
    assert trace.num_rows == 200
    for col in ("t", "x", "y", "psi", "v", "v_meas", "R_R", "R_L", "R_R_hat", "R_L_hat", "R_R_std", "R_L_std",
                "innovation", "innovation_std", "omega_R", "omega_L", "omega_R_cmd", "omega_L_cmd",
                "cross_track_error"):
        assert col in trace.column_names
    metrics = json.loads((run_dir / "metrics.json").read_text())
    for key in ("radius_rmse_R", "radius_rmse_L", "radius_final_error_R", "radius_final_error_L",
                "innovation_in_2sigma", "cross_track_rms", "cross_track_max", "cross_track_final",
                "omega_at_limit_fraction", "solve_time_ms", "solver_failures", "wall_time_s", "realtime_factor"):
        assert key in metrics
    assert set(metrics["solve_time_ms"]) == {"median", "p95", "max"}
    # consistency with χ² bounds, recomputable from the trace alone (full 2x2 radius covariance)
    for key in ("radius_nees", "nees", "nis"):
        assert set(metrics[f"{key}_test"]) == {"lo", "hi", "n_eff", "samples", "tau", "dof"}
        assert metrics[f"{key}_test"]["lo"] < metrics[f"{key}_test"]["hi"]
    cols = trace.to_pydict()
    e = np.stack([np.asarray(cols["R_R_hat"]) - cols["R_R"], np.asarray(cols["R_L_hat"]) - cols["R_L"]], axis=1)
    sR, sL, c = (np.asarray(cols[k]) for k in ("R_R_std", "R_L_std", "R_RL_cov"))
    P = np.stack([np.stack([sR**2, c], axis=1), np.stack([c, sL**2], axis=1)], axis=1)
    assert np.nanmean(nees(e, P)) == pytest.approx(metrics["radius_nees_mean"], rel=1e-9)
    assert metrics["exceptions"] == 0 and metrics["error"] is None
    # the scenario's puncture at 10 s lies after the end of this 2 s run
    assert metrics["onsets"] == [{"wheel": "left", "time": 10.0, "status": "after end"}]
    assert metrics["missed_detection"] is None


def test_cli_says_a_fault_after_the_end_is_neither_detected_nor_missed(tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["run", "scenario2", "--duration", "1", "--no-rrd", "--out", str(tmp_path),
                                   "--controller", "open-loop"])
    assert res.exit_code == 0, res.output
    text = " ".join(res.output.split())
    assert "fault onset: left at t = 10 s: after the end of the run (1 s), neither detected nor missed" in text


def test_scenario3_run_reports_both_onsets(shared_runs: SharedRuns) -> None:
    m = shared_runs["s3-kinematic-gyro-12s"].metrics
    assert [(e["wheel"], e["time"], e["status"]) for e in m["onsets"]] == [("left", 5.0, "in run"),
                                                                         ("right", 10.0, "in run")]
    print({k: [e[k] for e in m["onsets"]] for k in ("detection_delay", "time_to_correct_isolation",
                                                     "false_isolations", "declared_at_onset")})
    for e in m["onsets"]:
        assert {"detection_delay", "time_to_correct_isolation", "false_isolations", "missed_detection"} <= set(e)
    assert m["detection_delay"] == m["onsets"][0]["detection_delay"]


def test_second_run_never_overwrites(tmp_path: Path) -> None:
    args = ["run", "scenario1", "--duration", "0.5", "--out", str(tmp_path), "-q", "--no-rrd",
            "--controller", "open-loop"]
    for _ in range(2):
        assert CliRunner().invoke(app, args).exit_code == 0
    names = sorted(p.name for p in tmp_path.iterdir())
    assert len(names) == 2 and names[1] == names[0] + "-2"


def _assert_same_trace(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> None:
    assert list(a) == list(b)
    for col in a:
        if col == "solve_time_ms":  # wall-clock, the only column that may differ
            continue
        np.testing.assert_array_equal(a[col], b[col], err_msg=col)


def test_run_is_pure_function_of_config_and_seed(shared_runs: SharedRuns) -> None:
    """Scenario 2 with a gyro and the puncture at 3 s, 5 s (the puncture, its detection and the safe policy's
    hand-over): a run on a freshly built plant and solver equals one on the per-process cache's (reset)
    plant and solver, bit for bit."""
    name = "s2-puncture-5s-safe"
    shared = shared_runs[name].result.trace
    cfg = shared_runs.config(name)
    builds = cache.stats["controller_builds"], cache.stats["plant_builds"]
    cache.clear()
    fresh = execute(cfg).result.trace  # built fresh
    assert (cache.stats["controller_builds"], cache.stats["plant_builds"]) == (builds[0] + 1, builds[1] + 1)
    _assert_same_trace(fresh, shared)
    if not shared_runs.reused_solver(name):  # the shared run was a fresh build too: run once more, cached
        hits = cache.stats["controller_hits"], cache.stats["plant_hits"]
        _assert_same_trace(fresh, execute(cfg).result.trace)
        assert cache.stats["controller_hits"] > hits[0] and cache.stats["plant_hits"] > hits[1]
    # another seed draws other sensor noise from the first step on (1 s is enough to see it)
    scenario, overrides = SHARED_RUNS[name]
    other = execute(load_config(scenario, {**overrides, "seed": 1, "duration": 1.0})).result.trace
    assert not np.array_equal(fresh["v_meas"][: other["v_meas"].size], other["v_meas"])


def test_imm_run_has_mode_columns() -> None:
    out = execute(load_config("scenario4", {"duration": 1.0, "estimator.kind": "imm-ukf", "estimator.imm_models": 5}))
    assert out.metrics["status"] == "ok"
    probs = np.stack([out.result.trace[f"mode_prob_{j}"] for j in range(1, 6)])
    np.testing.assert_allclose(probs.sum(axis=0), 1.0, atol=1e-9)


def test_killed_run_leaves_no_output_under_final_name(tmp_path: Path) -> None:
    """Kill the run inside its write window: as soon as the output folder gets its first entry (the
    temporary directory, or — if the writes were not atomic — the run directory itself), while the
    files are being written. Nothing may be visible under a final name. (Replacing ``atomic_dir`` by a
    plain directory makes this test fail: the half-written run directory is left behind.) The
    preflight's writability probe (``.ftc-mj-probe.*``, created and deleted before any work) is not
    the write window and is skipped."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    proc = subprocess.Popen([sys.executable, "-m", "ftc_mj.cli", "run", "scenario2", "--duration", "10",
                             "--out", str(tmp_path), "-q"], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120.0
    entries: list[Path] = []
    while not entries and proc.poll() is None and time.monotonic() < deadline:
        entries = [p for p in tmp_path.iterdir() if not p.name.startswith(".ftc-mj-probe.")]
        time.sleep(0.001)
    alive = proc.poll() is None
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert alive and entries, "the run ended (or timed out) before its write window was seen"
    visible = [p for p in tmp_path.iterdir() if not p.name.startswith(".")]
    assert visible == []
    left = [p for p in tmp_path.iterdir() if not p.name.startswith(".ftc-mj-probe.")]
    assert [p.name.endswith(".partial") for p in left] == [True]  # killed inside the window


def _raise_type_error(self, *args, **kwargs):
    raise TypeError("unsupported operand type(s) for +: 'NoneType' and 'float'")


def test_a_component_exception_fails_the_run_and_is_recorded(tmp_path: Path, monkeypatch) -> None:
    """A ``TypeError`` inside the NMPC's solve is a bug, not a solver failure: the run fails (exit 1)
    with the error and where it was raised in ``metrics.json``, and no fallback is counted."""
    from ftc_mj.control.nmpc import NMPC
    from ftc_mj.sim.loop import STRICT_ENV

    monkeypatch.setenv(STRICT_ENV, "0")
    monkeypatch.setattr(NMPC, "_solve", _raise_type_error)
    res = CliRunner().invoke(app, ["run", "scenario2", "--duration", "1", "--no-rrd", "--out", str(tmp_path), "-q"])
    assert res.exit_code == 1 and "TypeError" in res.stderr
    (run_dir,) = list(tmp_path.iterdir())
    m = json.loads((run_dir / "metrics.json").read_text())
    assert m["status"] == "failed" and m["error"].startswith("TypeError: unsupported operand")
    assert "_raise_type_error" in m["error_where"]
    assert m["exceptions"] == 1 and m["solver_failures"] == 0
    assert pq.read_table(run_dir / "trace.parquet").num_rows == 0  # failed at the first control sample
    # strict mode (the suite's default) re-raises instead of recording
    monkeypatch.setenv(STRICT_ENV, "1")
    with pytest.raises(TypeError, match="unsupported operand"):
        execute(load_config("scenario2", {"duration": 1.0}))


def test_solver_errors_still_become_fallbacks(monkeypatch) -> None:
    """An error raised by CasADi inside a solve is a solver failure: the controller falls back to its
    plan, the run goes on and counts it; a plain ``RuntimeError`` of our own code fails the run."""
    import casadi as ca

    from ftc_mj.control.nmpc import NMPC

    def casadi_error(self, t, pose, radii, t_start):
        ca.DM.ones(2, 3) @ ca.DM.ones(2, 3)  # dimension mismatch: CasADi raises RuntimeError
        raise AssertionError("unreachable")

    monkeypatch.setattr(NMPC, "_solve", casadi_error)
    out = execute(load_config("scenario2", {"duration": 1.0}))
    assert out.metrics["status"] == "ok" and out.metrics["exceptions"] == 0
    assert out.metrics["solver_failures"] == 10  # every sample of 1 s at 10 Hz
    assert all(s.status.startswith("fallback: solver error: RuntimeError") for s in out.result.solves)

    def lapack_error(self, t, pose, radii, t_start):
        np.linalg.cholesky(-np.eye(2))  # LinAlgError: not positive definite

    monkeypatch.setattr(NMPC, "_solve", lapack_error)
    out = execute(load_config("scenario2", {"duration": 0.5}))
    assert out.metrics["status"] == "ok" and out.metrics["solver_failures"] == 5
    assert out.result.solves[0].status.startswith("fallback: solver error: LinAlgError")

    def own_error(self, t, pose, radii, t_start):
        raise RuntimeError("a bug of ours")

    monkeypatch.setattr(NMPC, "_solve", own_error)
    with pytest.raises(RuntimeError, match="a bug of ours"):
        execute(load_config("scenario2", {"duration": 1.0}))


def test_view_bad_run_dir(tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["view", str(tmp_path)])
    assert res.exit_code == 2
    assert res.stderr.count("\n") == 1 and "RUN_DIR" in res.stderr


def test_view_opens_the_recording(tmp_path: Path, monkeypatch) -> None:
    """``ftc-mj view`` hands the run's recording to the Rerun viewer binary."""
    import ftc_mj.rerun.viewer as viewer
    from ftc_mj.rerun.record import write_rrd
    from tests.support.synthetic import synthetic_run

    trace, solves, events, ref = synthetic_run(2.0)
    write_rrd(tmp_path / "run.rrd", trace, run_id="r", solves=solves, events=events, reference_path=ref)
    monkeypatch.setenv("DISPLAY", ":99")
    seen: list[list[str]] = []

    class Done:
        returncode = 0

    monkeypatch.setattr(viewer.subprocess, "run", lambda cmd, check=False: seen.append(cmd) or Done())
    assert CliRunner().invoke(app, ["view", str(tmp_path)]).exit_code == 0
    assert seen and seen[0][1] == str(tmp_path / "run.rrd")


def test_cli_reconfig_option_and_feedback_aliases(tmp_path: Path) -> None:
    r = CliRunner()
    for args, policy in ((["--reconfig", "direct"], "direct"), (["--no-feedback"], "none"), (["--feedback"], "direct"),
                         ([], "safe")):
        out = tmp_path / (args[0].strip("-") if args else "default")
        res = r.invoke(app, ["run", "scenario2", "--duration", "0.5", "--no-rrd", "--out", str(out), "-q", *args])
        assert res.exit_code == 0, res.output
        (run_dir,) = list(out.iterdir())
        assert json.loads((run_dir / "metrics.json").read_text())["policy"] == policy
        assert f"_{policy}_s0_" in run_dir.name
    # contradictions and unknown policies: one line naming the option or field, exit 2, nothing written
    for args, msg in ((["--reconfig", "safe", "--no-feedback"], "--feedback/--no-feedback"),
                      (["--set", "feedback=false", "--set", "reconfiguration.policy=direct"], "feedback: false"),
                      (["--reconfig", "sometimes"], "--reconfig")):
        out = tmp_path / "bad"
        res = r.invoke(app, ["run", "scenario2", "--duration", "0.5", "--out", str(out), "-q", *args])
        assert res.exit_code == 2 and msg in res.output, (args, res.output)
        assert not out.exists()


def test_a_simulated_run_written_afterwards_reads_back_the_same(shared_runs: SharedRuns) -> None:
    """:func:`~ftc_mj.sim.run.write_outcome` (what ``execute`` does with ``out_root``) on a run simulated
    earlier: the directory reads back with the run's trace, metrics, events and config."""
    import ftc_mj

    name = "s2-puncture-5s-none"
    out = shared_runs[name]
    d = shared_runs.run_dir(name)
    assert d.name == out.run_id and sorted(p.name for p in d.iterdir()) == ["config.toml", "events.json",
                                                                          "metrics.json", "metrics.schema.json",
                                                                          "record.json", "trace.parquet"]
    back = ftc_mj.load_run(d)
    assert back.config == shared_runs.config(name) and back.run_id == out.run_id
    for col, values in out.result.trace.items():
        np.testing.assert_array_equal(back.trace[col].to_numpy(), values, err_msg=col)
    assert [(e.t, e.level, e.text) for e in back.events] == [(e.t, e.level, e.text) for e in out.result.events]
    assert back.metrics["detection_time"] == out.metrics["detection_time"]
    assert "total_wall_time_s" in back.metrics and "total_wall_time_s" not in out.metrics  # the shared run is unchanged
