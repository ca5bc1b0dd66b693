"""``ftc-mj warm-up``: compile the numba kernels and build the IPOPT solvers a first run needs, on two cores.

Why: the compiled kernels (the filters', :mod:`ftc_mj.estimation.kernels`; the real-time iteration's,
:mod:`ftc_mj.control.kernels`) are compiled by numba on their first call and cached on disk, and the
controllers' IPOPT solvers are built once and cached (:mod:`ftc_mj.control.solver_cache`). After an install
the first run pays for all of it on one core. This command pays for it up front on two processes at once,
split so that no kernel is compiled twice and the two take about as long: one process steps the UKF (with
the open-loop controller), the other runs the default run's MPC, the RTI NMPC, without a filter
(:data:`WARM_UP`); ``--all`` (:data:`WARM_UP_ALL`) adds the other MPCs of the built-in benchmark methods, the
multi-stage robust and the path-following NMPC, to the second process. Each part is a short run of
scenario 2, with no output written.

Kernels of other filter kinds (EKF, IMM), and without ``--all`` those only the robust and path-following
NMPCs use, still compile on their first use.
"""

from __future__ import annotations

import multiprocessing
import os
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any

_FILTER = ("scenario2", {"estimator.kind": "ukf", "controller.kind": "open-loop", "duration": 0.5})
_MPC = {kind: ("scenario2", {"estimator.kind": "none", "controller.kind": kind, "duration": 0.5})
        for kind in ("nmpc", "robust-nmpc", "pf-nmpc")}
WARM_UP: tuple[tuple[tuple[str, dict[str, Any]], ...], ...] = ((_FILTER,), (_MPC["nmpc"],))
"""The warm-up's parts, one per process: each a sequence of (scenario, overrides) runs — what the default run
(``ftc-mj run scenario2``: UKF, RTI NMPC) compiles and builds."""
WARM_UP_ALL: tuple[tuple[tuple[str, dict[str, Any]], ...], ...] = ((_FILTER,), tuple(_MPC.values()))
"""``--all``: also the robust and the path-following NMPC (every MPC of the built-in benchmark methods)."""


Part = tuple[tuple[str, dict[str, Any]], ...]


def _part(runs: Part) -> tuple[int, float]:
    """Run one part's runs in this process (nothing written): the process id and the part's CPU seconds."""
    from ..config import load_config
    from .run import execute

    t = time.process_time()
    for scenario, overrides in runs:
        status = execute(load_config(scenario, overrides), None, rrd=False).metrics.get("status")
        if status != "ok":  # a run that failed has not compiled what follows its failure
            raise RuntimeError(f"warm-up run {scenario} {overrides}: {status}")
    return os.getpid(), time.process_time() - t


def warm_up(parts: tuple[Part, ...] = WARM_UP, processes: int = 2) -> list[tuple[int, float]]:
    """Run ``parts`` (default :data:`WARM_UP`) on ``processes`` fresh processes (spawned: nothing compiled or
    imported is inherited): each part's process id and CPU seconds."""
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=max(1, processes), mp_context=ctx) as pool:
        return list(pool.map(_part, parts))
