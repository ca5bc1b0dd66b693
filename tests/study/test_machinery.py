"""Study machinery with an injected, instantaneous run function (serial, in-process): persistence
of each row, resume without recomputation, failing runs as rows, refusal of a different study in
the same output folder, analysis output. The real simulation on a dask cluster is exercised in
``test_study_cluster.py``."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from ftc_mj.config import RunConfig
from ftc_mj.errors import BadInput
from ftc_mj.study.plan import plan_study
from ftc_mj.study.rows import wall_columns
from ftc_mj.study.runner import run_study
from ftc_mj.study.store import StudyStore
from tests.study.studies import NO_FIGURES, SENSORS_BY_ESTIMATOR
from tests.support.fake_runs import FakeOutcome, FakeResult


def fake_run(cfg: RunConfig, out_root: Path | None, rrd: bool) -> FakeOutcome:
    """Deterministic stand-in for ``execute``: metrics are simple functions of the config."""
    if cfg.sensors.speed_sigma == 0.3:
        raise RuntimeError("boom in the plant")
    n = int(cfg.duration * cfg.estimator.rate)
    t = np.arange(n) / cfg.estimator.rate
    rng = np.random.default_rng(cfg.seed)
    gyro = cfg.sensors.yaw_rate_sigma is not None
    err = (0.05 if gyro else 0.8) + 0.01 * rng.standard_normal()
    RL = np.where(t >= 1.0, 1.0, 2.0)
    trace = {"t": t, "R_R": np.full(n, 2.0), "R_L": RL, "R_R_hat": np.full(n, 2.0 + err), "R_L_hat": RL - err,
             "R_R_std": np.full(n, 0.1), "R_L_std": np.full(n, 0.1), "fault_detected": (t > 1.5).astype(float),
             "cross_track_error": 0.1 * np.sin(t)}
    status = "failed" if cfg.sensors.speed_sigma == 0.4 else "ok"
    metrics = {"status": status, "error": "diverged" if status != "ok" else None, "radius_final_error_L": -err,
               "radius_final_error_R": err, "detection_delay": 0.5 + 0.1 * rng.random(), "false_alarm": False,
               "missed_detection": False, "true_fault_wheel": "left", "isolated_wheel": "left" if gyro else "right",
               "isolation_correct": gyro, "cross_track_rms": 0.07, "solve_time_ms": {"median": 3.0, "p95": 4.0},
               "wall_time_s": float(rng.random()), "estimator": cfg.estimator.kind}
    return FakeOutcome(metrics, FakeResult(trace))


STUDY = """
name = "mach"
scenario = "scenario2"
seeds = 3
[base]
duration = 3.0
""" + SENSORS_BY_ESTIMATOR + """
[[analysis.findings]]
metric = "isolation_correct"
axis = "sensors"
by = "estimator"
"""


def study(tmp_path: Path, text: str = STUDY, name: str = "mach.toml") -> Path:
    p = tmp_path / name
    p.write_text(textwrap.dedent(text))
    return p


def comparable(df: pl.DataFrame) -> pl.DataFrame:
    return df.drop(wall_columns(df.columns)).sort("run_index")


def test_serial_study_rows_results_summary(tmp_path: Path) -> None:
    plan = plan_study(study(tmp_path))
    out = tmp_path / "out"
    rep = run_study(plan, out, serial=True, run_fn=fake_run)
    assert len(rep.computed) == 12 and rep.already_done == 0
    assert len(list((out / "rows").glob("*.parquet"))) == 12
    df = pl.read_parquet(out / "results.parquet")
    assert df.height == 12 and df["run_key"].to_list() == [r.key for r in plan.runs]
    for col in ("sensors", "estimator", "seed", "solve_time_ms_median", "m_estimator", "ts_t", "ts_R_L_hat"):
        assert col in df.columns, col
    assert (out / "study.toml").read_text() == (tmp_path / "mach.toml").read_text()
    text = (out / "summary.md").read_text()
    assert "sensors = speed+yaw reduces it from 0.8" in text and "(95 % CIs do not overlap)" in text
    assert "| true \\ isolated |" in text and (out / "figures" / "by_sensors.png").is_file()
    assert (out / "figures" / "time_sensors.png").is_file()


def test_resume_computes_only_missing(tmp_path: Path) -> None:
    plan = plan_study(study(tmp_path))
    ref = run_study(plan, tmp_path / "ref", serial=True, run_fn=fake_run, analyse=False).results
    out = tmp_path / "out"
    first = run_study(plan, out, serial=True, run_fn=fake_run, limit=5, analyse=False)
    second = run_study(plan, out, serial=True, run_fn=fake_run, analyse=False)
    third = run_study(plan, out, serial=True, run_fn=fake_run, analyse=False)
    assert len(first.computed) == 5 and len(second.computed) == 7 and third.computed == []
    assert set(first.computed).isdisjoint(second.computed)
    log = StudyStore(out).read_log()
    per_inv: dict[str, list[str]] = {}
    for e in log:
        if e["event"] == "run":
            per_inv.setdefault(e["invocation"], []).append(e["run_key"])
    keys = [k for ks in per_inv.values() for k in ks]
    assert len(keys) == len(set(keys)) == 12
    assert ref is not None and second.results is not None
    assert comparable(second.results).equals(comparable(ref))


def test_row_persisted_without_its_log_line_is_logged_once_on_resume(tmp_path: Path) -> None:
    """A kill between a row's atomic write and its log line (the window a SIGKILL can hit) leaves a
    row the log does not name; the next invocation neither recomputes it nor leaves it unlogged."""
    plan = plan_study(study(tmp_path))
    out = tmp_path / "out"
    first = run_study(plan, out, serial=True, run_fn=fake_run, limit=3, analyse=False)
    store = StudyStore(out)
    lost = first.computed[-1]
    lines = store.log_path.read_text().splitlines()
    kept = [ln for ln in lines if f'"run_key": "{lost}"' not in ln]
    assert len(kept) == len(lines) - 1
    store.log_path.write_text("\n".join(kept) + "\n")
    second = run_study(plan, out, serial=True, run_fn=fake_run, analyse=False)
    assert lost not in second.computed and second.already_done == 3 and len(second.computed) == 9
    runs = [e for e in store.read_log() if e["event"] == "run"]
    assert sorted(e["run_key"] for e in runs) == sorted(r.key for r in plan.runs)  # each exactly once
    (rec,) = [e for e in runs if e.get("recovered")]
    assert rec["run_key"] == lost and rec["invocation"] == first.invocation
    assert store.reconcile_log() == []  # nothing left to recover


def test_failing_runs_become_rows(tmp_path: Path) -> None:
    text = STUDY.replace('values = [{}, { "sensors.yaw_rate_sigma" = 0.01 }]',
                         'values = [{}, { "sensors.speed_sigma" = 0.3 }, { "sensors.speed_sigma" = 0.4 }]')
    text = text.replace('labels = ["speed", "speed+yaw"]', 'labels = ["a", "raises", "fails"]')
    text = text.replace('baseline = "speed"', 'baseline = "a"')
    plan = plan_study(study(tmp_path, text))
    rep = run_study(plan, tmp_path / "out", serial=True, run_fn=fake_run)
    df = rep.results
    assert df is not None and df.height == 18 and len(rep.failed) == 12
    raised = df.filter(pl.col("sensors") == "raises")
    assert set(raised["status"].to_list()) == {"failed"}
    assert all("RuntimeError: boom in the plant" in e for e in raised["error"].to_list())
    assert set(df.filter(pl.col("sensors") == "fails")["error"].to_list()) == {"diverged"}
    assert "## Failed runs" in (tmp_path / "out" / "summary.md").read_text()
    # --retry-failed recomputes exactly the failed ones (rows replaced, not duplicated)
    again = run_study(plan, tmp_path / "out", serial=True, run_fn=fake_run, retry_failed=True, analyse=False)
    assert sorted(again.computed) == sorted(rep.failed)
    assert len(list((tmp_path / "out" / "rows").glob("*.parquet"))) == 18


def test_different_study_same_out_refused(tmp_path: Path) -> None:
    plan = plan_study(study(tmp_path))
    out = tmp_path / "out"
    run_study(plan, out, serial=True, run_fn=fake_run, limit=2, analyse=False)
    before = {p.name: p.stat().st_mtime_ns for p in (out / "rows").iterdir()}
    other = plan_study(study(tmp_path, STUDY.replace("seeds = 3", "seeds = 2"), "other.toml"))
    with pytest.raises(BadInput, match="holds results of a different study"):
        run_study(other, out, serial=True, run_fn=fake_run)
    with pytest.raises(BadInput, match="different study"):  # same file, different overrides
        run_study(plan_study(tmp_path / "mach.toml", extra_overrides={"duration": 2.0}), out, serial=True,
                  run_fn=fake_run)
    assert {p.name: p.stat().st_mtime_ns for p in (out / "rows").iterdir()} == before


def fake_run_writing(cfg: RunConfig, out_root: Path | None, rrd: bool) -> FakeOutcome:
    """Like :func:`fake_run`, and writes ``out_root/<run-id>/`` as ``execute`` does."""
    from ftc_mj.sim.run import run_id_for

    o = fake_run(cfg, None, rrd)
    if out_root is not None:
        d = Path(out_root) / run_id_for(cfg)
        d.mkdir(parents=True)
        (d / "run.rrd").write_bytes(b"rrd" if rrd else b"")
        o.run_dir = d
    return o


@pytest.mark.parametrize("mode", ["failures", "all"])
def test_recordings_modes(tmp_path: Path, mode: str) -> None:
    text = STUDY.replace('values = [{}, { "sensors.yaw_rate_sigma" = 0.01 }]',
                         'values = [{}, { "sensors.speed_sigma" = 0.4 }]').replace("seeds = 3", "seeds = 1")
    plan = plan_study(study(tmp_path, text))
    out = tmp_path / "out"
    rep = run_study(plan, out, serial=True, run_fn=fake_run_writing, rrd=mode, analyse=False)  # type: ignore[arg-type]
    kept = sorted(p.name for p in (out / "runs").iterdir() if not p.name.startswith("."))
    df = rep.results
    assert df is not None
    expect = df if mode == "all" else df.filter(pl.col("status") != "ok")
    assert len(kept) == expect.height == (4 if mode == "all" else 2)
    assert all(Path(p).is_dir() for p in expect["run_dir"].to_list())
    # recomputing a run replaces its own folder instead of adding a "-2" copy
    run_study(plan, out, serial=True, run_fn=fake_run_writing, rrd=mode, retry_failed=True, analyse=False)  # type: ignore[arg-type]
    assert sorted(p.name for p in (out / "runs").iterdir() if not p.name.startswith(".")) == kept


def test_editing_findings_keeps_results(tmp_path: Path) -> None:
    p = study(tmp_path, STUDY + NO_FIGURES)
    out = tmp_path / "out"
    run_study(plan_study(p), out, serial=True, run_fn=fake_run, analyse=False)  # the edit's summary is checked
    p.write_text(textwrap.dedent(STUDY + NO_FIGURES).replace('baseline = "speed"', 'baseline = "speed+yaw"'))
    rep = run_study(plan_study(p), out, serial=True, run_fn=fake_run)
    assert rep.computed == [] and rep.already_done == 12
    summary = (out / "summary.md").read_text()
    assert "sensors = speed raises it from 0.05" in summary
    assert (out / "study.toml").read_text() == p.read_text()
    # [analysis] figures = false: the tables, no figure and no link to one
    assert "| sensors |" in summary and "![" not in summary and not (out / "figures").exists()


def test_bad_invocations_leave_results_untouched(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from typer.testing import CliRunner

    from ftc_mj.cli import app

    p = study(tmp_path, STUDY + NO_FIGURES)
    out = tmp_path / "out"
    run_study(plan_study(p), out, serial=True, run_fn=fake_run, limit=5)
    snapshot = {q: q.read_bytes() for q in out.rglob("*") if q.is_file()}
    bad_key = study(tmp_path, STUDY.replace('key = "estimator.kind"', 'key = "estimator.knd"'), "bad.toml")
    empty = study(tmp_path, STUDY.replace('values = ["ekf", "ukf"]', "values = []"), "empty.toml")
    other = study(tmp_path, STUDY.replace("seeds = 3", "seeds = 4"), "other.toml")
    cases = [
        ([str(bad_key)], "axes[1].key (estimator.knd): unknown key 'knd' in estimator"),
        ([str(empty)], "axes[1].values: empty axis"),
        ([str(p), "--address", "tcp://host-without-port"], "expected tcp://HOST:PORT"),
        ([str(p), "--address", "tcp://127.0.0.1:1"], "cannot reach a dask scheduler within 6 s"),
        ([str(other)], "holds results of a different study"),
    ]
    # the refused port is retried until dask's connect timeout: 0.5 s instead of 5 s here (the one
    # line still names the handshake's 6 s; the refusal, not the wait, is what is checked)
    monkeypatch.setattr("ftc_mj.study.cluster.CONNECT_TIMEOUT_S", 0.5)
    runner = CliRunner()
    for args, expect in cases:
        res = runner.invoke(app, ["study", *args, "--out", str(out), "-q"])
        assert res.exit_code == 2, (args, res.output)
        assert res.output.count("\n") == 1 and res.output.startswith("ftc-mj: error: ") and expect in res.output
    assert {q: q.read_bytes() for q in out.rglob("*") if q.is_file()} == snapshot
