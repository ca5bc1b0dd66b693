"""The example scripts run end to end as a user runs them (``python examples/NAME.py``, from another
folder), shortened with their ``--duration`` option."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"


def _run(script: str, args: list[str], cwd: Path) -> str:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
           "OMP_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, str(EXAMPLES / script), *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout


@pytest.mark.slow
def test_run_and_plot_one_scenario(tmp_path: Path) -> None:
    out = _run("run_scenario.py", ["--duration", "12", "--out", "o"], tmp_path)
    assert ": ok, robot not judged, fault declared 0." in out and "isolated: left" in out  # 12 s: ends before 15 s
    assert len(list((tmp_path / "o").glob("*/radius.png"))) == 1


@pytest.mark.slow
def test_custom_estimator_against_the_ukf(tmp_path: Path) -> None:
    lines = _run("custom_estimator.py", ["--duration", "12"], tmp_path).splitlines()
    rows = {ln.split()[0]: ln.split() for ln in lines[1:]}
    assert set(rows) == {"ukf", "textbook-ekf"} and all(r[1] == "ok" and r[3] == "left" for r in rows.values())


@pytest.mark.slow
def test_custom_policy_study_on_a_local_cluster(tmp_path: Path) -> None:
    args = ["--duration", "3", "--seeds", "1", "--workers", "1", "--out", "study"]
    out = _run("custom_policy_study.py", args, tmp_path)
    for policy in ("none", "safe", "late-handover"):
        assert f"│ {policy} " in out, out
    assert (tmp_path / "study" / "results.parquet").is_file()


@pytest.mark.slow
def test_gym_random_policy_against_a_tracking_law(tmp_path: Path) -> None:
    """3 s before the puncture: the hand-written law stays within 0.2 m (RMS) of the circle, random wheel rates
    stray by more than 1 m."""
    lines = _run("gym_random_policy.py", ["--duration", "3"], tmp_path).splitlines()[1:]
    rms = {ln.split()[0]: float(ln.split()[2]) for ln in lines}
    assert set(rms) == {"random", "tracking"} and rms["tracking"] < 0.2 < 1.0 < rms["random"]


def test_readme_python_section_fits_in_15_lines() -> None:
    readme = (ROOT / "README.md").read_text()
    section = readme.split("\n## Python\n", 1)[1]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]
    assert 5 <= len(code.strip().splitlines()) <= 15
    for name in ("load_config", "run(", "load_run", "register_estimator", "run_study", "load_study", ".trace",
                 ".metrics", ".events", ".path"):
        assert name in code, name
