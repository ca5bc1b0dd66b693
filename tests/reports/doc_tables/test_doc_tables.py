"""The published tables from a study output folder (``ftc-mj study NAME --report``) on small fake results:
the numbers each cell states, the sibling robust-FTC folder, and the one-line refusals."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import polars as pl
import pytest
from typer.testing import CliRunner

from ftc_mj.cli import app
from ftc_mj.errors import BadInput
from ftc_mj.reports.doc_tables import doc_tables, reconfiguration, robust_ftc


def _reconfiguration(out: Path) -> None:
    rows = [{"fault": sc, "sensors": sens, "policy": pol, "seed": seed, "status": "ok",
             "cross_track_final": -0.5 * (seed + 1), "tipped": seed == 1, "reconfig_handover_delay": 1.0 + seed,
             "omega_at_limit_s": 2.0, "cross_track_max_recovered": 0.25 * (seed + 1),
             "liftoff_time_post_transient_s": None}
            for sc, sens, pol, seed in itertools.product(("s2",), ("speed",), ("none", "safe"), (0, 1))]
    out.mkdir(parents=True)
    pl.DataFrame(rows).write_parquet(out / "results.parquet")


def test_reconfiguration_rows_state_mean_worst_and_counts(tmp_path: Path) -> None:
    _reconfiguration(tmp_path / "reconfiguration")
    text = reconfiguration.report(tmp_path / "reconfiguration")
    lines = text.splitlines()
    assert lines[0] == "4 runs (0 not ok), seeds [0, 1]"
    assert "| 2 | speed | none | 0.375 (0.5) | 0.75 | 2.0 | 1/2 | — | — |" in lines
    assert "| 2 | speed | safe | 0.375 (0.5) | 0.75 | 2.0 | 1/2 | — | 1.50 (2.00) |" in lines


def _robust(out: Path, strategies: tuple[str, ...], seeds: tuple[int, ...]) -> None:
    rows = [{"fault": "s2", "plant": "mujoco", "sensing": "speed", "strategy": st, "seed": seed, "status": "ok",
             "cross_track_max_recovered": 1.0 + seed if st == "safe" else 0.5, "cross_track_final": -0.25,
             "cross_track_rms": 0.125, "cross_track_rms_settled": 0.0625, "tipped": False, "solver_failures": 0}
            for st, seed in itertools.product(strategies, seeds)]
    out.mkdir(parents=True)
    pl.DataFrame(rows).write_parquet(out / "results.parquet")


def test_robust_ftc_reads_both_studies_and_clips_the_interval_at_zero(tmp_path: Path) -> None:
    _robust(tmp_path / "robust_ftc", ("safe",), (0, 1, 2))
    _robust(tmp_path / "robust_ftc_fixed", ("nominal",), (11, 12))
    lines = robust_ftc.report(tmp_path / "robust_ftc").splitlines()
    assert lines[2] == "| 2 | mujoco | any | nominal | 1 | 0.50 | 0.25 | 0.06 | 0/1 | 0 |"
    # mean 2, Student-t half-width 4.30 · 1/√3 = 2.48: the lower end clipped at 0, worst seed 3
    assert lines[3] == "| 2 | mujoco | speed | safe | 3 | 2.00 [0.00, 4.48] (3.00) | 0.25 [0.25, 0.25] (0.25) | " \
                       "0.06 [0.06, 0.06] (0.06) | 0/3 | 0 |"


def test_findings_section_and_refusals(tmp_path: Path) -> None:
    out = tmp_path / "severity"
    out.mkdir()
    (out / "plan.json").write_text(json.dumps({"study": "severity"}))
    (out / "summary.md").write_text("# Study\n\nRuns: 4 of 4 planned have results.\n\n## Findings\n\n- a finding.\n\n"
                                    "## By `x`\n")
    assert doc_tables("severity", out) == "#### `severity` — generated findings (runs: 4 of 4 planned have " \
                                          "results)\n\n- a finding.\n"
    with pytest.raises(BadInput, match="--report: study 'no_such_study' has no published table"):
        doc_tables("no_such_study", out)
    with pytest.raises(BadInput, match="--report: .* is not a study output folder"):
        doc_tables("severity", tmp_path / "missing")


def test_cli_report_prints_and_writes_the_tables(tmp_path: Path) -> None:
    _reconfiguration(tmp_path / "reconfiguration")
    (tmp_path / "reconfiguration" / "summary.md").write_text("Runs: 4.\n\n## Findings\n\n- none.\n")
    res = CliRunner().invoke(app, ["study", "reconfiguration", "--out", str(tmp_path / "reconfiguration"), "--report"])
    assert res.exit_code == 0, res.output
    assert "| 2 | speed | safe | 0.375 (0.5) |" in res.output and "generated findings" in res.output
    assert (tmp_path / "reconfiguration" / "doc_tables.md").read_text() == res.output
    assert not (tmp_path / "reconfiguration" / "rows").exists()  # nothing ran


def test_window_stats_of_the_full_trace() -> None:
    from ftc_mj.study.worker import window_stats

    t = np.arange(0.0, 4.01, 0.5)
    trace = {"t": t, "x": t - 2.0}
    specs = [{"name": "m", "column": "x", "stat": "mean", "start": 1.0, "end": 3.0},
             {"name": "s", "column": "x", "stat": "std", "start": 1.0, "end": 3.0, "end_inclusive": False},
             {"name": "a", "column": "x", "stat": "max_abs", "start": 0.0},
             {"name": "none", "column": "x", "stat": "mean", "start": 5.0}]
    got = window_stats(trace, specs)
    assert got["m"] == 0.0 and got["a"] == 2.0 and got["none"] is None
    assert got["s"] == pytest.approx(float(np.std([-1.0, -0.5, 0.0, 0.5])))  # 3 s excluded


def test_rate_bound_and_physical_plant_tables(tmp_path: Path) -> None:
    from ftc_mj.reports.doc_tables import physical_plant, rate_bound

    rows = []
    for (yaw, rp, fb), form, seed in itertools.product(rate_bound.CONFIGS, ("old", "new"), (0, 1)):
        rows.append({"sensors": "speed+yaw" if yaw else "speed", "cost": rp, "feedback": fb, "formulation": form,
                     "seed": seed, "status": "ok", "yaw_rate_std_1_10": 0.01 * (seed + 1),
                     "command_total_variation_per_s": 10.0 if form == "old" else 2.0,
                     "command_at_rate_limit_s": 0.0, "command_step_max": 0.5, "cross_track_max_abs_after_15": 1.0})
    (tmp_path / "rb").mkdir()
    pl.DataFrame(rows).write_parquet(tmp_path / "rb" / "results.parquet")
    lines = rate_bound.report(tmp_path / "rb").splitlines()
    assert lines[1] == "Seed 0:"
    assert lines[5] == "| speed | paper | off | 0.01 / 0.01 | 10 / 2 | 0 / 0 | 0.5 / 0.5 | 1 / 1 |"
    assert lines[14] == "Means over seeds 0–1 (± Student-t 95 % half-width):"
    # two seeds 0.01, 0.02: half-width t(0.975, 1) · 0.00707 / √2 = 0.0635
    assert lines[18].startswith("| speed | paper | off | 0.015 ± 0.064 / 0.015 ± 0.064 | 10 ± 0 / 2 ± 0 |")
    pp = [{"plant": plant, "sensors": "speed", "cost": 0.0, "feedback": False, "seed": 0, "R_L_hat_mean_15_40": 1.004,
           "R_R_hat_mean_15_40": 2.0, "cross_track_max_abs_after_15": 0.31, "yaw_rate_std_1_10": 0.0123,
           "detection_delay": None, "isolated_wheel": None, "command_total_variation_per_s": 12.34,
           "plant_out_of_domain_fraction": 0.25} for plant in ("kinematic", "mujoco")]
    (tmp_path / "pp").mkdir()
    pl.DataFrame(pp).write_parquet(tmp_path / "pp" / "results.parquet")
    lines = physical_plant.report(tmp_path / "pp").splitlines()
    assert lines[2:] == ["| mujoco | speed | paper | off | 1.00 | 2.00 | 0.31 | 0.012 | — | — | 12.3 | 25% |",
                         "| kinematic | speed | paper | off | 1.00 | 2.00 | 0.31 | 0.012 | — | — | 12.3 | 25% |"]


def test_pcrb_constant_truth_table_has_the_published_digits() -> None:
    """The nominal-circle table of docs/fdi.md (no run needed): the same digits."""
    from ftc_mj.reports.doc_tables.pcrb import constant_truth_table

    published = [("0.0356", "0.0261", "0.733"), ("0.0371", "0.0272", "0.732"), ("0.0513", "0.0375", "0.732"),
                 ("0.0035", "0.0032", "0.908"), ("0.0513", "0.0376", "0.732")]
    rows = constant_truth_table()[2:]
    assert [tuple(r.strip("| ").split(" | ")[2:]) for r in rows] == published


def _columns(line: str) -> int:
    """Cells of a Markdown table line (``|`` not escaped by a backslash delimit them)."""
    import re

    return len(re.split(r"(?<!\\)\|", line)) - 2


def test_pathfollow_table_states_each_cell_once_with_its_numbers(tmp_path: Path) -> None:
    """Two seeds per cell of a small pathfollow study: one row per (scenario, sensing, policy, controller) run,
    in the table's order, with 9 cells; the mean and worst of the recovered contouring error and the tip-over
    count are the data's."""
    from ftc_mj.reports.doc_tables import pathfollow

    rows = [{"fault": sc, "cell": f"speed/{pol}/{ctl}", "seed": seed, "status": "ok",
             "contouring_max_recovered": 0.2 * (seed + 1), "liftoff_time_post_transient_s": None,
             "tipped": seed == 1 and pol == "safe", "omega_at_limit_s": 1.0, "speed_ratio_final": 1.0,
             "cross_track_max": 0.5, "cross_track_max_settled": 0.05, "speed_mean_after_fault": 10.0}
            for sc, pol, ctl, seed in itertools.product(("s2", "s4"), ("none", "safe"), ("nmpc", "pf-nmpc"), (0, 1))]
    out = tmp_path / "pathfollow"
    out.mkdir()
    pl.DataFrame(rows).write_parquet(out / "results.parquet")
    table = pathfollow.report(out).split("\n\n")[1].split("\n\nnmpc:")[0].splitlines()
    assert table[1] == "|---|" + "---|" * 8 and all(_columns(ln) == 9 for ln in table), table
    body = table[2:]
    assert [ln.split(" | ")[:4] for ln in body] == [[f"| {sc}", "speed", pol, ctl] for sc in "24"
                                                    for pol in ("none", "safe") for ctl in ("nmpc", "pf-nmpc")]
    assert body[2] == "| 2 | speed | safe | nmpc | 0.3 ± 1.3 (0.4) | — | 1/2 | 1 ± 0 (1) | 1 ± 0 (1) |"


def test_fdi_tables_merge_identical_filters_and_insert_their_column(tmp_path: Path, monkeypatch) -> None:
    """Filters whose rows are identical share one row (``EKF, UKF``); the filters column is the third of
    every row; table 1 has 12 cells per line, table 2 five plus one per rule."""
    from types import SimpleNamespace

    from ftc_mj.reports.doc_tables import fdi

    cells = [SimpleNamespace(key={"plant": "mujoco", "sensors": "speed", "estimator": e})
             for e in ("ekf", "ukf", "imm-ekf")]

    def rows(cell: SimpleNamespace) -> tuple[list[tuple[str, ...]], list[tuple[str, ...]]]:
        x = "2" if cell.key["estimator"] == "imm-ekf" else "1"
        return ([("mujoco", "speed", "glr", x, "> 30 (0)", "—", "—", "—", "1/2", "1/2", "0/2")],
                [("mujoco", "speed", "50 %", "0.3", "none", "none", "none", x)])

    monkeypatch.setattr(fdi, "load_cells", lambda out, axis: (cells, None))
    monkeypatch.setattr(fdi, "cell_rows", rows)
    t1, t2 = fdi.report(tmp_path).split("\n\n")
    t1, t2 = t1.splitlines(), t2.splitlines()
    assert all(_columns(ln) == 12 for ln in t1) and all(_columns(ln) == 5 + len(fdi.RULES) for ln in t2)
    assert t1[2:] == ["| mujoco | speed | EKF, UKF | glr | 1 | > 30 (0) | — | — | — | 1/2 | 1/2 | 0/2 |",
                      "| mujoco | speed | IMM-EKF | glr | 2 | > 30 (0) | — | — | — | 1/2 | 1/2 | 0/2 |"]
    assert t2[2:] == ["| mujoco | speed | EKF, UKF | 50 % | 0.3 | none | none | none | 1 |",
                      "| mujoco | speed | IMM-EKF | 50 % | 0.3 | none | none | none | 2 |"]
