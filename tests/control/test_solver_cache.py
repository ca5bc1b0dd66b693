"""The IPOPT solver cache: a loaded solver is bitwise the fresh build; the key follows the problem,
the options and nothing else; a broken file is rebuilt; the switch turns it off."""

from __future__ import annotations

import os
import time
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from ftc_mj.control import solver_cache
from ftc_mj.control.solver_cache import CACHE_ENV, SWITCH_ENV, ipopt_solver, problem_key, prune
from ftc_mj.control.solvers import ipopt_options

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
    return tmp_path / "solvers"


def test_a_loaded_solver_is_bitwise_the_fresh_build(cache: Path) -> None:
    fresh = ipopt_solver("t", rosenbrock(), OPTS)
    loaded = ipopt_solver("t", rosenbrock(), OPTS)
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
    ipopt_solver("t", rosenbrock(), OPTS)
    (path,) = cache.glob("t-*.casadi.z")
    path.write_bytes(b"not a solver")
    solver = ipopt_solver("t", rosenbrock(), OPTS)
    assert solver_cache.stats == {"built": 2, "loaded": 0}
    assert solve(solver)[2] > 3
    ipopt_solver("t", rosenbrock(), OPTS)
    assert solver_cache.stats["loaded"] == 1  # the replacement is a good file


def test_switched_off_writes_nothing(cache: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(SWITCH_ENV, "off")
    ipopt_solver("t", rosenbrock(), OPTS)
    ipopt_solver("t", rosenbrock(), OPTS)
    assert solver_cache.stats == {"built": 2, "loaded": 0} and not cache.exists()


def test_a_load_marks_the_entry_used_and_prune_deletes_only_unused_ones(cache: Path) -> None:
    ipopt_solver("t", rosenbrock(), OPTS)
    ipopt_solver("u", rosenbrock(a=2.0), OPTS)
    (t_path,), (u_path,) = cache.glob("t-*.casadi.z"), cache.glob("u-*.casadi.z")
    old = time.time() - 3600.0
    for path in (t_path, u_path):
        os.utime(path, (old, old))
    ipopt_solver("t", rosenbrock(), OPTS)  # a load: used now
    assert solver_cache.stats == {"built": 2, "loaded": 1}
    assert t_path.stat().st_mtime > old + 3000.0
    assert prune(cache, 1800.0) == 1
    assert t_path.is_file() and not u_path.exists()
