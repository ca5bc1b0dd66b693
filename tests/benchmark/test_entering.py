"""Entering the benchmark: a misspelt method gets a "did you mean", ``bench --help`` shows the method-file
format, a method file's plug-ins are found beside it, replay commands name what works from any folder, and the
terminal summary gives each method's success with its interval."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import polars as pl
import pytest
from typer.testing import CliRunner

from ftc_mj import registry
from ftc_mj.benchmark.methods import MethodFile, load_method
from ftc_mj.benchmark.report import replay_command, summary_lines
from ftc_mj.benchmark.run import plan_bench
from ftc_mj.cli import app
from ftc_mj.errors import BadInput

ROOT = Path(__file__).resolve().parents[2]


def test_a_misspelt_method_gets_a_did_you_mean(tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["bench", "saf", "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and "(did you mean 'safe'?)" in res.output and not (tmp_path / "o").exists()


def test_bench_help_shows_every_field_of_a_method_file() -> None:
    text = CliRunner().invoke(app, ["bench", "--help"], terminal_width=200).stdout
    for key in MethodFile.model_fields:
        assert f"{key} =" in text or f"[{key}]" in text, key
    assert "examples/blend_policy.toml" in text


def test_a_method_files_plugins_are_found_beside_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """From another folder, the example method loads (its plug-in module imported from the file's folder) and
    the folder reaches the local workers through PYTHONPATH."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p not in ("", str(tmp_path))])
    monkeypatch.setenv("PYTHONPATH", "")
    monkeypatch.delitem(sys.modules, "blend_policy", raising=False)
    try:
        m = load_method(str(ROOT / "examples" / "blend_policy.toml"))
    finally:  # the rest of the session's registry as it was
        if "blend" in registry.policies.names():
            registry.policies.unregister("blend")
        registry._loaded_plugins.discard("blend_policy")
    assert m.name == "blend-half" and m.plugins == ("blend_policy",)
    assert str(ROOT / "examples") in sys.path and str(ROOT / "examples") in os.environ["PYTHONPATH"]
    assert m.argument == str((ROOT / "examples" / "blend_policy.toml").resolve())


def test_replay_commands_name_the_method_file_and_the_definition(tmp_path: Path) -> None:
    """A built-in by name; a method file by its absolute path (a command that works from any folder)."""
    src = tmp_path / "my method.toml"  # a space: quoted in the command
    src.write_text('name = "mine"\n[settings]\n"reconfiguration.policy" = "direct"\n')
    mine = load_method(str(src))
    bp = plan_bench([mine, load_method("safe")], "dev", 1, start=3, healthy=True)
    tail = "--split dev --start 3 --draws 1 --benchmark ftc-v2 --healthy"  # the version named: a later default
    assert replay_command(bp, "safe", 3) == f"ftc-mj bench safe {tail}"  # cannot change what it replays
    assert replay_command(bp, "mine", 3) == f"ftc-mj bench '{src.resolve()}' {tail}"
    with pytest.raises(BadInput, match="no such built-in method"):
        load_method("mine")  # the bare name: what the report printed before


def test_the_terminal_summary_gives_success_with_its_interval() -> None:
    bp = plan_bench([load_method("safe"), load_method("feedback-off")], "dev", 2)
    rows = pl.DataFrame([{"run_key": r.key, "method": r.labels["method"], "draw": r.labels["draw"],
                          "success": r.labels["method"] == "safe"} for r in bp.plan.runs])
    lines = summary_lines(bp, rows)
    assert lines[0].startswith("success per method")
    assert lines[1].split() == ["safe", "100", "%", "[34,", "100]", "(n=2)"]
    assert lines[2].split()[:3] == ["feedback-off", "0", "%"] and lines[2].endswith("(n=2)")


def test_the_benchmark_page_documents_method_files_and_the_builtins_settings() -> None:
    """docs/benchmark.md holds what the generator writes: the method-file paragraph and each built-in method's
    settings (the page is regenerated only with the leaderboard)."""
    from ftc_mj.reports.benchmark_page import METHOD_FILE, builtin_settings

    page = (ROOT / "docs" / "benchmark.md").read_text()
    assert "\n".join([*METHOD_FILE, "", *builtin_settings()]) in page


def test_every_entry_defaults_to_the_current_version() -> None:
    """The bench command, a draw, a plan and a Gym episode name no version: they all get the current one."""
    import inspect

    from ftc_mj import cli
    from ftc_mj.benchmark.definition import CURRENT_VERSION, load_definition
    from ftc_mj.benchmark.draws import draw
    from ftc_mj.envs.episode import DEFAULT_VERSION

    assert inspect.signature(cli.bench).parameters["version"].default == CURRENT_VERSION == DEFAULT_VERSION
    assert load_definition().version == CURRENT_VERSION
    assert draw("dev", 0).factors() == draw("dev", 0, CURRENT_VERSION).factors()
    assert plan_bench([load_method("safe")], "dev", 1).version == CURRENT_VERSION
