"""``not judged`` is explained wherever the outcomes are listed: ``ftc-mj metrics`` (docs/metrics.md) and the
run summary name both causes — a run that did not complete, and a completed run that ended before the window
its outcome is judged on (a 15 s run of a fault at 10 s)."""

from __future__ import annotations

from typer.testing import CliRunner

from ftc_mj.cli import app
from ftc_mj.metrics.outcome import NOT_JUDGED, physical_outcome
from ftc_mj.metrics.run import RECOVERY_S
from ftc_mj.sim.summary import outcome_lines


def test_metrics_lists_both_causes_of_not_judged() -> None:
    line = next(ln for ln in CliRunner().invoke(app, ["metrics"]).stdout.splitlines() if ln.startswith("outcome "))
    assert "not judged (status not ok, or the run ended before the window" in line
    assert f"{RECOVERY_S:g} s after the first fault onset" in line


def test_a_run_not_judged_says_why_in_its_summary() -> None:
    """Status ok but no cross-track error after the recovery window (the run ended first), and a failed run:
    both ``not judged``, and the summary prints what that means; the completed one's rule says that a longer
    duration judges it."""
    short = {"status": "ok", "tipped": False, "cross_track_max_recovered": None}
    failed = {"status": "failed", "tipped": False}
    for m in (short, failed):
        m.update(physical_outcome(m))
        assert m["outcome"] == "not judged"
        assert NOT_JUDGED in [text for text, _style in outcome_lines(m)]
    assert "longer duration" in short["outcome_rule"]
    assert "longer duration" in NOT_JUDGED and "did not complete" in NOT_JUDGED
