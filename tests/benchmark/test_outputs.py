"""The bench's outputs from a results table (no simulation): draws.parquet has every drawn factor, one row a
draw; scores.parquet one row per method × draw with the settings digest and the package version; the report
is a leaderboard on the test split only; --publish writes docs/benchmark.md with the distributions."""

from __future__ import annotations

import polars as pl
import pytest

from ftc_mj import __version__
from ftc_mj.benchmark.methods import load_methods
from ftc_mj.benchmark.report import write_outputs
from ftc_mj.benchmark.run import plan_bench
from ftc_mj.reports.benchmark_page import publish


def _results(bp) -> pl.DataFrame:
    rows = []
    for r in bp.plan.runs:
        good = r.labels["method"] == "safe" or r.labels["draw"] % 2 == 0
        rows.append({"run_key": r.key, "run_index": r.index, **r.labels, "status": "ok", "outcome": "on the path",
                     "success": good, "tipped": False, "false_alarm": False, "contouring_max": 0.1 if good else 2.0,
                     "contouring_rms": 0.05, "detection_delay": 0.8, "isolation": "correct", "reconfig_delay": 1.0,
                     "lorden_delay_bound": 0.2, "radius_pcrb_R": 0.01, "radius_error_R": 0.02, "ts_t": [0.0, 0.5]})
    return pl.DataFrame(rows)


@pytest.mark.parametrize("split", ["dev", "test"])
def test_outputs_of_a_bench(tmp_path, split):
    bp = plan_bench(load_methods(["safe", "feedback-off"]), split, 4)
    path = write_outputs(bp, _results(bp), tmp_path, compare=0)
    assert path.name == ("leaderboard.md" if split == "test" else "dev-report.md")
    draws = pl.read_parquet(tmp_path / "draws.parquet")
    assert draws.height == 4 and {"seed", "fault_class", "tyre_friction", "payload_mass", "path", "speed_sigma",
                                  "fault1_onset", "gyro_sigma"} <= set(draws.columns)
    scores = pl.read_parquet(tmp_path / "scores.parquet")
    assert scores.height == 8 and not any(c.startswith("ts_") for c in scores.columns)
    assert set(scores["package_version"]) == {__version__}
    assert dict(zip(scores["method"], scores["method_digest"], strict=True)) == {m.name: m.digest for m in bp.methods}
    text = path.read_text()
    assert "does the safe policy beat feedback off" in text and "| safe − feedback-off | success | 4 |" in text
    assert (tmp_path / "figures" / "success_by_class.png").stat().st_size > 0
    docs = tmp_path / "docs"
    docs.mkdir()
    page = publish(docs, path, tmp_path, ["bench", "safe", "feedback-off", "--split", split], "ftc-v1").read_text()
    assert "| tyre friction | uniform 0.7–1.2 |" in page and ("Not generated yet" in page) == (split == "dev")
    assert (docs / "figures" / "benchmark" / "success_by_class.png").is_file()


def test_the_report_says_which_invocations_computed_the_runs(tmp_path) -> None:
    """Only invocations that computed runs are named, each with its runs, wall time, date and commit (when
    recorded); an invocation that computed nothing (a resumed, finished bench) is left out."""
    from ftc_mj.benchmark.report import computed_line
    from ftc_mj.study.store import StudyStore

    assert computed_line(tmp_path) == "No run was computed in this output folder's log."
    store = StudyStore(tmp_path)
    store.log("end", invocation="a", computed=12, failed=0, wall_time_s=30.4)
    store.log("end", invocation="b", computed=0, failed=0, wall_time_s=2.0, source=None)
    store.log("end", invocation="c", computed=3, failed=0, wall_time_s=9.6, source="abc1234")
    line = computed_line(tmp_path)
    assert line.startswith("Computed by 12 runs in 30 s on ") and "; 3 runs in 10 s on " in line
    assert line.count(" runs in ") == 2 and line.count("at commit") == 1 and "at commit abc1234" in line


def test_the_source_revision_names_a_commit_or_nothing() -> None:
    """A short hash (optionally ``+modified``) in a git checkout, ``None`` elsewhere; never an exception."""
    import re

    from ftc_mj.identity import source_revision

    rev = source_revision()
    assert rev is None or re.fullmatch(r"[0-9a-f]{7,40}(\+modified)?", rev)


def test_a_question_is_answered_only_by_an_interval_that_excludes_zero() -> None:
    """The verdict rule on constructed pairs: ``a`` succeeds on 30 more of 60 draws (interval above 0) → yes;
    the reverse → no; one draw of difference in 60 (interval contains 0) → not shown; for the contouring error
    (lower is better) the sides swap."""
    from ftc_mj.benchmark.report import answers
    from ftc_mj.benchmark.stats import paired

    def rows(a_success: list[bool], b_success: list[bool], a_err: float, b_err: float) -> list[dict]:
        out = []
        for i, (sa, sb) in enumerate(zip(a_success, b_success, strict=True)):
            out += [{"draw": i, "method": "safe", "success": sa, "contouring_max": a_err + 0.01 * i},
                    {"draw": i, "method": "feedback-off", "success": sb, "contouring_max": b_err + 0.01 * i}]
        return out

    from ftc_mj.benchmark.report import verdict

    better = rows([True] * 60, [False] * 30 + [True] * 30, 0.1, 2.0)
    assert verdict(paired(better, "success", "safe", "feedback-off"), True) == "yes"
    assert verdict(paired(better, "contouring_max", "safe", "feedback-off"), False) == "yes"
    assert verdict(paired(better, "success", "feedback-off", "safe"), True) == "no"
    assert verdict(paired(better, "contouring_max", "feedback-off", "safe"), False) == "no"
    tie = rows([True] * 59 + [False], [True] * 60, 1.0, 1.0)
    assert verdict(paired(tie, "success", "safe", "feedback-off"), True) == "not shown"
    text = "\n".join(answers(better, ["safe", "feedback-off"]))
    assert "Success: **yes** (safe − feedback-off +0.5" in text and "30 draws won / 0 lost of 60" in text
    assert answers(better, ["safe", "paper-like"]) == []
