"""One writer per output folder: a second ``ftc-mj study`` or ``bench`` on a folder another process is
writing gets one line and exit 2, writes nothing and computes nothing; results that cannot be written (a
full disk) end the command with one line and exit 1, the rows persisted before kept."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest
from typer.testing import CliRunner

from ftc_mj.cli import app
from ftc_mj.errors import BadInput
from ftc_mj.io import writer_lock
from tests.support.processes import second_while_first_runs
from tests.support.small_disk import fill, small_tmpfs

STUDY = textwrap.dedent("""
    name = "lock"
    scenario = "scenario2"
    seeds = {seeds}
    [base]
    duration = {duration}
    "plant.kind" = "kinematic"
    "estimator.kind" = "none"
    [analysis]
    figures = false
""")
HOLDER = ("import fcntl, os, sys, time\n"
          "fd = os.open(sys.argv[1], os.O_RDONLY)\n"
          "fcntl.flock(fd, fcntl.LOCK_EX)\n"
          "print('held', flush=True)\n"
          "time.sleep(120)\n")


def study_file(tmp_path: Path, seeds: int, duration: float, plant: str = "kinematic") -> Path:
    path = tmp_path / "lock.toml"
    path.write_text(STUDY.format(seeds=seeds, duration=duration).replace('"kinematic"', f'"{plant}"'))
    return path


@pytest.fixture
def held(tmp_path: Path) -> Iterator[Path]:
    """An output folder whose lock another process holds."""
    out = tmp_path / "out"
    out.mkdir()
    proc = subprocess.Popen([sys.executable, "-c", HOLDER, str(out)], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == "held"
        yield out
    finally:
        proc.kill()
        proc.wait(timeout=10)


def test_the_lock_is_reentrant_in_a_process_and_released_after() -> None:
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        folder = Path(d) / "new" / "out"
        with writer_lock(folder), writer_lock(folder):  # ftc-mj bench holds it around the study runner
            assert folder.is_dir()
        proc = subprocess.run([sys.executable, "-c", HOLDER.replace("time.sleep(120)", ""), str(folder)],
                              capture_output=True, text=True, timeout=30)
        assert proc.stdout.strip() == "held"  # released: another process takes it at once


@pytest.mark.parametrize("command", ["study", "bench"])
def test_a_held_folder_is_refused_with_one_line_and_nothing_written(held: Path, tmp_path: Path,
                                                                    command: str) -> None:
    args = (["study", str(study_file(tmp_path, 1, 0.5)), "--serial"] if command == "study"
            else ["bench", "safe", "--draws", "1"])
    res = CliRunner().invoke(app, [*args, "--out", str(held), "-q"])
    assert res.exit_code == 2, res.stdout + res.stderr
    assert res.stderr == (f"ftc-mj: error: --out: {held} is being written by another ftc-mj process (study or "
                          "bench); wait for it to finish or use another folder\n")
    assert list(held.iterdir()) == []
    with pytest.raises(BadInput, match="being written by another"), writer_lock(held):
        pass


def test_two_studies_on_one_folder_one_computes_the_other_refuses(tmp_path: Path) -> None:
    """Two real processes: the second, started while the first computes, exits 2 with one line and
    writes nothing; every run is computed and logged exactly once."""
    study, out = study_file(tmp_path, 10, 4.0, "mujoco"), tmp_path / "out"  # about 10 s: the second comes in
    race = second_while_first_runs(["study", str(study), "--serial", "--out", str(out), "-q"], out / "log.jsonl", 120)
    first, second = race.first, race.second
    assert first.returncode == 0, first.stderr
    assert race.overlapped, "the first study ended before the second asked: nothing was tested"
    assert second.returncode == 2 and second.stdout == ""
    assert second.stderr.count("\n") == 1 and "is being written by another ftc-mj process" in second.stderr
    log = [json.loads(line) for line in (out / "log.jsonl").read_text().splitlines()]
    assert [e["event"] for e in log].count("start") == 1
    runs = [e["run_key"] for e in log if e["event"] == "run"]
    assert len(runs) == 10 and len(set(runs)) == 10
    assert len(list((out / "rows").glob("*.parquet"))) == 10


@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Path | None]:
    """A real 4 MB tmpfs (root may mount one), else ``None``."""
    with small_tmpfs(tmp_path / "small") as mnt:
        yield mnt


def test_results_on_a_full_disk_end_with_one_line_and_exit_1(small_disk: Path | None, tmp_path: Path,
                                                             monkeypatch: pytest.MonkeyPatch) -> None:
    """The run's row is persisted; then the disk is full when ``results.parquet`` is written: polars' own
    error (on a real full tmpfs; without root, polars writing to ``/dev/full``) becomes one line, exit 1."""
    from ftc_mj.study import store as store_mod

    collect = store_mod.StudyStore.collect
    seen: list[BaseException] = []

    def collect_on_a_full_disk(self, plan):  # noqa: ANN001
        if small_disk is not None:
            fill(small_disk)
        else:
            @__import__("contextlib").contextmanager
            def to_dev_full(path):  # noqa: ANN001
                yield Path("/dev/full")
            monkeypatch.setattr(store_mod, "atomic_path", to_dev_full)
        try:
            return collect(self, plan)
        except Exception as err:
            seen.append(err.__context__ or err)
            raise

    monkeypatch.setattr(store_mod.StudyStore, "collect", collect_on_a_full_disk)
    out = (small_disk or tmp_path) / "out"
    res = CliRunner().invoke(app, ["study", str(study_file(tmp_path, 1, 0.5)), "--serial", "--out", str(out), "-q"])
    assert res.exit_code == 1, res.stdout + res.stderr
    assert res.stderr.count("\n") == 1 and res.stderr.startswith(f"ftc-mj: error: {out / 'results.parquet'}: "
                                                                 "cannot write the results: ")
    # polars may word it "Invalid thrift: transport error" (its footer write failed): the full file system is said
    assert small_disk is None or "no space left on device" in res.stderr.lower()
    (err,) = seen
    assert type(err).__module__.startswith("polars")  # the real writer's own error, not a stand-in
    assert len(list((out / "rows").glob("*.parquet"))) == 1 and not (out / "results.parquet").exists()
    assert [p.name for p in out.iterdir() if p.name.startswith(".")] == []  # no temporary left
