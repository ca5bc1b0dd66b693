"""The private split: its draws come from a key given at run time — without one ``--split private`` exits 2
with one line and writes nothing; with one, the draws are a pure function of (version, index, key) that the
repository cannot reproduce (their seeds differ from the dev and test ones and change with the key), and no
file of the outputs holds the key (only its SHA-256 id)."""

from __future__ import annotations

import hashlib
from pathlib import Path

import polars as pl
import pytest
from typer.testing import CliRunner

from ftc_mj.benchmark.draws import draw
from ftc_mj.benchmark.methods import load_methods
from ftc_mj.benchmark.private import KEY_ENV, key_id, read_key
from ftc_mj.benchmark.report import write_outputs
from ftc_mj.benchmark.run import plan_bench, prepare_output
from ftc_mj.cli import app
from ftc_mj.errors import BadInput
from ftc_mj.study.store import StudyStore

KEY = b"judge-private-key-0123456789abcdef"
OTHER = b"another-private-key-fedcba9876543210"


def _tree(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


def test_without_a_key_the_private_split_exits_2_with_one_line_and_writes_nothing(tmp_path, monkeypatch) -> None:
    monkeypatch.delenv(KEY_ENV, raising=False)
    monkeypatch.chdir(tmp_path)
    for args, needle in (([], "--split private: needs a key"), (["--key-file", "nokey"], "--key-file: cannot read"),
                         (["--key-file", "short"], "--key-file: the private key has 5 bytes")):
        (tmp_path / "short").write_text("short\n")
        before = _tree(tmp_path)
        res = CliRunner().invoke(app, ["bench", "safe", "--split", "private", "--draws", "1", "--out", "bout", *args])
        lines = res.stderr.splitlines()
        assert res.exit_code == 2 and len(lines) == 1 and needle in lines[0], (res.exit_code, res.stderr)
        assert _tree(tmp_path) == before
    res = CliRunner().invoke(app, ["bench", "safe", "--split", "dev", "--key-file", "short", "--out", "bout"])
    assert res.exit_code == 2 and "--key-file: only the private split" in res.stderr
    with pytest.raises(BadInput, match="needs a key"):
        draw("private", 0)


def test_the_key_comes_from_the_environment_or_a_file(tmp_path, monkeypatch) -> None:
    monkeypatch.setenv(KEY_ENV, KEY.decode())
    assert read_key() == KEY
    (tmp_path / "k").write_bytes(OTHER + b"\n")
    assert read_key(str(tmp_path / "k")) == OTHER  # the file wins; one trailing newline dropped
    assert key_id(KEY) == hashlib.sha256(KEY).hexdigest()[:16]


def test_private_draws_need_the_key() -> None:
    """The same key gives the same draws (a pure function); another key, or the dev and test splits whose
    entropies the repository holds, give other seeds; the seeds lie in the held-out range."""
    mine = [draw("private", i, key=KEY) for i in range(20)]
    assert [d.seed for d in mine] == [draw("private", i, key=KEY).seed for i in range(20)]
    assert mine[3] == draw("private", 3, key=KEY)
    other = {draw("private", i, key=OTHER).seed for i in range(20)}
    public = {draw(s, i).seed for s in ("dev", "test") for i in range(20)}
    seeds = {d.seed for d in mine}
    assert len(seeds) == 20 and not seeds & other and not seeds & public and min(seeds) >= 1000
    assert {d.tyre_friction for d in mine} != {draw("private", i, key=OTHER).tyre_friction for i in range(20)}


def test_no_output_holds_the_key(tmp_path) -> None:
    """A private bench's outputs (bench.json, the study files, draws, scores, the leaderboard, figures, log)
    hold the key's id, never the key (raw, hex or as text); a folder of one key refuses another key's bench."""
    bp = plan_bench(load_methods(["safe", "feedback-off"]), "private", 3, private_key=KEY)
    out = tmp_path / "out"
    prepare_output(bp, out)
    StudyStore(out).init(bp.plan)
    rows = [{"run_key": r.key, "run_index": r.index, **r.labels, "status": "ok", "outcome": "on the path",
             "success": r.labels["draw"] != 1, "tipped": False, "false_alarm": False, "contouring_max": 0.2,
             "contouring_rms": 0.1, "detection_delay": None, "isolation": "n/a", "reconfig_delay": None}
            for r in bp.plan.runs]
    report = write_outputs(bp, pl.DataFrame(rows), out, compare=0)
    assert report.name == "leaderboard.md" and "private split" in report.read_text()
    files = [p for p in out.rglob("*") if p.is_file()]
    assert len(files) >= 7
    for p in files:
        data = p.read_bytes()
        for secret in (KEY, KEY.hex().encode(), KEY.decode().encode("utf-16-le")):
            assert secret not in data, p
    assert key_id(KEY).encode() in (out / "bench.json").read_bytes()
    other = plan_bench(load_methods(["safe", "feedback-off"]), "private", 3, private_key=OTHER)
    with pytest.raises(BadInput, match="--out"):
        StudyStore(out).check(other.plan)
