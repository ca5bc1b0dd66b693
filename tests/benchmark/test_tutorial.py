"""docs/tutorial-benchmark.md, followed literally: its files written where it says, its commands run as
printed (the ``console`` blocks; the test split's ``sh`` block is hours and is not run), the report's
replay command run from another folder. The commands run in this process (the CLI's ``app`` with the page's
arguments, from the page's folder), as the console script calls it; what a command adds to the process (the
plug-in's module, its registration, its folder on ``sys.path`` and ``PYTHONPATH``) is taken back after the test.
The bench's runs are computed in the local Dask workers either way."""

from __future__ import annotations

import json
import os
import re
import shlex
import sys
from collections.abc import Iterator
from pathlib import Path

import polars as pl
import pytest
from typer.testing import CliRunner, Result

from ftc_mj import registry
from ftc_mj.cli import app

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "tutorial-benchmark.md"


def page_files() -> dict[str, str]:
    """The blocks the page asks to write: ``<!-- file: PATH -->`` then a fenced block."""
    return dict(re.findall(r"<!-- file: (\S+) -->\n```\w*\n(.*?)```", PAGE.read_text(), flags=re.S))


def page_commands() -> list[str]:
    """The ``$ `` lines of the page's ``console`` blocks, in order."""
    blocks = re.findall(r"```console\n(.*?)```", PAGE.read_text(), flags=re.S)
    return [ln[2:] for b in blocks for ln in b.splitlines() if ln.startswith("$ ")]


PLUGIN, POLICY = "blend_policy", "blend"
"""The page's plug-in module and the policy it registers."""


@pytest.fixture
def page_process(monkeypatch: pytest.MonkeyPatch) -> Iterator[pytest.MonkeyPatch]:
    """This process as the page's commands leave it, then as it was: the working folder, ``sys.path`` and
    ``PYTHONPATH`` (the plug-in's folder is added to both; the local workers import this checkout's package), the
    plug-in's module and its registration."""
    monkeypatch.setattr(sys, "path", list(sys.path))
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p))
    monkeypatch.delitem(sys.modules, PLUGIN, raising=False)
    assert POLICY not in registry.policies.names() and PLUGIN not in registry._loaded_plugins
    try:
        yield monkeypatch
    finally:
        sys.modules.pop(PLUGIN, None)  # imported again, and so registered again, by the next user
        if POLICY in registry.policies.names():
            registry.policies.unregister(POLICY)
        registry._loaded_plugins.discard(PLUGIN)


def ftc_mj(command: str, cwd: Path, mp: pytest.MonkeyPatch) -> Result:
    """``command`` (``ftc-mj …``) run in ``cwd``: the CLI's ``app`` with its arguments, as the console script
    calls it."""
    args = shlex.split(command)
    assert args[0] == "ftc-mj", command
    mp.chdir(cwd)
    res = CliRunner().invoke(app, args[1:], prog_name="ftc-mj")
    assert res.exit_code == 0, f"{command}: exit {res.exit_code}\n{res.stdout[-2000:]}\n{res.stderr[-2000:]}\n" \
                               f"{res.exception!r}"
    return res


def test_the_page_files_are_the_examples() -> None:
    """The plug-in and the method file on the page are ``examples/blend_policy.py`` and ``.toml``."""
    files = page_files()
    assert sorted(files) == ["my-method/blend_policy.py", "my-method/blend_policy.toml"]
    for path, text in files.items():
        assert text == (ROOT / "examples" / Path(path).name).read_text(), path


@pytest.mark.slow
def test_score_your_own_method_as_the_page_says(tmp_path: Path, page_process: pytest.MonkeyPatch) -> None:
    """Write the page's files, run its two commands from the folder above them (the plug-in is found beside
    the method file), check that adding ``feedback-off`` computed only its runs (``log.jsonl``), and run the
    report's replay command from a third folder: the replayed run scores as the bench's did (a run is a
    pure function of its config)."""
    for path, text in page_files().items():
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / path).write_text(text)
    first, second = page_commands()
    out = tmp_path / "runs" / "blend"
    res = ftc_mj(first, tmp_path, page_process)
    assert "success per method" in res.stdout and re.search(r"^  blend-half +\d+ % \[", res.stdout, re.M), res.stdout
    res = ftc_mj(second, tmp_path, page_process)
    assert re.search(r"^  feedback-off +\d+ % \[.*\(n=2\)$", res.stdout, re.M), res.stdout
    log = [json.loads(ln) for ln in (out / "log.jsonl").read_text().splitlines()]
    last = [e for e in log if e["event"] == "start"][-1]["invocation"]
    computed = {e["run_key"] for e in log if e["event"] == "run" and e["invocation"] == last}
    scores = pl.read_parquet(out / "scores.parquet")
    by_key = dict(zip(scores["run_key"], scores["method"], strict=True))
    assert sorted(by_key[k] for k in computed) == ["feedback-off", "feedback-off"]
    assert sorted(scores["method"]) == ["blend-half", "blend-half", "feedback-off", "feedback-off"]

    report = (out / "dev-report.md").read_text()
    replay = re.search(r"^\| blend-half \|.*`(ftc-mj bench [^`]+ --draws 1 --benchmark ftc-v2)` \|$", report, re.M)
    assert replay, report[:2000]
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    ftc_mj(replay.group(1), elsewhere, page_process)
    again = pl.read_parquet(next((elsewhere / "runs/out/bench").glob("*/scores.parquet")))
    mine = scores.filter((pl.col("method") == "blend-half") & (pl.col("draw") == 0))
    assert again["run_key"].to_list() == mine["run_key"].to_list()
    assert again["contouring_max"].to_list() == mine["contouring_max"].to_list()
