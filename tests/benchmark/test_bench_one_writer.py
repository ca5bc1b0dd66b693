"""Two ``ftc-mj bench`` processes on one ``--out``: the second, started while the first computes, gets one
line and exit 2 and computes nothing (before, both computed every run)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_two_benches_on_one_folder_one_computes_the_other_refuses(tmp_path: Path) -> None:
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    cmd = [sys.executable, "-m", "ftc_mj.cli", "bench", "passive", "--draws", "1", "--workers", "1", "--compare", "0",
           "--out", str(out), "-q"]
    first = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 300
        while not (out / "bench.json").is_file() and first.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)  # bench.json is written under the lock
        second = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
        still_running = first.poll() is None
        out1, err1 = first.communicate(timeout=600)
    finally:
        first.kill()
    assert first.returncode == 0, err1
    assert "bench: computed 1 runs" in out1
    assert still_running, "the first bench ended before the second asked: nothing was tested"
    assert second.returncode == 2 and second.stdout == ""
    assert second.stderr == (f"ftc-mj: error: --out: {out} is being written by another ftc-mj process (study or "
                             "bench); wait for it to finish or use another folder\n")
    log = [json.loads(line) for line in (out / "log.jsonl").read_text().splitlines()]
    assert [e["event"] for e in log].count("start") == 1 and [e["event"] for e in log].count("run") == 1
