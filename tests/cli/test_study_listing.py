"""``ftc-mj studies`` shows each built-in study's run count, whole description (wrapped) and the
analyses that apply; ``ftc-mj study NAME --list`` prints the plan and runs nothing."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from ftc_mj.cli import app
from ftc_mj.resources import builtin_studies
from ftc_mj.study.listing import fdi_curves_apply
from ftc_mj.study.plan import plan_study
from ftc_mj.study.store import StudyStore


def test_studies_lists_counts_whole_descriptions_and_analyses(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each block states what the study's plan holds, and listing resolves no run: the command outlines the
    studies (:func:`~ftc_mj.study.plan.outline_study`) instead of validating and hashing thousands of run
    configs (a resolved run here fails the command); the plans are made afterwards to check the blocks."""
    import ftc_mj.study.plan as plan_module

    monkeypatch.chdir(tmp_path)  # no study folders: no measured durations

    def resolving(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("ftc-mj studies resolved a run config")

    monkeypatch.setattr(plan_module, "run_key", resolving)
    monkeypatch.setattr(plan_module, "validate_config", resolving)
    res = CliRunner().invoke(app, ["studies"])
    monkeypatch.undo()
    plans = {name: plan_study(name) for name in builtin_studies()}
    assert res.exit_code == 0, res.output
    blocks = {}
    for line in res.stdout.splitlines():
        if not line.startswith(" "):
            name = line.split(":", 1)[0]
            blocks[name] = [line]
        else:
            blocks[name].append(line.strip())
    assert list(blocks) == list(builtin_studies())
    for name, lines in blocks.items():
        plan = plans[name]
        assert lines[0].startswith(f"{name}: {len(plan.runs)} runs, "), lines[0]
        text = " ".join(lines[1:])
        assert " ".join(plan.spec.description.split()) in text, name  # whole, not cut mid-sentence
        assert "analyses: OUT/summary.md" in text
        assert ("ftc-mj fdi-curves OUT" in text) == fdi_curves_apply(plan), name
        assert all(len(ln) <= 100 for ln in res.stdout.splitlines() if " " in ln.strip()), name


@pytest.mark.parametrize(("study", "applies"), [("fdi", True), ("fdi_arl0", True), ("severity", False),
                                                ("reconfiguration", False)])
def test_fdi_curves_is_offered_only_where_it_can_run(study: str, applies: bool) -> None:
    """fdi-curves needs a severity axis, logged decision statistics and no-fault runs (``severity`` has
    no no-fault runs: the command would fail after the user picked it)."""
    assert fdi_curves_apply(plan_study(study)) is applies


def test_studies_give_the_expected_duration_at_the_rate_measured_here(tmp_path: Path,
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """A study folder whose log records 12 runs computed in 60 s: 12 runs/min, so the 108 runs of
    ``severity`` take about 9 min; a study without a folder gets no guess."""
    monkeypatch.chdir(tmp_path)
    plan = plan_study("severity")
    StudyStore(tmp_path / "runs/out/studies" / plan.spec.name).log("end", computed=12, wall_time_s=60.0)
    res = CliRunner().invoke(app, ["studies"])
    heads = {ln.split(":")[0]: ln for ln in res.stdout.splitlines() if not ln.startswith(" ")}
    assert heads["severity"] == ("severity: 108 runs, 36 min simulated; about 9 min at the 12 runs/min measured in "
                                 "runs/out/studies/severity")
    assert "measured" not in heads["fdi"]


def test_study_list_prints_the_plan_and_runs_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    res = CliRunner().invoke(app, ["study", "severity", "--list", "--seeds", "1"])
    assert res.exit_code == 0, res.output
    head, *rows = res.stdout.splitlines()
    plan = plan_study("severity", seeds=1)
    assert head.startswith(f"# severity: {len(plan.runs)} runs = severity (9) x wheel (2) x estimator (3) x 1 seed")
    assert len(rows) == len(plan.runs) == 54
    index, key, labels, seed = rows[5].split("\t")
    assert (int(index), key, seed) == (5, plan.runs[5].key, f"seed={plan.runs[5].seed}")
    assert labels == " ".join(f"{k}={v}" for k, v in plan.runs[5].labels.items())
    assert list(tmp_path.iterdir()) == []  # no output folder, nothing run
