"""Studies with the real simulation: a real LocalCluster (2 workers) against the same runs made
serially, an interrupted CLI study resumed without recomputation, and the shipped studies at
reduced size (their summaries state the findings with numbers).

Kept small for 2 shared cores: short durations, one seed, first and last value of each axis.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import signal
import subprocess
import sys
import textwrap
import time
import tomllib
from pathlib import Path
from typing import Any

import polars as pl
import pytest
import tomli_w
from typer.testing import CliRunner

from ftc_mj import resources
from ftc_mj.cli import app
from ftc_mj.study.plan import plan_study
from ftc_mj.study.rows import wall_columns
from ftc_mj.study.runner import run_study
from ftc_mj.study.store import StudyStore
from tests.study.studies import NO_FIGURES, SENSORS_BY_ESTIMATOR

ROOT = Path(__file__).resolve().parents[2]
STUDIES = resources.resource_path("studies")

SMALL = """
name = "small"
description = "8 short runs: left 50 % puncture at 1.5 s"
scenario = "scenario2"
seeds = 2
[base]
duration = 4.0
feedback = false
"faults.left" = [[1.5, 2.0], [1.5, 1.0]]
"estimator.decision.dwell" = 0.2
"controller.time_budget" = 5.0   # no wall-time-dependent fallbacks: runs must be reproducible
""" + SENSORS_BY_ESTIMATOR + NO_FIGURES


def comparable(df: pl.DataFrame) -> pl.DataFrame:
    """Drop timing/bookkeeping columns; order by plan index."""
    return df.drop(wall_columns(df.columns)).sort("run_index")


def assert_same_rows(a: pl.DataFrame, b: pl.DataFrame) -> None:
    """Row by row, every non-wall-time column identical (NaN/None equal)."""
    a, b = comparable(a), comparable(b)
    assert a.columns == b.columns or set(a.columns) == set(b.columns)
    b = b.select(a.columns)
    assert a.height == b.height
    for ra, rb in zip(a.iter_rows(named=True), b.iter_rows(named=True), strict=True):
        diff = {k: (ra[k], rb[k]) for k in ra if ra[k] != rb[k] and not (_nan(ra[k]) and _nan(rb[k]))}
        assert not diff, (ra["run_key"], diff)


def _nan(x: Any) -> bool:
    return x is None or (isinstance(x, float) and x != x)


@pytest.fixture(scope="module")
def small_study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    p = tmp_path_factory.mktemp("study") / "small.toml"
    p.write_text(textwrap.dedent(SMALL))
    return p


@pytest.fixture(scope="module")
def serial_reference(small_study: Path, tmp_path_factory: pytest.TempPathFactory) -> pl.DataFrame:
    rep = run_study(plan_study(small_study), tmp_path_factory.mktemp("serial"), serial=True, analyse=False)
    assert rep.results is not None
    return rep.results


def test_cluster_matches_serial(small_study: Path, serial_reference: pl.DataFrame, dask_client: Any,
                                tmp_path: Path) -> None:
    plan = plan_study(small_study)
    assert len(plan.runs) == 8
    before = dask_client.run(_worker_cache)  # the session's cluster may have run other studies
    before = {f"{host}:{pid}": stats for host, pid, stats in before.values()}
    rep = run_study(plan, tmp_path, client=dask_client)
    assert rep.results is not None and rep.results.height == 8 and not rep.failed, rep.results["error"].to_list()
    workers = set(rep.results["worker"].to_list())
    assert len(workers) == 2  # both worker processes did runs
    # solvers are built once per worker process (ftc_mj.sim.cache), then reset and reused: on each
    # worker this study's runs are one build (none if the worker already had this solver) and hits
    per_worker = rep.results.group_by("worker").agg(pl.col("worker_controller_builds").max().alias("builds"),
                                                    pl.col("worker_controller_hits").max().alias("hits"),
                                                    pl.len().alias("runs"))
    for w, builds, hits, runs in per_worker.iter_rows():
        b0 = before[w].get("controller_builds", 0)
        new_builds, new_hits = builds - b0, hits - before[w].get("controller_hits", 0)
        assert new_builds == 1 if b0 == 0 else new_builds <= 1, (w, builds, before[w])
        assert new_builds + new_hits == runs, (w, builds, hits, before[w])
    assert_same_rows(rep.results, serial_reference)
    assert re.search(r"sensors = speed\+yaw (reduces|raises) it from [0-9.]+ ± [0-9.e-]+ m", (tmp_path / "summary.md")
                     .read_text())


def _worker_cache() -> tuple[str, int, dict[str, int]]:
    """Host, process id and cache counters of the worker process this runs in."""
    import socket

    from ftc_mj.study.worker import cache_stats

    return socket.gethostname(), os.getpid(), cache_stats()


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "ftc_mj.cli", "study", *args]


def test_interrupted_study_resumes_without_recomputing(small_study: Path, serial_reference: pl.DataFrame,
                                                       dask_client: Any, tmp_path: Path) -> None:
    """A CLI study killed after two rows (SIGKILL of the study process alone, as a user's kill does; its
    local worker outlives it for a moment) is resumed by the same command, which computes only the
    missing runs. The kill prints nothing: multiprocessing's resource tracker removes the semaphores
    dask left without "There appear to be N leaked semaphore objects", which reads like a bug. The
    resuming invocation runs the CLI in this process on the session's cluster (``--address``): the
    process boundary matters only for the kill, and the session's workers already hold the solver."""
    psutil = pytest.importorskip("psutil")
    out, err = tmp_path / "out", tmp_path / "stderr.txt"
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    with open(err, "w") as fh:
        proc = subprocess.Popen(_cli(str(small_study), "--out", str(out), "--workers", "1", "-q"), cwd=ROOT,
                                env=env, stdout=subprocess.DEVNULL, stderr=fh, start_new_session=True)
    deadline = time.time() + 120
    rows = out / "rows"
    try:
        while time.time() < deadline and proc.poll() is None:
            if rows.is_dir() and len(list(rows.glob("[!.]*.parquet"))) >= 2:
                break
            time.sleep(0.05)
        assert proc.poll() is None, "the study finished before it could be killed"
        session = [p for p in psutil.process_iter() if _sid(p) == proc.pid]
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
        psutil.wait_procs([p for p in session if p.pid != proc.pid], timeout=60)  # the tracker's last words
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)  # whatever of the session is left
    assert "leaked" not in err.read_text(), err.read_text()
    n_before = len(list(rows.glob("[!.]*.parquet")))
    assert 2 <= n_before < 8, f"kill came too late ({n_before} rows)"
    assert not (out / "results.parquet").exists()
    res = CliRunner().invoke(app, ["study", str(small_study), "--out", str(out), "--address",
                                   dask_client.scheduler.address, "-q"])
    assert res.exit_code == 0, res.output
    log = StudyStore(out).read_log()
    starts = [e for e in log if e["event"] == "start"]
    assert len(starts) == 2 and starts[1]["done_before"] == n_before and starts[1]["todo"] == 8 - n_before
    persisted = [(e["invocation"], e["run_key"]) for e in log if e["event"] == "run"]
    assert len(persisted) == 8 and len({k for _, k in persisted}) == 8  # no run persisted twice
    second = [k for inv, k in persisted if inv == starts[1]["invocation"]]
    assert len(second) == 8 - n_before
    final = pl.read_parquet(out / "results.parquet")
    assert_same_rows(final, serial_reference)
    assert set(final["invocation"].to_list()) == {starts[0]["invocation"], starts[1]["invocation"]}


def reduced(name: str, tmp_path: Path, overrides: dict[str, Any], keep: dict[str, list[Any]],
            figures: bool = True) -> Path:
    """A copy of a shipped study with one seed, shorter runs and only the axis labels in ``keep`` (and its
    summary without figures unless ``figures``)."""
    data = tomllib.loads((STUDIES / f"{name}.toml").read_text())
    data["seeds"] = 1
    data.setdefault("analysis", {})["figures"] = figures
    data.setdefault("base", {}).update(overrides)
    for ax in data.get("axes", []):
        col = ax.get("name", ax.get("key"))
        labels = ax.get("labels", ax["values"])
        idx = [labels.index(v) for v in keep[col]]
        ax["values"] = [ax["values"][i] for i in idx]
        if "labels" in ax:
            ax["labels"] = [ax["labels"][i] for i in idx]
    p = tmp_path / f"{name}.toml"
    p.write_text(tomli_w.dumps(data))
    return p


NUM = r"[0-9.]+(e[-+][0-9]+)?"


@pytest.mark.parametrize(("name", "overrides", "keep", "expect"), [
    ("observability", {"duration": 12.0}, {"sensors": ["speed", "speed+yaw+pos"], "estimator": ["ukf"]},
     rf"final left-radius error .*: sensors = speed\+yaw\+pos (reduces|raises) it from {NUM} m \(speed, n = 1\) "
     rf"to {NUM} m"),
    ("mismatch", {"duration": 12.0}, {"half_track": [0.9, 1.1], "friction": [1.0], "variant": ["suspended"]},
     r"detection delay: half_track = 1\.1 (reduces|raises|leaves)"),
    ("severity", {"duration": 10.0}, {"severity": [0.1, 0.9], "wheel": ["left"], "estimator": ["ekf"]},
     r"detection delay \(estimator = ekf\): severity = 0\.9 (reduces|raises|leaves)"),
])
def test_shipped_study_reduced(name: str, overrides: dict[str, Any], keep: dict[str, list[Any]], expect: str,
                               dask_client: Any, tmp_path: Path) -> None:
    """Two runs of a shipped study on the cluster: its finding is stated; one of them (observability) also
    draws its figures (the same figure code serves every study)."""
    figures = name == "observability"
    plan = plan_study(reduced(name, tmp_path, overrides, keep, figures))
    assert len(plan.runs) == 2
    rep = run_study(plan, tmp_path / "out", client=dask_client)
    assert rep.results is not None and rep.results.height == len(plan.runs)
    text = (tmp_path / "out" / "summary.md").read_text()
    assert "## Findings" in text
    assert re.search(expect, text), text[:3000]
    assert (tmp_path / "out" / "figures" / f"by_{plan.axis_columns[0]}.png").is_file() == figures


def _sid(p: Any) -> int | None:
    try:
        return os.getsid(p.pid)
    except OSError:
        return None


TRIM_AT_COLLECTION = os.environ.get("MALLOC_TRIM_THRESHOLD_")


def test_local_workers_keep_glibc_trim_threshold(dask_client: Any) -> None:
    """dask gives its workers ``MALLOC_TRIM_THRESHOLD_=65536`` (freed memory back to the system at once): a run
    allocates and frees arrays every step and paid for it in page faults, a fifth of its CPU in the kernel.
    The local cluster leaves glibc's own threshold, unless this process's environment named one (read when this
    module was collected: a nanny writes dask's value into its parent's environment when it spawns)."""
    expected = TRIM_AT_COLLECTION
    seen = dask_client.run(lambda: os.environ.get("MALLOC_TRIM_THRESHOLD_"))
    assert set(seen.values()) == {expected}, seen


def test_local_workers_do_not_profile(dask_client: Any) -> None:
    """dask's statistical profiler is off in the local cluster's workers (it walked each run's stack every 10 ms
    and kept a tree per second of the last 1000 s, ``ftc_mj.study.cluster.LOCAL_CLUSTER_CONFIG``): a task that
    runs 1.3 s, longer than the profiler's 1 s cycle after which its samples show, leaves none in the workers'
    profile (about 100 with dask's default)."""
    import time

    dask_client.submit(time.sleep, 1.3, pure=False).result()
    assert dask_client.profile()["count"] == 0


def test_local_workers_monitor_memory_once_a_second(dask_client: Any) -> None:
    """The local cluster's slower housekeeping reaches the worker processes (dask's memory monitor polls every
    0.1 s by default; an idle worker spent 1.6 % of a core on housekeeping)."""
    import dask

    seen = dask_client.run(lambda: dask.config.get("distributed.worker.memory.monitor-interval"))
    assert set(seen.values()) == {"1s"}, seen


def _record_raised_in(filename: str, name: str, exc: type[BaseException]) -> logging.LogRecord:
    """tornado's "Exception in callback" record of ``exc`` raised by a function ``name`` compiled as ``filename``."""
    scope: dict[str, Any] = {}
    exec(compile(f"def {name}():\n    raise {exc.__name__}('x')\n", filename, "exec"), scope)  # noqa: S102
    try:
        scope[name]()
    except BaseException:  # noqa: BLE001 - the record carries whatever was raised
        info = sys.exc_info()
    return logging.LogRecord("tornado.application", logging.ERROR, __file__, 1, "Exception in callback %r",
                             ("cb",), info)


def test_sync_cancel_race_drops_that_record_only() -> None:
    """The filter drops tornado's record of distributed's ``sync`` ``cancel()`` race (a ``NameError`` raised in
    ``cancel`` of ``distributed/utils.py``, which failed the Ctrl-C test's one-line check on a loaded clean
    clone) and keeps any other error: another file, another function, another exception, no exception."""
    from ftc_mj.study.cluster import SyncCancelRace

    race = SyncCancelRace()
    upstream = "/venv/site-packages/distributed/utils.py"
    assert not race.filter(_record_raised_in(upstream, "cancel", NameError))
    assert race.filter(_record_raised_in("/venv/site-packages/distributed/client.py", "cancel", NameError))
    assert race.filter(_record_raised_in(upstream, "other", NameError))
    assert race.filter(_record_raised_in(upstream, "cancel", ValueError))
    assert race.filter(logging.LogRecord("tornado.application", logging.ERROR, __file__, 1, "plain", (), None))


def test_a_gather_of_forgotten_keys_only_is_dropped() -> None:
    """The scheduler's "Couldn't gather keys" record is dropped when every key is ``forgotten`` (the runs an
    interrupted study just cancelled, which failed the Ctrl-C test's one-line check on a clean clone) and kept when
    any key is still known, or for any other message."""
    from ftc_mj.study.cluster import ForgottenGather

    def record(msg: str, states: object) -> logging.LogRecord:
        return logging.LogRecord("distributed.scheduler", logging.ERROR, __file__, 1, msg, (states,), None)

    gather, drop = "Couldn't gather keys: %s", ForgottenGather()
    assert not drop.filter(record(gather, {"ftc-run-a": "forgotten", "ftc-run-b": "forgotten"}))
    assert drop.filter(record(gather, {"ftc-run-a": "forgotten", "ftc-run-b": "memory"}))
    assert drop.filter(record(gather, {}))
    assert drop.filter(record("Other %s", {"ftc-run-a": "forgotten"}))


def test_the_client_drops_the_sync_cancel_race_while_open(dask_client: Any) -> None:
    """The session's client (``open_client``) has the filters on tornado's callback-error logger and the
    scheduler's."""
    from ftc_mj.study.cluster import ForgottenGather, SyncCancelRace

    assert any(isinstance(f, SyncCancelRace) for f in logging.getLogger("tornado.application").filters)
    assert any(isinstance(f, ForgottenGather) for f in logging.getLogger("distributed.scheduler").filters)
