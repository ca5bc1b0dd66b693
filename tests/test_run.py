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
from typer.testing import CliRunner

from ftc_mj.cli import app
from ftc_mj.config import load_config, read_toml, validate_config
from ftc_mj.sim import cache
from ftc_mj.sim.run import execute


def test_cli_run_writes_all_outputs(tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["run", "scenario2", "--duration", "2", "--out", str(tmp_path), "-q"])
    assert res.exit_code == 0, res.output + res.stderr
    (run_dir,) = [p for p in tmp_path.iterdir()]
    assert sorted(p.name for p in run_dir.iterdir()) == ["config.toml", "metrics.json", "run.rrd", "trace.parquet"]
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


def test_second_run_never_overwrites(tmp_path: Path) -> None:
    args = ["run", "scenario1", "--duration", "0.5", "--out", str(tmp_path), "-q", "--no-rrd",
            "--controller", "open-loop"]
    for _ in range(2):
        assert CliRunner().invoke(app, args).exit_code == 0
    names = sorted(p.name for p in tmp_path.iterdir())
    assert len(names) == 2 and names[1] == names[0] + "-2"


def test_run_is_pure_function_of_config_and_seed() -> None:
    cfg = load_config("scenario2", {"duration": 12.0, "estimator.kind": "ukf", "controller.kind": "nmpc"})
    cache.clear()
    a = execute(cfg).result.trace  # built fresh
    b = execute(cfg).result.trace  # plant and solver reused from the per-process cache, after reset()
    assert cache.stats["controller_hits"] >= 1 and cache.stats["plant_hits"] >= 1
    for col in a:
        if col == "solve_time_ms":  # wall-clock, the only column that may differ
            continue
        np.testing.assert_array_equal(a[col], b[col], err_msg=col)
    c = execute(load_config("scenario2", {"duration": 12.0, "seed": 1})).result.trace
    assert not np.array_equal(a["v_meas"], c["v_meas"])


def test_imm_run_has_mode_columns() -> None:
    out = execute(load_config("scenario4", {"duration": 1.0, "estimator.kind": "imm-ukf", "estimator.imm_models": 5}))
    assert out.metrics["status"] == "ok"
    probs = np.stack([out.result.trace[f"mode_prob_{j}"] for j in range(1, 6)])
    np.testing.assert_allclose(probs.sum(axis=0), 1.0, atol=1e-9)


def test_killed_run_leaves_no_output_under_final_name(tmp_path: Path) -> None:
    env = dict(os.environ, OMP_NUM_THREADS="1")
    proc = subprocess.Popen([sys.executable, "-m", "ftc_mj.cli", "run", "scenario2", "--duration", "40",
                             "--out", str(tmp_path), "-q"], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    time.sleep(1.5)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    visible = [p for p in tmp_path.iterdir() if not p.name.startswith(".")] if tmp_path.exists() else []
    assert visible == []


def test_view_bad_run_dir(tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["view", str(tmp_path)])
    assert res.exit_code == 2
    assert res.stderr.count("\n") == 1 and "RUN_DIR" in res.stderr


def test_view_opens_the_recording(tmp_path: Path, monkeypatch) -> None:
    """``ftc-mj view`` hands the run's recording to the Rerun viewer binary."""
    import ftc_mj.recorder as recorder

    trace, solves, events, ref = recorder.synthetic_run(2.0)
    recorder.write_rrd(tmp_path / "run.rrd", trace, run_id="r", solves=solves, events=events, reference_path=ref)
    monkeypatch.setenv("DISPLAY", ":99")
    seen: list[list[str]] = []

    class Done:
        returncode = 0

    monkeypatch.setattr(recorder.subprocess, "run", lambda cmd, check=False: seen.append(cmd) or Done())
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
