"""``ftc-mj paper`` end to end on a few short real runs: the single-seed quick look and the verdicts
over seeds (the same study pipeline: resume, a failed run, exit codes), the matrix list, bad input."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pyarrow.parquet as pq
from typer.testing import CliRunner

from ftc_mj.cli import app
from ftc_mj.rerun.record import REQUIRED_COLUMNS

runner = CliRunner()
QUICK = ["--only", "s2-ukf-*fb-nmpc",  # NMPC feedback off and on
         "--only", "s2-ukf-safe-yaw-nmpc-rp",  # and one run of the reconfiguration-policy axis
         "--duration", "2", "--jobs", "1"]


def test_paper_list_prints_the_matrix() -> None:
    res = runner.invoke(app, ["paper", "--list", "--no-extras"])
    assert res.exit_code == 0, res.output
    assert len(res.output.strip().splitlines()) == 38
    res = runner.invoke(app, ["paper", "--list"])
    assert len(res.output.strip().splitlines()) == 38 + 2 + 18 + 11  # + literal IMM, policy and path-following axes


def test_paper_bad_input_exits_2_and_writes_nothing(tmp_path: Path) -> None:
    out = tmp_path / "o"
    for args in (["--jobs", "0"], ["--only", "no-such-label"], ["--duration", "-1"], ["--seeds", "0"],
                 ["--seed-set", "dev", "--seeds", "11"], ["--quick", "--seeds", "3"], ["--quick", "--tune"],
                 ["--quick", "--baseline", "docs"], ["--rrd", "compare"],
                 ["--fresh"], ["--baseline", str(tmp_path / "nothing")],
                 ["--report-only", "--only", "s2-ukf-fb-nmpc", "--seeds", "2"]):
        res = runner.invoke(app, ["paper", "--out", str(out), *args])
        assert res.exit_code == 2, (args, res.output)
        assert not out.exists()
    f = tmp_path / "file"
    f.write_text("x")
    assert runner.invoke(app, ["paper", "--out", str(f), "--duration", "1"]).exit_code == 2


def test_quick_look_is_the_study_with_seed_0_and_retries_a_failed_run(tmp_path: Path, monkeypatch) -> None:
    """The quick look end to end (in-process runs): a failed run gives exit 1 with everything still
    written; the next invocation recomputes only that run and reuses the others; --report-only
    rebuilds the report from the persisted rows."""
    from ftc_mj.paper import derived

    real = derived.report_metrics

    def broken(cfg, trace):  # a shape bug in one run's metrics: the run fails, it is not a fallback
        if cfg.reconfiguration.policy == "direct":
            raise TypeError("broken metric")
        return real(cfg, trace)

    monkeypatch.setattr(derived, "report_metrics", broken)
    out = tmp_path / "paper"
    res = runner.invoke(app, ["paper", "--quick", "--out", str(out), *QUICK])
    assert res.exit_code == 1, res.output
    rows = {r["label"]: r for r in csv.DictReader(open(out / "summary.csv"))}
    bad = rows["s2-ukf-fb-nmpc"]
    assert bad["status"] == "failed" and "TypeError: broken metric" in bad["error"]
    assert (out / "claims.md").is_file()
    assert json.loads((out / "paper_run.json").read_text())["failed"] == ["s2-ukf-fb-nmpc"]
    monkeypatch.setattr(derived, "report_metrics", real)
    res = runner.invoke(app, ["paper", "--quick", "--out", str(out), *QUICK])
    assert res.exit_code == 0, res.output
    assert "single-seed quick look" in res.output
    rows = list(csv.DictReader(open(out / "summary.csv")))
    assert {r["label"] for r in rows} == {"s2-ukf-nofb-nmpc", "s2-ukf-fb-nmpc", "s2-ukf-safe-yaw-nmpc-rp"}
    for r in rows:
        assert r["status"] == "ok" and r["seed"] == "0"
        assert r["scenario"] == "scenario2" and r["controller"] == "nmpc"
        assert r["policy"] == ("none" if "nofb" in r["label"] else "safe" if "safe" in r["label"] else "direct")
        assert float(r["radius_rmse_L"]) >= 0 and r["solve_time_ms_median"] != ""
        run_dir = Path(r["run_dir"])
        for name in ("config.toml", "trace.parquet", "metrics.json", "events.json"):
            assert (run_dir / name).is_file(), (run_dir, name)
        assert run_dir.parent == out / "runs" and not (run_dir / "run.rrd").exists()  # recordings on request
        columns = pq.read_schema(run_dir / "trace.parquet").names  # the columns the figures need
        assert set(REQUIRED_COLUMNS) <= set(columns) and "reconfig_state" in columns and "nis" not in columns
    md = (out / "claims.md").read_text()
    assert "## Verdicts" in md and "## Thresholds" in md and "single-seed quick look" in md
    doc = json.loads((out / "claims.json").read_text())
    assert doc["mode"] == "single-seed" and doc["seeds"] == [0]
    figs = sorted(p.name for p in (out / "figures").glob("*.png"))
    assert "innovations_s2.png" in figs and "trajectory_s2.png" in figs and "policies.png" in figs
    info = json.loads((out / "paper_run.json").read_text())
    assert info["runs"] == 3 and info["failed"] == [] and info["reused"] == 2 and info["mode"] == "quick"
    assert not list(out.glob(".*.tmp"))
    # the report alone, rebuilt from the persisted rows of the same selection, with the claims' comparisons
    (out / "claims.md").unlink()
    res = runner.invoke(app, ["paper", "--quick", "--out", str(out), "--report-only", "--rrd", "compare", *QUICK])
    assert res.exit_code == 0, res.output
    assert (out / "claims.md").is_file() and (out / "compare" / "claim-1.rrd").is_file()
    info = json.loads((out / "paper_run.json").read_text())
    assert info["report_only"] is True and info["reused"] == 3


def test_quick_look_recordings_on_request_keep_the_whole_trace(tmp_path: Path) -> None:
    out = tmp_path / "paper"
    res = runner.invoke(app, ["paper", "--quick", "--out", str(out), "--rrd", "runs", "--only", "s2-ukf-nofb-nmpc",
                              "--duration", "1", "--jobs", "1"])
    assert res.exit_code == 0, res.output
    (run_dir,) = (out / "runs").iterdir()
    assert (run_dir / "run.rrd").is_file() and "nis" in pq.read_schema(run_dir / "trace.parquet").names
    assert "--rrd runs" in json.loads((out / "paper_run.json").read_text())["command"]


SEEDED = ["--only", "s2-ukf-nofb-nmpc", "--only", "s2-ukf-fb-nmpc", "--seeds", "2", "--duration", "2", "--jobs", "1"]


def test_seeded_paper_judges_over_seeds_resumes_and_fails_a_failed_run(tmp_path: Path, monkeypatch) -> None:
    from ftc_mj.paper import derived

    real = derived.report_metrics

    def broken(cfg, trace):  # a shape bug in one run's metrics: the run fails, it is not a fallback
        if cfg.seed == 1001 and cfg.reconfiguration.policy == "direct":
            raise TypeError("broken metric")
        return real(cfg, trace)

    monkeypatch.setattr(derived, "report_metrics", broken)
    out = tmp_path / "paper"
    res = runner.invoke(app, ["paper", "--out", str(out), *SEEDED])
    assert res.exit_code == 1, res.output
    assert "s2-ukf-fb-nmpc (seed 1001)" in res.output
    rows = list(csv.DictReader(open(out / "summary.csv")))
    assert sorted((r["label"], r["seed"]) for r in rows) == [("s2-ukf-fb-nmpc", "1000"), ("s2-ukf-fb-nmpc", "1001"),
                                                            ("s2-ukf-nofb-nmpc", "1000"), ("s2-ukf-nofb-nmpc", "1001")]
    bad = next(r for r in rows if r["label"] == "s2-ukf-fb-nmpc" and r["seed"] == "1001")
    assert bad["status"] == "failed" and "TypeError: broken metric" in bad["error"]
    doc = json.loads((out / "claims.json").read_text())
    assert doc["mode"] == "seeded" and doc["seeds"] == [1000, 1001] and doc["seed_set"] == "held-out"
    c1 = next(c for c in doc["claims"] if c["id"] == "1")
    fb = next(ch for ch in c1["checks"] if ch["text"].startswith("UKF fb on declares"))
    # 2 s runs end before the 10 s puncture: every seed is n/a, except the failed run, which fails
    assert (fb["passed"], fb["applicable"], fb["na"], fb["failing_seeds"]) == (0, 1, 1, [1001])
    assert fb["na_reasons"] == {"a fault onset lies after the end of the run": 1}
    md = (out / "claims.md").read_text()
    assert "verdicts over seeds" in md and "held-out seeds 1000, 1001" in md and "validation run" in md
    assert "Not applicable" in md and "| 0/1 |" in md
    # the same command resumes: nothing is recomputed (the failed row stays failed)
    monkeypatch.setattr(derived, "report_metrics", real)
    res = runner.invoke(app, ["paper", "--out", str(out), *SEEDED])
    assert res.exit_code == 1 and "[1/" not in res.output
    res = runner.invoke(app, ["paper", "--out", str(out), "--report-only", *SEEDED[:-2]])
    assert res.exit_code == 1, res.output
    assert json.loads((out / "paper_run.json").read_text())["mode"] == "seeded"
