"""docs/tutorial-benchmark.md, followed literally: its files written where it says, its commands run as
printed (the ``console`` blocks; the test split's ``sh`` block is hours and is not run), the report's
replay command run from another folder."""

from __future__ import annotations

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import polars as pl
import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "tutorial-benchmark.md"
CLI = "import sys; from ftc_mj.cli import app; sys.argv[0] = 'ftc-mj'; sys.exit(app())"


def page_files() -> dict[str, str]:
    """The blocks the page asks to write: ``<!-- file: PATH -->`` then a fenced block."""
    return dict(re.findall(r"<!-- file: (\S+) -->\n```\w*\n(.*?)```", PAGE.read_text(), flags=re.S))


def page_commands() -> list[str]:
    """The ``$ `` lines of the page's ``console`` blocks, in order."""
    blocks = re.findall(r"```console\n(.*?)```", PAGE.read_text(), flags=re.S)
    return [ln[2:] for b in blocks for ln in b.splitlines() if ln.startswith("$ ")]


def ftc_mj(command: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """``command`` (``ftc-mj …``) run in ``cwd`` with this checkout's package, as the console script does."""
    args = shlex.split(command)
    assert args[0] == "ftc-mj", command
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)}
    proc = subprocess.run([sys.executable, "-c", CLI, *args[1:]], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=1800)
    assert proc.returncode == 0, f"{command}: exit {proc.returncode}\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}"
    return proc


def test_the_page_files_are_the_examples() -> None:
    """The plug-in and the method file on the page are ``examples/blend_policy.py`` and ``.toml``."""
    files = page_files()
    assert sorted(files) == ["my-method/blend_policy.py", "my-method/blend_policy.toml"]
    for path, text in files.items():
        assert text == (ROOT / "examples" / Path(path).name).read_text(), path


@pytest.mark.slow
def test_score_your_own_method_as_the_page_says(tmp_path: Path) -> None:
    """Write the page's files, run its two commands from the folder above them (the plug-in is found beside
    the method file), check that adding ``feedback-off`` computed only its runs (``log.jsonl``), and run the
    report's replay command from a third folder: the replayed run scores as the bench's did (a run is a
    pure function of its config)."""
    for path, text in page_files().items():
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / path).write_text(text)
    first, second = page_commands()
    out = tmp_path / "runs" / "blend"
    res = ftc_mj(first, tmp_path)
    assert "success per method" in res.stdout and re.search(r"^  blend-half +\d+ % \[", res.stdout, re.M), res.stdout
    res = ftc_mj(second, tmp_path)
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
    ftc_mj(replay.group(1), elsewhere)
    again = pl.read_parquet(next((elsewhere / "runs/out/bench").glob("*/scores.parquet")))
    mine = scores.filter((pl.col("method") == "blend-half") & (pl.col("draw") == 0))
    assert again["run_key"].to_list() == mine["run_key"].to_list()
    assert again["contouring_max"].to_list() == mine["contouring_max"].to_list()
