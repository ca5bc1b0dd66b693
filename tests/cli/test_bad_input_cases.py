"""One test per failure that a campaign of generated bad inputs found (the generated suites are
``tests/config/test_bad_values.py`` and ``tests/cli/test_bad_input.py``): a scheduler that never
answers, names escaping ``--out``, blown-up physics reported as success, output checked only after
simulating, non-finite numbers, tracebacks on odd files, unbounded study grids, boxed usage errors,
Ctrl-C noise, leftovers of killed runs, the dashboard listening on every interface."""

from __future__ import annotations

import errno
import json
import os
import signal
import socket
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest
from typer.testing import CliRunner

from ftc_mj import resources
from ftc_mj.cli import app
from ftc_mj.config import load_config
from ftc_mj.errors import EXIT_UNSTABLE, BadInput
from ftc_mj.plant import NAN, PHYSICS_WARNING, UNSTABLE
from ftc_mj.study.plan import plan_study
from ftc_mj.study.runner import run_study
from ftc_mj.wiring.plant import build_plant
from tests.support.fake_runs import FakeOutcome, FakeResult

ROOT = Path(__file__).resolve().parents[2]
MODEL = resources.resource_path("models", "diffdrive.xml")
QUICK = ["--duration", "0.5", "--controller", "open-loop", "--no-rrd", "-q"]


def one_error_line(res: Any) -> str:
    lines = res.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("ftc-mj: "), res.stderr
    return lines[0]


# ------------------------------------------------------------------------------------------ hang
def test_address_that_accepts_and_never_answers_fails_within_10_s(tmp_path: Path) -> None:
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    conns: list[socket.socket] = []

    def accept() -> None:
        while True:
            try:
                conns.append(srv.accept()[0])
            except OSError:
                return

    threading.Thread(target=accept, daemon=True).start()
    study = tmp_path / "s.toml"
    study.write_text('name = "s"\nscenario = "scenario1"\n')
    t0 = time.monotonic()
    try:
        res = CliRunner().invoke(app, ["study", str(study), "--out", str(tmp_path / "out"), "--address",
                                       f"tcp://127.0.0.1:{srv.getsockname()[1]}"])
    finally:
        srv.close()
        for c in conns:
            c.close()
    assert time.monotonic() - t0 < 10.0  # the acceptance bound (handshake timeout 6 s plus start-up)
    assert res.exit_code == 2 and "no dask scheduler answered within 6 s" in one_error_line(res)
    assert conns, "the CLI never connected"
    assert not (tmp_path / "out").exists()


# ------------------------------------------------------------------------------------------ names
@pytest.mark.parametrize("name", ["../../../x", "/abs/x", "a/b", ".hidden", "x" * 101, "a\0b", ""])
def test_run_names_never_leave_out(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str) -> None:
    work = tmp_path / "a" / "b" / "c"
    work.mkdir(parents=True)
    monkeypatch.chdir(work)
    (work / "s.toml").write_text(f"name = {json.dumps(name)}\nduration = 0.5\n")
    for args in (["run", "s.toml"], ["run", "scenario1", "--set", f"name={json.dumps(name)}"]):
        res = CliRunner().invoke(app, [*args, "--out", "out", *QUICK])
        assert res.exit_code == 2 and "name: " in one_error_line(res)
    assert sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*")) == [
        "a", "a/b", "a/b/c", "a/b/c/s.toml"]


# ------------------------------------------------------------------------------------------ unstable physics
def test_blown_up_physics_is_not_success(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """1000 m/s on a 1 mm circle (reported as status ok before): MuJoCo's state blows up in the first steps."""
    monkeypatch.chdir(tmp_path)
    res = CliRunner().invoke(app, ["run", "scenario2", "--set", "reference.speed=1000", "--set",
                                   "reference.radius=0.001", "--duration", "0.3", "--controller", "open-loop",
                                   "--out", "out", "-q"])
    assert res.exit_code == EXIT_UNSTABLE == 3, res.output
    assert "physics unstable" in one_error_line(res)
    (run_dir,) = (tmp_path / "out").iterdir()
    m = json.loads((run_dir / "metrics.json").read_text())
    assert m["status"] == "unstable" and m["physics_unstable_time"] <= 0.02
    assert m["plant_flags"] & UNSTABLE
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()  # MuJoCo's warnings did not land in the cwd
    assert res.stdout.strip() == str(Path("out") / run_dir.name)


def make_cfg(**ov: Any) -> Any:
    return load_config("scenario1", {"plant.start_moving": False, **ov})


def test_plant_flags_mujoco_instability_and_freezes() -> None:
    """A huge (finite) velocity trips MuJoCo's bad-qvel check, which resets the state to the model's
    initial one; the plant must flag UNSTABLE (not NAN: nothing became non-finite) and hold the last
    good state instead of the reset one."""
    p = build_plant(make_cfg())
    p.set_command(1.0, 1.0)
    p.advance(100)
    good = p.truth()
    p.data.qvel[0] = 1e12  # above MuJoCo's 1e10 "huge value" bound
    p.advance(1)
    tr = p.truth()
    assert p.frozen and tr.flags & UNSTABLE and tr.flags & PHYSICS_WARNING and not tr.flags & NAN
    assert tr.x == pytest.approx(good.x, abs=1e-9) and tr.t == pytest.approx(0.101)
    assert p.data.warning[mujoco.mjtWarning.mjWARN_BADQVEL].number > 0
    p.advance(50)  # frozen: time runs, the state does not
    assert p.truth().x == pytest.approx(good.x, abs=1e-9) and p.time == pytest.approx(0.151)
    p.reset()
    assert not p.frozen and not p.truth().flags & UNSTABLE


def fake_run(cfg: Any, out_root: Path | None, rrd: bool) -> FakeOutcome:
    """Instantaneous run: ``sensors.speed_sigma = 0.7`` plays a run whose physics blew up (a frozen robot
    with an absurd cross-track error); the others are well-behaved."""
    n = int(cfg.duration * cfg.estimator.rate)
    blown = cfg.sensors.speed_sigma == 0.7
    status = "unstable" if blown else "ok"
    m = {"status": status, "error": "physics unstable" if blown else None,
         "cross_track_rms": 1000.0 if blown else 0.1 + 0.01 * cfg.seed, "estimator": cfg.estimator.kind}
    return FakeOutcome(m, FakeResult({"t": np.arange(n) / cfg.estimator.rate}))


STUDY = """
name = "u"
scenario = "scenario2"
seeds = 3
[base]
duration = 1.0
[[axes]]
key = "sensors.speed_sigma"
values = [0.5, 0.7]
[[analysis.findings]]
metric = "cross_track_rms"
axis = "sensors.speed_sigma"
unit = "m"
"""


def test_study_counts_unstable_runs_apart(tmp_path: Path) -> None:
    p = tmp_path / "u.toml"
    p.write_text(textwrap.dedent(STUDY))
    rep = run_study(plan_study(p), tmp_path / "out", serial=True, run_fn=fake_run)
    assert len(rep.unstable) == 3 and len(rep.failed) == 3
    text = (tmp_path / "out" / "summary.md").read_text()
    assert "(3 ok, 0 failed, 3 with unstable physics, excluded from every statistic)" in text
    assert "1000" not in text.split("## Failed runs")[0]  # never averaged into a table or finding
    assert text.count("physics unstable") == 3  # listed with the failed runs


# ------------------------------------------------------------------------------------------ checked too late
def test_output_problems_are_found_before_simulating(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import ftc_mj.sim.run as run_mod

    def never(*a: Any, **k: Any) -> Any:
        raise AssertionError("simulated before checking the output folder")

    monkeypatch.setattr(run_mod, "simulate", never)
    (tmp_path / "afile").write_text("x")
    cases = [(str(tmp_path / "afile" / "sub"), "is a file, not a folder"), ("/sys/ftc-mj-out", "cannot write in /sys"),
             (str(tmp_path / ("n" * 300)), "path component is longer than"),
             ("/".join([str(tmp_path)] + ["p" * 200] * 21), "the path is too long")]
    for out, msg in cases:
        res = CliRunner().invoke(app, ["run", "scenario1", "--out", out, *QUICK])
        assert res.exit_code == 2 and msg in one_error_line(res), (out, res.stderr)
    import ftc_mj.sim.output as output_mod

    monkeypatch.setattr(output_mod.shutil, "disk_usage", lambda p: type("U", (), {"free": 1000})())
    res = CliRunner().invoke(app, ["run", "scenario1", "--out", str(tmp_path / "o"), *QUICK])
    assert res.exit_code == 2 and "MB free in" in one_error_line(res)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]


def test_write_failure_exits_1_and_keeps_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import ftc_mj.sim.run as run_mod

    def full_disk(*a: Any, **k: Any) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(run_mod, "write_parquet", full_disk)
    out = tmp_path / "deep" / "out"
    res = CliRunner().invoke(app, ["run", "scenario1", "--out", str(out), *QUICK])
    assert res.exit_code == 1 and "cannot write the run" in one_error_line(res) and "No space" in res.stderr
    assert list(tmp_path.iterdir()) == []  # not even the folders made for it


def test_empty_out_is_not_the_working_directory(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    res = CliRunner().invoke(app, ["run", "scenario1", "--out", "", *QUICK])
    assert res.exit_code == 2 and "--out: expected a folder path" in one_error_line(res)
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------------------------------ numbers
# the range and strict-type messages are checked in-process (tests/config/test_bad_values.py); through
# the CLI, one of each: the message reaches stderr whole and nothing is written
def test_non_finite_numbers_and_strict_types_name_the_range(tmp_path: Path) -> None:
    for key, value, msg in (("duration", "inf", "duration: must be a finite number in (0, 3600] s, got inf"),
                            ("output.rrd", '"yes"', 'output.rrd: Input should be a valid boolean, got "yes"')):
        res = CliRunner().invoke(app, ["run", "scenario1", "--set", f"{key}={value}", "--out", str(tmp_path / "o")])
        assert res.exit_code == 2 and msg in one_error_line(res)
        assert not (tmp_path / "o").exists()


# ------------------------------------------------------------------------------------------ tracebacks
def test_odd_scenario_files_are_one_line(tmp_path: Path) -> None:
    files = {"binary.toml": bytes(range(256)), "latin1.toml": 'description = "caf\xe9"\n'.encode("latin-1"),
             "nested.toml": ("a = " + "[" * 5000 + "]" * 5000 + "\n").encode()}
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
        res = CliRunner().invoke(app, ["run", str(tmp_path / name), "--out", str(tmp_path / "o")])
        assert res.exit_code == 2 and f"scenario {tmp_path / name}:" in one_error_line(res), res.stderr
    assert "not UTF-8" in CliRunner().invoke(app, ["run", str(tmp_path / "latin1.toml")]).stderr


def test_model_mujoco_cannot_simulate_is_bad_input(tmp_path: Path) -> None:
    """A model whose arena cannot hold a step (what a 20 000-body model does to the default arena) raises
    ``mujoco.FatalError`` inside MuJoCo; it is a one-line BadInput naming the model file."""
    tiny = tmp_path / "tiny.xml"
    tiny.write_text(MODEL.read_text().replace('<mujoco model="ftc_mj_diffdrive">',
                                              '<mujoco model="ftc_mj_diffdrive">\n  <size memory="4K"/>', 1))
    with pytest.raises(BadInput, match=r"plant.model_file: .*tiny.xml: MuJoCo cannot simulate it: mj_stackAlloc"):
        build_plant(make_cfg(**{"plant.model_file": str(tiny)}))
    res = CliRunner().invoke(app, ["run", "scenario1", "--set", f"plant.model_file='{tiny}'", "--out",
                                   str(tmp_path / "o"), *QUICK])
    assert res.exit_code == 2 and "plant.model_file" in one_error_line(res)
    assert not (tmp_path / "o").exists()


def test_corrupt_row_is_quarantined_and_recomputed(tmp_path: Path) -> None:
    p = tmp_path / "u.toml"
    p.write_text(textwrap.dedent(STUDY).replace("values = [0.5, 0.7]", "values = [0.5, 0.6]"))
    out = tmp_path / "out"
    plan = plan_study(p)
    run_study(plan, out, serial=True, run_fn=fake_run, analyse=False)
    victim = out / "rows" / f"{plan.runs[2].key}.parquet"
    victim.write_bytes(b"PAR1 torn by a crash")
    notes: list[str] = []
    rep = run_study(plan, out, serial=True, run_fn=fake_run, analyse=False, echo=notes.append)
    assert rep.computed == [plan.runs[2].key] and rep.results is not None and rep.results.height == 6
    assert len(notes) == 1 and "unreadable row" in notes[0] and plan.runs[2].key in notes[0]
    (q,) = (out / "rows" / "quarantine").iterdir()
    assert q.read_bytes() == b"PAR1 torn by a crash"


# ------------------------------------------------------------------------------------------ grids
def test_huge_grid_is_refused_at_once(tmp_path: Path) -> None:
    axes = "".join(f'[[axes]]\nkey = "{k}"\nvalues = [{", ".join(str(1.0 + i / 1000) for i in range(1000))}]\n'
                   for k in ("sensors.speed_sigma", "reference.radius"))
    p = tmp_path / "g.toml"
    p.write_text(f'name = "g"\nscenario = "scenario1"\n{axes}')
    with pytest.raises(BadInput, match=r"the plan has 1000000 runs \(1000 × 1000 × 1 seeds\); at most 10000"):
        plan_study(p)


# ------------------------------------------------------------------------------------------ messages
def test_usage_errors_are_one_line_exit_2() -> None:
    for args, msg in ((["run", "scenario1", "--bogus"], "No such option: --bogus"),
                      (["run", "scenario1", "--seed", "abc"], "Invalid value for '--seed'"),
                      (["runn"], "No such command 'runn'")):
        res = CliRunner().invoke(app, args)
        assert res.exit_code == 2 and msg in one_error_line(res) and "--help" in res.stderr
        assert "╭" not in res.stderr and "Usage" not in res.stderr
    # a component name is checked against the registry (plug-ins included), naming the flag
    res = CliRunner().invoke(app, ["run", "scenario1", "--estimator", "kalman"])
    assert res.exit_code == 2
    assert "--estimator: unknown estimator 'kalman'; registered: ekf, imm-ekf, imm-ukf, none" in one_error_line(res)


def test_imm_flags_and_contradicting_sets_are_errors(tmp_path: Path) -> None:
    imm_only = "not a setting of estimator 'ukf' (a setting of imm-ekf, imm-ukf)"
    for args, msg in ((["--imm-models", "5"], f"--imm-models: {imm_only}"),
                      (["--imm-models", "4"], f"--imm-models: {imm_only}"),  # the default: the CLI's own check
                      (["--estimator", "ukf", "--imm-variant", "paper"], f"--imm-variant: {imm_only}"),
                      (["--duration", "2", "--set", "duration=3"], "--duration: 2.0 contradicts --set duration=3"),
                      (["--controller", "lmpc", "--set", "controller.kind='nmpc'"], "--controller: 'lmpc'")):
        res = CliRunner().invoke(app, ["run", "scenario1", "--out", str(tmp_path / "o"), *args])
        assert res.exit_code == 2 and msg in one_error_line(res), res.stderr
    # the same value twice is no contradiction
    res = CliRunner().invoke(app, ["run", "scenario1", "--out", str(tmp_path / "o"), "--set", "duration=0.5",
                                   "--duration", "0.5", "--controller", "open-loop", "--no-rrd", "-q"])
    assert res.exit_code == 0, res.stderr


def test_view_of_a_non_recording_is_bad_input(tmp_path: Path) -> None:
    (tmp_path / "run.rrd").write_text("not a recording")
    res = CliRunner().invoke(app, ["view", str(tmp_path)])
    assert res.exit_code == 2 and "is not a Rerun recording" in one_error_line(res)


def test_view_without_display_points_to_the_screenshot_script(tmp_path: Path,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    from ftc_mj.rerun.record import write_rrd
    from tests.support.synthetic import synthetic_run

    trace, solves, events, ref = synthetic_run(2.0)
    write_rrd(tmp_path / "run.rrd", trace, run_id="r", solves=solves, events=events, reference_path=ref)
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    res = CliRunner().invoke(app, ["view", str(tmp_path)])
    line = one_error_line(res)
    assert res.exit_code == 1 and f"{tmp_path / 'run.rrd'} OUT.png" in line
    # the script is named by its installed path (a wheel has no docs/ folder), and it is there
    script = Path(line.split(" bash ", 1)[1].split()[0])
    assert script.is_file() and script.parent == resources.resource_path("screenshot.sh").parent
    assert "docs/" not in line


@pytest.mark.slow
def test_ctrl_c_on_a_study_is_one_line(tmp_path: Path) -> None:
    """SIGINT to the whole process group, as a terminal's Ctrl-C sends it: the worker processes ignore
    it, the client cancels, keeps what finished and says so in one line (exit 130)."""
    study = tmp_path / "s.toml"
    # enough runs that the study cannot end before the signal is acted upon (in a fresh clone under the suite's
    # load, 400 two-second runs once ended with exit 0 after the signal)
    study.write_text('name = "c"\nscenario = "scenario1"\nseeds = 2000\n[base]\nduration = 5.0\n'
                     '"controller.kind" = "open-loop"\n')
    out = tmp_path / "out"
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "ftc_mj.cli", "study", str(study), "--out", str(out),
                             "--workers", "2", "-q"], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.time() + 120
    while time.time() < deadline and proc.poll() is None and not (
            (out / "rows").is_dir() and list((out / "rows").glob("*.parquet"))):
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=120)  # the runs in flight finish and the cluster closes: slow under load
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("ftc-mj: interrupted: ") and "persisted" in lines[0], err


def test_workers_are_quiet_while_the_cluster_closes() -> None:
    """What each local worker runs before the cluster closes: a heartbeat failing against the closed scheduler
    (a worker still computing a cancelled run after Ctrl-C) logs nothing, tornado's own-level child included
    (the CI run that added this printed 31 lines of that traceback after the interrupt message)."""
    import logging

    from ftc_mj.study.cluster import QUIET_LOGGERS, _quiet_worker_logs

    names = ["distributed.worker", "tornado.application", *QUIET_LOGGERS]
    before = {n: logging.getLogger(n).level for n in names}
    try:
        logging.getLogger("tornado.application").setLevel(logging.ERROR)
        _quiet_worker_logs()
        assert not any(logging.getLogger(n).isEnabledFor(logging.ERROR) for n in names)
    finally:
        for n, level in before.items():
            logging.getLogger(n).setLevel(level)  # setLevel, not the attribute: it clears the loggers' caches


def test_leftovers_of_killed_runs_are_removed(tmp_path: Path) -> None:
    """Temporaries carry their writer's process id: those of dead processes go on the next run into the
    folder, a live writer's stay."""
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    out = tmp_path / "out"
    out.mkdir()
    stale_dir = out / f".scenario1_x.{dead.pid}.abcd1234.partial"
    stale_dir.mkdir()
    (stale_dir / "trace.parquet").write_text("half")
    stale_file = out / f".summary.csv.{dead.pid}.k2j4h5g6.tmp"
    stale_file.write_text("half")
    live = out / f".claims.md.{os.getpid()}.zzzz9999.tmp"
    live.write_text("being written")
    res = CliRunner().invoke(app, ["run", "scenario1", "--out", str(out), *QUICK])
    assert res.exit_code == 0, res.stderr
    names = sorted(p.name for p in out.iterdir())
    assert stale_dir.name not in names and stale_file.name not in names and live.name in names
    assert len([n for n in names if not n.startswith(".")]) == 1


# ------------------------------------------------------------------------------------------ network
def test_local_cluster_listens_on_localhost_only(dask_client: Any) -> None:
    """The suite's one LocalCluster (``dask_client``, opened by :func:`ftc_mj.study.cluster.open_client`
    as ``ftc-mj study`` opens its own): the dashboard and every listening socket of this process and its
    worker processes are on the loopback interface."""
    psutil = pytest.importorskip("psutil")

    assert dask_client.dashboard_link.startswith("http://127.0.0.1:")
    pids = {os.getpid(), *(c.pid for c in psutil.Process().children(recursive=True))}
    listening = [c for c in psutil.net_connections(kind="inet")
                 if c.status == psutil.CONN_LISTEN and c.pid in pids]
    assert listening and all(c.laddr.ip in ("127.0.0.1", "::1") for c in listening), listening
