"""Test-suite settings and session fixtures.

Strict mode: an exception inside a simulation fails the test that caused it instead of being recorded
as a failed run (the tests of the recorded failure turn it off). ``shared_runs``: the closed-loop runs
of :data:`tests.support.shared_runs.SHARED_RUNS`, each simulated once per session on first use;
``policy_runs``: two of them written as run directories with recordings; ``dask_client``: the suite's
one Dask cluster. Under pytest-xdist (``--dist loadgroup --no-loadscope-reorder`` from the pytest options)
every test that uses the cluster runs in one worker, and every other module's tests in one worker each, in
order, so its module-scoped fixtures are built once: the ``xdist_group`` of :func:`pytest_collection_modifyitems`.

Solver cache: the session's processes (xdist workers, CLI and example subprocesses, Dask workers)
share the suite's own IPOPT solver cache (:mod:`ftc_mj.control.solver_cache`), never the user's: pytest's
cache folder ``.pytest_cache/d/ftc-mj-solvers`` (kept between sessions like numba's cache beside the
sources, so each distinct NLP is derived once per clone; ``pytest --cache-clear`` empties it, entries
unused for 14 days are pruned), or a temporary folder removed at the end when pytest's cache is off
(``-p no:cacheprovider``). A loaded solver is bitwise the fresh build (``control/test_solver_cache.py``).

BLAS: one thread per process, as a run sets it when it builds its controller
(:func:`ftc_mj.control.blas.limit_blas_threads`). Tests that call the maths directly would otherwise run numpy's
and SciPy's OpenBLAS with a thread per core beside the other xdist worker: on two cores a 300-sample Cholesky of
the diagnoser's shape fit took 165 ms instead of 2 ms and one diagnosis test 43 s.

Hypothesis: no deadline per example (profile ``ftc-mj``). Its default of 200 ms is a timed assert, and on two
loaded cores an example that takes 0.1 ms alone took 271 ms once (``test_radius_directions_split_is_what_the_speed_
cannot_see``, a FlakyFailure); speed is measured in ``benchmarks/``."""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy loads OpenBLAS; inherited by subprocesses

import json
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import settings as hypothesis_settings

from ftc_mj.control.blas import limit_blas_threads
from ftc_mj.control.solver_cache import prune
from ftc_mj.disk_cache import CACHE_ENV, prune_values
from ftc_mj.estimation.calibration import THRESHOLD_FOLDER
from ftc_mj.sim.loop import STRICT_ENV
from tests.support.shared_runs import SharedRuns

hypothesis_settings.register_profile("ftc-mj", deadline=None)
hypothesis_settings.load_profile("ftc-mj")

os.environ[STRICT_ENV] = "1"
_OWN_CACHE: list[str] = []
SOLVER_CACHE_MAX_AGE_S = 14 * 86400.0
"""Cached solvers and thresholds unused this long (s) are deleted when a session starts."""


def pytest_configure(config: pytest.Config) -> None:
    """One BLAS thread in every process of the session (module docstring); the suite's solver cache, chosen by
    the main process (xdist workers inherit the variable)."""
    limit_blas_threads(1)
    if hasattr(config, "workerinput"):
        return
    if getattr(config, "cache", None) is not None:
        root = config.cache.mkdir("ftc-mj-solvers")
        prune(root / "solvers", SOLVER_CACHE_MAX_AGE_S)
        prune_values(root / THRESHOLD_FOLDER, SOLVER_CACHE_MAX_AGE_S)
    else:
        root = Path(tempfile.mkdtemp(prefix="ftc-mj-test-cache-"))
        _OWN_CACHE.append(str(root))
    os.environ[CACHE_ENV] = str(root)


def pytest_unconfigure(config: pytest.Config) -> None:
    """Remove the session's temporary solver cache (only one this process made)."""
    for folder in _OWN_CACHE:
        shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture(scope="session")
def shared_runs(tmp_path_factory: pytest.TempPathFactory) -> SharedRuns:
    """The session's shared closed-loop runs by name (``shared_runs["s2-puncture-5s-safe"]`` is a
    :class:`~ftc_mj.sim.run.RunOutcome`; ``shared_runs.run_dir(name)`` its run directory)."""
    return SharedRuns(tmp_path_factory.mktemp("shared-runs"))


@pytest.fixture(scope="session")
def policy_runs(shared_runs: SharedRuns) -> list[Path]:
    """Two short scenario-2 run directories with recordings, reconfiguration policy none and safe (the
    shared 5 s runs with the puncture at 3 s: declared at about 3.7 s, handed over at about 3.8 s)."""
    return [shared_runs.run_dir(f"s2-puncture-5s-{policy}", rrd=True) for policy in ("none", "safe")]


@pytest.fixture(scope="session")
def dask_client() -> Iterator[Any]:
    """A client of one LocalCluster for the whole session: 2 single-threaded worker processes on
    127.0.0.1 (:func:`ftc_mj.study.cluster.open_client`), started on first use, closed at the end.
    Tests pass it as ``client=`` instead of starting a cluster of their own. Its dashboard is given as
    ``--dashboard :0`` would give it (no host): ``test_local_cluster_listens_on_localhost_only`` checks
    that it listens on 127.0.0.1."""
    from ftc_mj.study.cluster import open_client

    with open_client(2, None, ":0") as client:
        yield client


MODULE_DURATIONS = Path(__file__).with_name("module_durations.json")
"""Each test module's summed duration (s) in a full warm session (``python tests/module_durations.py`` writes it
from pytest's cache): the order of a session without durations of its own."""
DURATIONS_KEY = "ftc-mj/durations"
"""pytest-cache key of every test's last duration (s, setup + call + teardown), by node id."""
_DURATIONS: dict[str, float] = {}


DASK_GROUP = "dask"
"""The ``xdist_group`` of the tests on the session's Dask cluster (``dask_client``)."""


def _group(item: pytest.Item) -> str:
    """The test's ``xdist_group``: :data:`DASK_GROUP` on the session's cluster, else its module's path."""
    return DASK_GROUP if "dask_client" in getattr(item, "fixturenames", ()) else _module(item.nodeid)


def _module(nodeid: str) -> str:
    return nodeid.split("::", 1)[0]


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist's own, which names the group in the node id
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Tests on the session's Dask cluster are one xdist group, so a parallel run (``-n 2``) still starts one
    cluster, and every other module is a group of its own, so its module-scoped fixtures are built once (xdist
    would otherwise hand out single tests, and both workers build a module's fixtures). The cluster's tests are
    collected first, so that their worker takes the group (about 40 s) at the start. The other modules follow
    longest first, by their tests' durations in the last session (pytest's cache; a test never timed counts as
    1 s), so that the two workers' last tests are short ones and they finish together (greedy
    longest-processing-time scheduling; ``--no-loadscope-reorder`` keeps this order); a module's tests stay
    together and in their order. Every worker reads the same cache, so the order is the same in each, as
    pytest-xdist requires. Without a last session (a fresh clone, as CI runs it) the modules' durations shipped
    in :data:`MODULE_DURATIONS` order them instead, so the longest modules still start first."""
    groups = {id(item): _group(item) for item in items}
    cache = getattr(config, "cache", None)
    last = cache.get(DURATIONS_KEY, {}) if cache is not None else {}
    module_time: dict[str, float] = {}
    for item in items:
        module = _module(item.nodeid)
        module_time[module] = module_time.get(module, 0.0) + float(last.get(item.nodeid, 1.0))
    if not last:
        shipped = json.loads(MODULE_DURATIONS.read_text()) if MODULE_DURATIONS.exists() else {}
        module_time = {m: float(shipped.get(m, t)) for m, t in module_time.items()}
    items.sort(key=lambda item: (groups[id(item)] != DASK_GROUP, -module_time[_module(item.nodeid)]))  # stable
    for item in items:
        item.add_marker(pytest.mark.xdist_group(groups[id(item)]))


def _ungrouped(nodeid: str) -> str:
    """``nodeid`` without the ``@group`` suffix pytest-xdist gives a grouped test's id in its reports."""
    head, sep, tail = nodeid.rpartition("@")
    return head if sep and tail in (DASK_GROUP, _module(head)) else nodeid


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    """Note each test's duration (in the main process, where xdist's workers report)."""
    key = _ungrouped(report.nodeid)
    _DURATIONS[key] = _DURATIONS.get(key, 0.0) + report.duration


def pytest_sessionfinish(session: pytest.Session) -> None:
    """Store this session's durations over the last ones (the main process only)."""
    cache = getattr(session.config, "cache", None)
    if cache is None or hasattr(session.config, "workerinput") or not _DURATIONS:
        return
    merged = {**cache.get(DURATIONS_KEY, {}), **{k: round(v, 3) for k, v in _DURATIONS.items()}}
    cache.set(DURATIONS_KEY, merged)
