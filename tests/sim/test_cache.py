"""The per-process cache keeps what a next run reuses and nothing else: a bench worker's new draws (another
reference, another plant) reuse one tracking controller, retargeted, with traces bit for bit those of a
fresh build, and the cache holds one plant and one controller per method however many draws it has seen."""

from __future__ import annotations

import numpy as np

from ftc_mj.config import load_config
from ftc_mj.control import solver_cache
from ftc_mj.sim import cache
from ftc_mj.sim.run import execute

DRAWS = ({"reference.kind": "circle", "reference.radius": 3.0, "plant.tyre_friction": 0.9},
         {"reference.kind": "line", "reference.speed": 0.4, "plant.tyre_friction": 0.7},
         {"reference.kind": "figure8", "reference.radius": 2.5, "plant.tyre_friction": 0.8})
"""Three 'draws' of scenario 2 (1.5 s each): other paths, speeds and tyre frictions."""


def _trace(overrides: dict) -> dict[str, np.ndarray]:
    return execute(load_config("scenario2", {"duration": 1.5, **overrides})).result.trace


def test_new_draws_reuse_one_retargeted_controller_bitwise() -> None:
    cache.clear()
    reused = []
    for i, draw in enumerate(DRAWS):
        hits = cache.stats["controller_hits"]
        reused.append(_trace(draw))
        assert cache.stats["controller_hits"] == hits + (i > 0)  # the first draw builds, the others reuse
        assert len(cache._controllers) == 1 and len(cache._plants) == 1
    for draw, trace in zip(DRAWS, reused, strict=True):
        cache.clear()
        fresh = _trace(draw)
        assert list(fresh) == list(trace)
        for col in fresh:
            if col != "solve_time_ms":  # wall clock
                np.testing.assert_array_equal(fresh[col], trace[col], err_msg=col)
    # the draws do track other paths
    assert not np.array_equal(reused[0]["cross_track_error"], reused[1]["cross_track_error"])


PF_DRAWS = ({"reference.kind": "circle", "reference.radius": 3.0, "reference.speed": 0.5, "plant.tyre_friction": 0.9},
            {"reference.kind": "circle", "reference.radius": 4.0, "reference.speed": 0.4, "reference.direction": "cw",
             "plant.tyre_friction": 0.7},
            {"reference.kind": "figure8", "reference.radius": 2.5, "reference.speed": 0.4, "plant.tyre_friction": 0.8})
"""Three 'draws' of the path-following NMPC: two circles (other radius, speed, direction and robot limits), then
another path kind (at 0.4 m/s: at scenario 2's 10 m/s, infeasible on 2.5 m lobes, every IPOPT solve stopped at
its iteration limit, 0.3 s each, and the run was the fallback's throughout)."""


def test_path_following_draws_share_one_controller_and_one_solver_per_path_kind() -> None:
    """The draw's path, desired speed and robot limits are parameters of the pf-nmpc's NLP: a second circle reuses
    the controller and its IPOPT solver (none built or loaded), and every retargeted run is bit for bit a fresh
    build's."""
    pf = {"controller.kind": "pf-nmpc"}
    cache.clear()
    reused, got = [], []
    for i, draw in enumerate(PF_DRAWS):
        hits = cache.stats["controller_hits"]
        reused.append(_trace({**pf, **draw}))
        got.append(solver_cache.stats["built"] + solver_cache.stats["loaded"])
        assert cache.stats["controller_hits"] == hits + (i > 0)
        assert len(cache._controllers) == 1
    assert got[1] == got[0]  # the second circle: no new solver
    for draw, trace in zip(PF_DRAWS, reused, strict=True):
        cache.clear()
        solver_cache.forget_solvers()
        fresh = _trace({**pf, **draw})
        for col in fresh:
            if col != "solve_time_ms":
                np.testing.assert_array_equal(fresh[col], trace[col], err_msg=col)
    assert not np.array_equal(reused[0]["pf_speed_desired"], reused[1]["pf_speed_desired"])


def test_above_the_memory_budget_a_build_drops_the_other_methods_parts(monkeypatch) -> None:  # noqa: ANN001
    """Two methods (the NMPC and the pf-nmpc) one after the other in one process: under the budget both are kept
    and the first is reused when it comes back; above it (budget 0 MiB) the second's build drops the first's
    controller and its solver (the run had not asked for it), so the first is built and loaded again — with a
    trace bit for bit the one it gave before."""
    a, b = {**DRAWS[0]}, {"controller.kind": "pf-nmpc", **PF_DRAWS[0]}
    for budget, kept in ((10**6, 2), (0, 1)):
        monkeypatch.setattr(cache, "MEMORY_BUDGET_MIB", budget)
        cache.clear()
        solver_cache.forget_solvers()
        first = _trace(a)
        _trace(b)
        assert len(cache._controllers) == kept
        builds, loads = cache.stats["controller_builds"], solver_cache.stats["loaded"] + solver_cache.stats["built"]
        again = _trace(a)
        assert cache.stats["controller_builds"] == builds + (kept == 1)
        assert solver_cache.stats["loaded"] + solver_cache.stats["built"] == loads + (kept == 1)
        for col in first:
            if col != "solve_time_ms":
                np.testing.assert_array_equal(again[col], first[col], err_msg=col)


def test_resident_memory_is_read() -> None:
    """The budget compares against this process's resident set: a positive number of MiB on Linux."""
    rss = cache.resident_mib()
    assert rss is not None and 10 < rss < 10**6


def test_above_the_budget_each_run_returns_free_pages_first(monkeypatch) -> None:  # noqa: ANN001
    """Above the budget a run starts by handing the malloc arenas' free pages back (``malloc_trim(0)``, no
    garbage collection); under it nothing is called."""
    calls: list[int] = []
    monkeypatch.setattr(cache, "_malloc_trim", lambda: calls.append)
    monkeypatch.setattr(cache.gc, "collect", lambda: calls.append(-1))
    for budget, expected in ((10**6, []), (0, [0])):
        monkeypatch.setattr(cache, "MEMORY_BUDGET_MIB", budget)
        calls.clear()
        cache.begin_run()
        assert calls == expected
