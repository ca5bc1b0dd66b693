"""What a new user finds without reading the code: help texts that list exactly the registered
components, a README synopsis that agrees with them, and a "did you mean" on every mistyped name
(scenario, study, component, config key, a key at the wrong level) — one line, exit code 2,
nothing written."""

from __future__ import annotations

import re
from pathlib import Path

import click
import pytest
import typer
from typer.testing import CliRunner

from ftc_mj import registry
from ftc_mj.cli import app

README = Path(__file__).resolve().parents[2] / "README.md"
OPTIONS = {"--estimator": registry.estimators, "--reconfig": registry.policies,
           "--controller": registry.controllers}
"""The options of ``ftc-mj run`` that name a component, and their registries."""


def run_help() -> str:
    """``ftc-mj run --help`` rendered without line wrapping (names with hyphens stay whole)."""
    cmd = typer.main.get_command(app).get_command(click.Context(typer.main.get_command(app)), "run")  # type: ignore[attr-defined]
    ctx = click.Context(cmd, info_name="run", terminal_width=10_000, max_content_width=10_000)
    return cmd.get_help(ctx)


@pytest.mark.parametrize("option", OPTIONS)
def test_run_help_lists_exactly_the_registered_components(option: str) -> None:
    line = next(ln for ln in run_help().splitlines() if ln.strip().startswith(option + " "))
    assert ", ".join(OPTIONS[option].names()) in line, line
    listed = set(re.findall(r"registered(?: estimator)?: ([a-z0-9+_-]+(?:, [a-z0-9+_-]+)*)", line)[0].split(", "))
    assert listed == set(OPTIONS[option].names())


def test_readme_synopsis_names_the_registered_components() -> None:
    synopsis = README.read_text().split("## What a run is", 1)[1].split("```", 2)[1]
    for option, reg in OPTIONS.items():
        choices = re.search(re.escape(option) + r" ([a-z0-9|+_.-]+)\]", synopsis)
        assert choices is not None, option
        builtin = {n for n in reg.names() if reg.get(n).origin == registry.BUILTIN}  # other tests add plug-ins
        assert set(choices.group(1).split("|")) == builtin, option


@pytest.mark.parametrize(("args", "expected"), [
    (["run", "scenaro2"], "scenario: no such built-in scenario or file: scenaro2 (did you mean 'scenario2'?)"),
    (["study", "severty"], "STUDY_FILE: no such built-in study or file: severty (did you mean 'severity'?)"),
    (["run", "scenario2", "--controller", "pf-nmcp"], "--controller: unknown controller 'pf-nmcp' (did you mean "
                                                      "'pf-nmpc'?)"),
    (["run", "scenario2", "--estimator", "ufk"], "--estimator: unknown estimator 'ufk' (did you mean 'ukf'?)"),
    (["run", "scenario2", "--set", "estimator.decision.rule=cusm"], "unknown decision rule 'cusm' (did you mean "
                                                                    "'cusum'?)"),
    (["run", "scenario2", "--set", "sensors.yaw_rate_sigmaa=0.01"],
     "sensors.yaw_rate_sigmaa: unknown key; did you mean sensors.yaw_rate_sigma?"),
    (["run", "scenario2", "--set", "decision.rule=glr"],
     "decision: unknown key; did you mean estimator.decision.rule?"),
    (["run", "sensor.toml"], "sensor: unknown key; did you mean sensors.yaw_rate_sigma?"),
    (["study", "typo.study.toml"], "unknown key 'yaw_rat' in sensors (did you mean sensors.yaw_rate_sigma?)"),
])
def test_a_mistyped_name_gets_one_line_with_the_close_match(args: list[str], expected: str, tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sensor.toml").write_text('name = "s"\n[sensor]\nyaw_rate_sigma = 0.01\n')
    (tmp_path / "typo.study.toml").write_text('name = "s"\nscenario = "scenario1"\n[[axes]]\n'
                                              'key = "sensors.yaw_rat"\nvalues = [0.1]\n')
    before = sorted(tmp_path.rglob("*"))
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 2
    assert len(res.stderr.splitlines()) == 1 and expected in res.stderr, res.stderr
    assert sorted(tmp_path.rglob("*")) == before


def test_no_suggestion_when_nothing_is_close() -> None:
    res = CliRunner().invoke(app, ["run", "zzzz"])
    assert res.exit_code == 2 and "did you mean" not in res.stderr
