"""The README is the front door: its first screen says what ftc-mj is, what it found and the two commands;
it has no commit hash or date; and every command and code block in it runs in the suite (at reduced size
here, in full in the named test) or is one of the stated exceptions (the install), so no example can
contradict its page."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

from typer.testing import CliRunner

from ftc_mj.cli import app
from ftc_mj.sim.summary import working_command

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
FIRST_COMMAND = ("python3 -m venv .venv && .venv/bin/pip install -e . && .venv/bin/ftc-mj warm-up && "
                 ".venv/bin/ftc-mj run scenario2 --out runs/out")
TEST_COMMAND = 'python3 -m venv .venv && .venv/bin/pip install -e ".[test]" && .venv/bin/pytest -q -n 2'
COVERED = {
    FIRST_COMMAND: "tests/docs/test_readme.py::test_the_first_command_runs_and_writes_what_the_readme_says "
                   "(reduced); tests/cli/test_hints.py::test_the_hint_after_the_default_run_works_as_printed (full); "
                   "tests/sim/test_warmup.py (the warm-up, reduced)",
    "ftc-mj warm-up": "tests/sim/test_warmup.py::test_each_part_runs_in_a_fresh_process_of_its_own (reduced)",
    TEST_COMMAND: "tests/docs/test_readme.py::test_ci_runs_the_readme_test_command",
    working_command("scenario2"): "tests/cli/test_hints.py::test_the_hint_after_the_default_run_works_as_printed",
    "ftc-mj view": "tests/cli/test_bad_input_cases.py::test_view_without_display_points_to_the_screenshot_script",
    ".venv/bin/sphinx-build -b html docs docs/_build/html":
        "tests/docs/test_site.py::test_the_site_builds_with_warnings_as_errors",
    "python examples/NAME.py": "tests/cli/test_examples.py::test_run_and_plot_one_scenario",
    "python block": "tests/docs/test_readme.py::test_the_python_block_runs",
}
"""Each command of the README (and its Python block) → the tests that run it."""
PENDING_PAGES: set[str] = set()
"""Pages the README links to that another branch adds (the "score your own method" tutorial)."""


def readme_commands(text: str) -> set[str]:
    """The README's commands: the lines of its ``bash`` blocks and its inline code that starts with a program."""
    commands = set()
    for block in re.findall(r"```bash\n(.*?)```", text, re.S):
        commands |= {ln.strip() for ln in block.splitlines() if ln.strip()}
    prose = re.sub(r"```.*?```", "", text, flags=re.S)
    commands |= {c for c in re.findall(r"`([^`\n]+)`", prose) if re.match(r"(ftc-mj|\.venv/bin/|python3? )", c)}
    if "```python" in text:
        commands.add("python block")
    return commands


def test_first_screen_says_what_it_is_what_it_found_and_the_two_commands() -> None:
    text = README.read_text()
    lines = text.splitlines()
    assert len(lines) <= 150
    first = "\n".join(lines[:40])
    assert "ftc-mj is an open-source toolkit for studying active fault-tolerant control" in first
    assert FIRST_COMMAND in first and TEST_COMMAND in first
    assert "90 % [87, 92]" in first and working_command("scenario2") in first
    figure = re.search(r"!\[[^\]]*\]\(([^)]+\.png)\)", first)
    assert figure is not None and (ROOT / figure.group(1)).is_file()
    assert "docs/performance.md" in first and "docs/usage.md" in first


def test_no_commit_hash_or_date() -> None:
    text = README.read_text()
    assert not re.search(r"\b(?=[0-9a-f]*[a-f])(?=[0-9a-f]*[0-9])[0-9a-f]{7,40}\b", text)
    assert not re.search(r"\b(19|20)\d\d-\d\d-\d\d\b|\b(19|20)\d\d/\d\d/\d\d\b", text)


def test_numbers_quoted_from_the_docs_are_there() -> None:
    """The headline numbers are the benchmark page's and the timings the performance page's."""
    benchmark = (ROOT / "docs" / "benchmark.md").read_text()
    for number in ("90 % [87, 92]", "91 % [88, 93]", "51 % [47, 55]", "+0.4 [+0.34, +0.448]", "95 % [92, 96]",
                   "95 % [92, 98]", "49 % [37, 62]", "51 % [38, 63]", "19 % [16, 22]"):
        assert number in README.read_text() and number in benchmark, number
    performance = (ROOT / "docs" / "performance.md").read_text()
    for fact in ("about 12 s on two idle cores", "about 5 to 6 minutes", "271 s with"):
        assert fact in performance, fact


def test_every_link_resolves() -> None:
    targets = re.findall(r"\]\(([^)#]+)\)", README.read_text())
    missing = [t for t in targets if "://" not in t and not (ROOT / t).exists() and t not in PENDING_PAGES]
    assert not missing


def test_every_command_is_run_by_a_named_test() -> None:
    assert readme_commands(README.read_text()) == set(COVERED)
    for tests in COVERED.values():
        for ref in re.findall(r"(tests/\S+\.py)::(\w+)", tests):
            assert f"def {ref[1]}(" in (ROOT / ref[0]).read_text(), ref


def test_ci_runs_the_readme_test_command() -> None:
    """``.ci/run`` installs and tests exactly as the README says (pip's ``-q`` aside)."""
    ci = [ln for ln in (ROOT / ".ci" / "run").read_text().splitlines() if ln.startswith("python3 ")]
    assert [ln.replace("pip install -q ", "pip install ") for ln in ci] == [TEST_COMMAND]


def test_the_first_command_runs_and_writes_what_the_readme_says(tmp_path: Path) -> None:
    """``ftc-mj run scenario2 --out runs/out`` shortened to 0.5 s: the summary opens with the outcome and the
    run folder holds the files the README names."""
    res = CliRunner().invoke(app, ["run", "scenario2", "--out", str(tmp_path / "runs" / "out"), "--duration", "0.5"])
    assert res.exit_code == 0, res.output
    assert res.stdout.startswith("OUTCOME:")
    (run_dir,) = (tmp_path / "runs" / "out").iterdir()
    for name in ("config.toml", "trace.parquet", "metrics.json", "run.rrd"):
        assert (run_dir / name).is_file(), name
    assert json.loads((run_dir / "metrics.json").read_text())["status"] == "ok"


def test_the_python_block_runs(tmp_path: Path) -> None:
    """The README's Python block as written, with a 0.5 s run, the example plug-in estimator as ``MyFilter`` and
    the study shortened (two 0.3 s runs, in process, results without the summary: the observability study's
    summary and figures are drawn in ``tests/study/test_cluster.py::test_shipped_study_reduced``)."""
    code = README.read_text().split("```python\n", 1)[1].split("```", 1)[0]
    shorten = {'"duration": 20.0': '"duration": 0.5',
               'ftc_mj.run_study("observability", workers=2)':
                   'ftc_mj.run_study("observability", serial=True, overrides={"duration": 0.3}, limit=2, '
                   'analyse=False)'}
    for old, new in shorten.items():
        assert old in code, old
        code = code.replace(old, new)
    prelude = "from my_components import TextbookEKF as MyFilter\n"
    env = {**os.environ, "OMP_NUM_THREADS": "1",
           "PYTHONPATH": os.pathsep.join([str(ROOT), str(ROOT / "examples"), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.run([sys.executable, "-c", prelude + code + "\nprint(len(same.trace), len(study.results))"],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    rows, results = map(int, proc.stdout.split()[-2:])
    assert rows == 50 and results == 2  # 0.5 s at 100 Hz; the two study runs


def test_synopsis_names_only_real_commands_and_options() -> None:
    """Every ``ftc-mj COMMAND`` of the README's synopsis is a command of the CLI and every option it shows is
    one of that command's (the component choices are checked in ``tests/cli/test_discoverability.py``)."""
    import typer

    synopsis = README.read_text().split("## What a run is", 1)[1].split("```", 2)[1]
    group = typer.main.get_command(app)
    ctx = group.make_context("ftc-mj", [], resilient_parsing=True)
    seen = set()
    command = None
    for line in synopsis.splitlines():
        code = line.split("#", 1)[0]
        head = re.match(r"ftc-mj ([a-z][a-z-]*(?: \| [a-z][a-z-]*)*)", code.strip())
        if head:
            names = head.group(1).split(" | ")
            for name in names:
                assert group.get_command(ctx, name) is not None, name
            command = group.get_command(ctx, names[0])
            seen |= set(names)
        elif code.strip().startswith("ftc-mj --"):
            command = group
        for option in re.findall(r"(?<![\w-])(--[a-z][a-z0-9-]*)", code):
            opts = {o for p in command.params for o in (*p.opts, *p.secondary_opts)}
            assert option in opts or (command is group and option == "--version"), (command.name, option)
    assert seen == set(group.list_commands(ctx))  # and every command is in it
