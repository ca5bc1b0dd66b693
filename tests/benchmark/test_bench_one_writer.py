"""Two ``ftc-mj bench`` processes on one ``--out``: the second, started while the first computes, gets one
line and exit 2 and computes nothing (before, both computed every run)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.support.processes import second_while_first_runs


@pytest.mark.slow
def test_two_benches_on_one_folder_one_computes_the_other_refuses(tmp_path: Path) -> None:
    out = tmp_path / "out"
    race = second_while_first_runs(["bench", "passive", "--draws", "1", "--workers", "1", "--compare", "0",
                                    "--out", str(out), "-q"], out / "bench.json", 300)  # written under the lock
    first, second = race.first, race.second
    assert first.returncode == 0, first.stderr
    assert "bench: computed 1 runs" in first.stdout
    assert race.overlapped, "the first bench ended before the second asked: nothing was tested"
    assert second.returncode == 2 and second.stdout == ""
    assert second.stderr == (f"ftc-mj: error: --out: {out} is being written by another ftc-mj process (study or "
                             "bench); wait for it to finish or use another folder\n")
    log = [json.loads(line) for line in (out / "log.jsonl").read_text().splitlines()]
    assert [e["event"] for e in log].count("start") == 1 and [e["event"] for e in log].count("run") == 1
