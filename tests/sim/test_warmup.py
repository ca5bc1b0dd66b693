"""``ftc-mj warm-up``: its parts run in processes of their own, split so that no kernel is compiled twice, and
cover what the default run and the built-in benchmark methods use."""

from __future__ import annotations

import os

from ftc_mj.benchmark.methods import BUILTIN
from ftc_mj.config import load_config
from ftc_mj.sim.warmup import WARM_UP, WARM_UP_ALL, warm_up


def test_each_part_runs_in_a_fresh_process_of_its_own() -> None:
    """Two short parts on two processes: two process ids, neither this one, each part's CPU time measured."""
    parts = ((("scenario2", {"estimator.kind": "ukf", "controller.kind": "open-loop", "duration": 0.1}),),
             (("scenario2", {"estimator.kind": "none", "controller.kind": "nmpc", "duration": 0.1}),))
    out = warm_up(parts, processes=2)
    pids = {pid for pid, _ in out}
    assert len(out) == 2 and len(pids) == 2 and os.getpid() not in pids
    assert all(cpu > 0.0 for _, cpu in out)


def test_the_parts_split_the_filter_from_the_controllers_and_cover_the_methods() -> None:
    """The first part steps the filter of the default run and of every built-in method without an MPC; the
    other builds and steps the default run's MPC (with ``--all``: every MPC kind of the built-in methods)
    without a filter, so the two processes compile disjoint kernels."""
    default = load_config("scenario2")
    for parts, mpcs in ((WARM_UP, {default.controller.kind}),
                        (WARM_UP_ALL, {s["controller.kind"] for _, s in BUILTIN.values()})):
        cfgs = [[load_config(sc, ov) for sc, ov in part] for part in parts]
        assert len(cfgs) == 2
        filters = {c.estimator.kind for c in cfgs[0]}
        assert filters == {default.estimator.kind} == {s["estimator.kind"] for _, s in BUILTIN.values()}
        assert {c.controller.kind for c in cfgs[0]} == {"open-loop"}
        assert {c.estimator.kind for c in cfgs[1]} == {"none"}
        assert {c.controller.kind for c in cfgs[1]} == mpcs
        assert {(c.controller.kind, c.controller.solver) for c in cfgs[1]} == {(k, default.controller.solver)
                                                                               for k in mpcs}
