"""The IPOPT solver cache: a loaded solver is bitwise the fresh build; the key follows the problem,
the options and nothing else; a broken file is rebuilt; the switch turns it off; a process keeps one
solver per structure in memory and loads it once."""

from __future__ import annotations

import json
import os
import time
import zlib
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from ftc_mj.control import solver_cache
from ftc_mj.control.solver_cache import disk_cached_solver, ipopt_solver, problem_key, prune
from ftc_mj.control.solvers import ipopt_options
from ftc_mj.disk_cache import CACHE_ENV, SWITCH_ENV

OPTS = ipopt_options(30, None, None)


def rosenbrock(a: float = 1.0) -> dict:
    """A small constrained NLP whose IPOPT path takes several iterations (so a difference would show)."""
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p", 2)
    f = (a - x[0]) ** 2 + 100 * (x[1] - x[0] ** 2) ** 2 + p[0] * (x[2] - x[1] ** 2) ** 2
    return {"x": x, "p": p, "f": f, "g": ca.vertcat(x[0] + x[1] + x[2], x[0] * x[2] - p[1])}


def solve(solver: ca.Function) -> tuple[np.ndarray, np.ndarray, int]:
    res = solver(x0=[-1.2, 1.0, 0.5], p=[3.0, 0.2], lbg=[-2.0, -1.0], ubg=[2.5, 1.0])
    return np.asarray(res["x"]).ravel(), np.asarray(res["lam_g"]).ravel(), int(solver.stats()["iter_count"])


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    monkeypatch.delenv(SWITCH_ENV, raising=False)
    monkeypatch.setattr(solver_cache, "stats", {"built": 0, "loaded": 0})
    monkeypatch.setattr(solver_cache, "_in_memory", {})
    monkeypatch.setattr(solver_cache, "_asked", {})
    return tmp_path / "solvers"


def test_a_process_loads_a_solver_once(cache: Path) -> None:
    """The second controller of the same problem gets the kept solver (no file read: the file may even be
    gone); results are those of the disk's copy, bit for bit."""
    solver_cache.stats["reused"] = 0
    first = ipopt_solver("t", rosenbrock(), OPTS)
    for path in cache.glob("t-*.casadi.z"):
        path.unlink()
    again = ipopt_solver("t", rosenbrock(), OPTS)
    assert again is first and solver_cache.stats == {"built": 1, "loaded": 0, "reused": 1}
    x0, l0, i0 = solve(disk_cached_solver("t", rosenbrock(), OPTS))
    x1, l1, i1 = solve(again)
    assert i0 == i1 and np.array_equal(x0, x1) and np.array_equal(l0, l1)


def test_one_solver_is_kept_per_structure(cache: Path) -> None:
    """A problem of the same structure with another constant replaces the kept solver (memory does not grow
    with the problems seen); another structure is kept beside it; ``forget_solvers`` drops them all."""
    solver_cache.stats["reused"] = 0
    a = ipopt_solver("t", rosenbrock(), OPTS)
    ipopt_solver("t", rosenbrock(a=2.0), OPTS)
    assert len(solver_cache._in_memory) == 1
    assert ipopt_solver("t", rosenbrock(), OPTS) is not a  # loaded again from the disk
    assert solver_cache.stats == {"built": 2, "loaded": 1, "reused": 0}
    ipopt_solver("u", rosenbrock(), OPTS)
    assert len(solver_cache._in_memory) == 2
    ipopt_solver("t", rosenbrock(), OPTS)
    assert solver_cache.stats["reused"] == 1
    solver_cache.forget_solvers()
    ipopt_solver("t", rosenbrock(), OPTS)
    assert solver_cache.stats == {"built": 3, "loaded": 2, "reused": 1}


def test_forget_keeps_the_solvers_asked_for_since(cache: Path) -> None:
    """``forget_solvers(not_asked_since=c)`` drops the kept solvers last asked for before the clock read ``c`` and
    keeps those asked for since (the per-process cache's memory budget keeps the current run's)."""
    solver_cache.stats["reused"] = 0
    ipopt_solver("t", rosenbrock(), OPTS)
    ipopt_solver("u", rosenbrock(), OPTS)
    c = solver_cache.asked_count()
    ipopt_solver("u", rosenbrock(), OPTS)
    assert solver_cache.forget_solvers(not_asked_since=c) == 1
    assert [json.loads(s)[0] for s in solver_cache._in_memory] == ["u"]
    assert solver_cache.forget_solvers(not_asked_since=solver_cache.asked_count()) == 1
    assert not solver_cache._in_memory


def test_a_loaded_solver_is_bitwise_the_fresh_build(cache: Path) -> None:
    fresh = disk_cached_solver("t", rosenbrock(), OPTS)
    loaded = disk_cached_solver("t", rosenbrock(), OPTS)
    assert solver_cache.stats == {"built": 1, "loaded": 1}
    assert len(list(cache.glob("t-*.casadi.z"))) == 1
    (x0, l0, i0), (x1, l1, i1) = solve(fresh), solve(loaded)
    assert i0 > 3 and i0 == i1
    assert np.array_equal(x0, x1) and np.array_equal(l0, l1)


def test_the_key_follows_the_problem_and_the_options() -> None:
    k = problem_key("t", rosenbrock(), OPTS)
    assert problem_key("t", rosenbrock(), OPTS) == k  # fresh symbols, same problem
    assert problem_key("t", rosenbrock(a=1.0 + 1e-12), OPTS) != k  # a constant
    assert problem_key("t", rosenbrock(), {**OPTS, "ipopt.max_iter": 29}) != k  # an option
    assert problem_key("u", rosenbrock(), OPTS) != k


def test_a_broken_file_is_rebuilt_and_replaced(cache: Path) -> None:
    disk_cached_solver("t", rosenbrock(), OPTS)
    (path,) = cache.glob("t-*.casadi.z")
    path.write_bytes(b"not a solver")
    solver = disk_cached_solver("t", rosenbrock(), OPTS)
    assert solver_cache.stats == {"built": 2, "loaded": 0}
    assert solve(solver)[2] > 3
    disk_cached_solver("t", rosenbrock(), OPTS)
    assert solver_cache.stats["loaded"] == 1  # the replacement is a good file


def test_switched_off_writes_nothing(cache: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(SWITCH_ENV, "off")
    disk_cached_solver("t", rosenbrock(), OPTS)
    disk_cached_solver("t", rosenbrock(), OPTS)
    assert solver_cache.stats == {"built": 2, "loaded": 0} and not cache.exists()


def test_a_load_marks_the_entry_used_and_prune_deletes_only_unused_ones(cache: Path) -> None:
    disk_cached_solver("t", rosenbrock(), OPTS)
    disk_cached_solver("u", rosenbrock(a=2.0), OPTS)
    (t_path,), (u_path,) = cache.glob("t-*.casadi.z"), cache.glob("u-*.casadi.z")
    old = time.time() - 3600.0
    for path in (t_path, u_path):
        os.utime(path, (old, old))
    disk_cached_solver("t", rosenbrock(), OPTS)  # a load: used now
    assert solver_cache.stats == {"built": 2, "loaded": 1}
    assert t_path.stat().st_mtime > old + 3000.0
    stale, fresh = cache / ".load-killed", cache / ".load-running"  # a killed load's temporary, a live one's
    for path in (stale, fresh):
        path.write_bytes(b"x")
    os.utime(stale, (old, old))
    assert prune(cache, 1800.0) == 1
    assert t_path.is_file() and not u_path.exists() and fresh.is_file() and not stale.exists()


def entry(cache: Path, name: str = "t") -> Path:
    (path,) = cache.glob(f"{name}-*.casadi.z")
    return path


def rebuilt_with_one_warning(capsys: pytest.CaptureFixture[str], cache: Path) -> ca.Function:
    """Ask for the solver of the damaged entry: it is rebuilt (not loaded), one warning line names the
    entry, and the replacement loads next time."""
    capsys.readouterr()
    solver = disk_cached_solver("t", rosenbrock(), OPTS)
    assert solver_cache.stats["loaded"] == 0 and solver_cache.stats["built"] == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("ftc-mj: warning: solver cache entry ") and "rebuilding" in err
    disk_cached_solver("t", rosenbrock(), OPTS)
    assert solver_cache.stats["loaded"] == 1 and capsys.readouterr().err == ""
    assert [p.name for p in cache.iterdir()] == [entry(cache).name]  # no temporary left
    return solver


def test_an_empty_function_under_the_key_is_rebuilt(cache: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The old format's poisoned entry: ``zlib.compress(b"")`` loads as an empty CasADi function."""
    disk_cached_solver("t", rosenbrock(), OPTS)
    entry(cache).write_bytes(zlib.compress(b""))
    assert solve(rebuilt_with_one_warning(capsys, cache))[2] > 3


def test_an_empty_function_with_a_forged_header_is_rebuilt(cache: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A header that matches the key, checksum and shapes cannot make an empty function load: the loaded
    function itself must have the name and shapes of the problem's ``nlpsol``."""
    disk_cached_solver("t", rosenbrock(), OPTS)
    payload = zlib.compress(b"")
    key = problem_key("t", rosenbrock(), OPTS)
    head = json.dumps(solver_cache.header(key, "t", rosenbrock(), payload)).encode()
    entry(cache).write_bytes(solver_cache.MAGIC + head + b"\n" + payload)
    rebuilt_with_one_warning(capsys, cache)


@pytest.mark.parametrize("other", ["max_iter=1", "another problem"])
def test_another_problems_solver_under_the_key_is_rebuilt(cache: Path, capsys: pytest.CaptureFixture[str],
                                                          other: str) -> None:
    """A valid entry of another problem (other options; other sizes) copied under this key is refused: its
    header records its own key (and shapes)."""
    if other == "max_iter=1":
        disk_cached_solver("t", rosenbrock(), {**OPTS, "ipopt.max_iter": 1})
    else:
        x, p = ca.SX.sym("x", 10), ca.SX.sym("p", 2)
        disk_cached_solver("t", {"x": x, "p": p, "f": ca.sumsqr(x - p[0]), "g": x[0] - p[1]}, OPTS)
    stranger = entry(cache)
    stranger.rename(cache / f"t-{problem_key('t', rosenbrock(), OPTS)}.casadi.z")
    solver_cache.stats.update(built=1, loaded=0)
    assert solve(rebuilt_with_one_warning(capsys, cache))[2] > 3  # max_iter=1 would stop after one iteration


@pytest.mark.parametrize("damage", ["bit flip", "truncated", "old format"])
def test_a_damaged_entry_is_rebuilt(cache: Path, capsys: pytest.CaptureFixture[str], damage: str) -> None:
    disk_cached_solver("t", rosenbrock(), OPTS)
    path = entry(cache)
    data = bytearray(path.read_bytes())
    if damage == "bit flip":
        data[-100] ^= 0x10  # in the payload: the checksum catches it
    elif damage == "truncated":
        data = data[: len(data) // 2]
    else:  # the format before headers: a valid solver, compressed, without a record of what it is
        data = bytearray(zlib.compress(ca.nlpsol("t", "ipopt", rosenbrock(), OPTS).serialize().encode()))
    path.write_bytes(bytes(data))
    rebuilt_with_one_warning(capsys, cache)


def test_a_named_pipe_as_entry_does_not_hang(cache: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Nothing ever writes to the pipe: a blocking open would wait forever."""
    cache.mkdir(parents=True)
    os.mkfifo(cache / f"t-{problem_key('t', rosenbrock(), OPTS)}.casadi.z")
    t0 = time.monotonic()
    solver_cache.stats.update(built=1)
    rebuilt_with_one_warning(capsys, cache)
    assert time.monotonic() - t0 < 60 and entry(cache).is_file()


def test_a_link_out_of_the_cache_is_not_followed(cache: Path, tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    disk_cached_solver("t", rosenbrock(), OPTS)
    outside = tmp_path / "elsewhere.casadi.z"
    entry(cache).rename(outside)  # a good entry, but outside the folder
    (cache / outside.name.replace("elsewhere", f"t-{problem_key('t', rosenbrock(), OPTS)}")).symlink_to(outside)
    solver_cache.stats.update(built=1)
    rebuilt_with_one_warning(capsys, cache)
    assert outside.is_file() and not entry(cache).is_symlink()  # the link was replaced, its target left alone


def test_a_folder_in_the_entrys_place_leaves_no_temporary(cache: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cache.mkdir(parents=True)
    (cache / f"t-{problem_key('t', rosenbrock(), OPTS)}.casadi.z").mkdir()
    for _ in range(2):
        assert solve(disk_cached_solver("t", rosenbrock(), OPTS))[2] > 3
    assert solver_cache.stats == {"built": 2, "loaded": 0}
    assert [p.name for p in cache.iterdir()] == [entry(cache).name]  # only the folder: no temporary file
    assert capsys.readouterr().err.count("cannot be used (not a regular file)") == 2


def test_a_full_disk_leaves_no_temporary(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """On a real full file system the entry cannot be written: the solver is built and used, and no
    temporary (a few MB each) is left behind in the cache folder."""
    from tests.support.small_disk import fill, small_tmpfs

    with small_tmpfs(tmp_path / "small", "1m") as mnt:
        if mnt is None:
            pytest.skip("no tmpfs can be mounted here")
        monkeypatch.setenv(CACHE_ENV, str(mnt))
        monkeypatch.delenv(SWITCH_ENV, raising=False)
        monkeypatch.setattr(solver_cache, "stats", {"built": 0, "loaded": 0})
        (mnt / "solvers").mkdir()
        fill(mnt)
        for _ in range(2):
            assert solve(disk_cached_solver("t", rosenbrock(), OPTS))[2] > 3
        assert solver_cache.stats == {"built": 2, "loaded": 0}
        assert list((mnt / "solvers").iterdir()) == []


def test_an_entry_over_the_size_bound_is_not_read(cache: Path, capsys: pytest.CaptureFixture[str],
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    disk_cached_solver("t", rosenbrock(), OPTS)
    monkeypatch.setattr(solver_cache, "MAX_ENTRY_BYTES", entry(cache).stat().st_size - 1)
    capsys.readouterr()
    disk_cached_solver("t", rosenbrock(), OPTS)
    assert solver_cache.stats == {"built": 2, "loaded": 0} and "larger than" in capsys.readouterr().err


POISON_RUN = ["run", "scenario2", "--duration", "2", "--set", "controller.solver='ipopt'", "--set",
              "plant.kind='kinematic'", "--no-rrd", "-q"]


def _cli_run(cache_dir: Path, out: Path) -> tuple[dict, str]:
    """``ftc-mj run`` of :data:`POISON_RUN` in a fresh process on the solver cache ``cache_dir``: the run's metrics
    and the process's stderr."""
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": str(root), "OMP_NUM_THREADS": "1", CACHE_ENV: str(cache_dir)}
    env.pop(SWITCH_ENV, None)
    proc = subprocess.run([sys.executable, "-m", "ftc_mj.cli", *POISON_RUN, "--out", str(out)], env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return json.loads((Path(proc.stdout.strip()) / "metrics.json").read_text()), proc.stderr


@pytest.fixture(scope="module")
def filled_cache(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    """A solver cache filled by a first ``ftc-mj run`` in a fresh process (an empty cache: it builds and stores
    every solver), and that run's metrics; each test poisons a copy of it."""
    root = tmp_path_factory.mktemp("filled-cache")
    good, _ = _cli_run(root / "cache", root / "first")
    return root / "cache", good


@pytest.mark.slow
@pytest.mark.parametrize("poison", ["empty function", "named pipe"])
def test_a_poisoned_cache_does_not_spoil_or_hang_a_run(tmp_path: Path, poison: str,
                                                       filled_cache: tuple[Path, dict]) -> None:
    """``ftc-mj run`` end to end in a fresh process: the cache is filled by a first run (``filled_cache``,
    shared by both poisons), every entry is then replaced (by ``zlib.compress(b"")``: an empty CasADi function;
    by a named pipe nothing writes to); the second run rebuilds, says so in one line per entry, solves as the
    first did and does not hang."""
    import shutil

    shutil.copytree(filled_cache[0], tmp_path / "cache")
    good = filled_cache[1]
    entries = sorted((tmp_path / "cache" / "solvers").glob("*.casadi.z"))
    assert entries and good["status"] == "ok" and good["solver_failures"] == 0
    for path in entries:
        path.unlink()
        if poison == "named pipe":
            os.mkfifo(path)
        else:
            path.write_bytes(zlib.compress(b""))
    again, err = _cli_run(tmp_path / "cache", tmp_path / "second")
    assert err.count("ftc-mj: warning: solver cache entry") == len(entries), err
    assert again["solver_failures"] == 0 and again["cross_track_rms"] == good["cross_track_rms"]
    assert all(p.is_file() for p in entries)  # replaced by good entries
