"""Closed-loop runs shared by the whole test session (the ``shared_runs`` fixture of
``tests/conftest.py``): each is simulated once, on first use, and handed to every test that asks for
it by name. Tests read a shared run and never change it, and ask for it only while nothing is
monkeypatched (a run simulated under a patch would be shared with it)."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

from ftc_mj.config import RunConfig, load_config
from ftc_mj.sim import cache
from ftc_mj.sim.run import RunOutcome, execute, write_outcome

GYRO_RATE = {"sensors.yaw_rate_sigma": 0.01, "controller.rate_penalty": 1.0}
"""Scenario 2's sensing and cost of ``examples/run_scenario.py``: a yaw-rate gyro and the NMPC's
actuation-rate term."""
PUNCTURE_5S = {**GYRO_RATE, "duration": 5.0, "faults.left": [[3.0, 2.0], [3.0, 1.0]]}
"""Scenario 2 shortened to 5 s with the left puncture moved from 10 s to 3 s: the fault is declared at
about 3.7 s and the safe policy hands the estimate over at about 3.8 s."""

SHARED_RUNS: dict[str, tuple[str, dict[str, Any]]] = {
    "s2-puncture-5s-none": ("scenario2", {**PUNCTURE_5S, "reconfiguration.policy": "none"}),
    "s2-puncture-5s-safe": ("scenario2", {**PUNCTURE_5S, "reconfiguration.policy": "safe"}),
    "s2-gyro-rate-plan-direct-40s": ("scenario2", {**GYRO_RATE, "controller.rate_penalty_first_step": False,
                                                   "reconfiguration.policy": "direct"}),
    "s3-kinematic-gyro-12s": ("scenario3", {"duration": 12.0, "plant.kind": "kinematic",
                                            "sensors.yaw_rate_sigma": 0.01}),
}
"""name -> (scenario, overrides) of the shared runs (MuJoCo plant, UKF, NMPC unless the overrides say
otherwise): the 5 s runs hold a puncture, its detection and the safe policy's hand-over; the 40 s run
is the paper's whole scenario 2 (recovery on the path); the 12 s scenario-3 run has both onsets."""


class SharedRuns:
    """The shared runs by name: :meth:`outcome` simulates a run on first use (in memory), :meth:`run_dir`
    writes it once into the session's folder ``root``."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self._outcomes: dict[str, RunOutcome] = {}
        self._reused: dict[str, bool] = {}
        self._dirs: dict[tuple[str, bool], Path] = {}

    def config(self, name: str) -> RunConfig:
        """The resolved config of the shared run ``name``."""
        scenario, overrides = SHARED_RUNS[name]
        return load_config(scenario, overrides)

    def outcome(self, name: str) -> RunOutcome:
        """The shared run ``name`` (simulated now if it is its first use)."""
        if name not in self._outcomes:
            hits = cache.stats["controller_hits"]
            self._outcomes[name] = execute(self.config(name))
            self._reused[name] = cache.stats["controller_hits"] > hits
        return self._outcomes[name]

    def __getitem__(self, name: str) -> RunOutcome:
        return self.outcome(name)

    def reused_solver(self, name: str) -> bool:
        """Whether the shared run ``name`` ran on a cached (reset) controller instead of a fresh build."""
        self.outcome(name)
        return self._reused[name]

    def run_dir(self, name: str, rrd: bool = False) -> Path:
        """The shared run ``name`` written to a run directory (with its Rerun recording if ``rrd``)."""
        key = (name, rrd)
        if key not in self._dirs:
            out = self.outcome(name)
            mine = RunOutcome(out.run_id, copy.deepcopy(out.metrics), out.result, None)
            folder = self.root / ("rrd" if rrd else "no-rrd")
            self._dirs[key] = write_outcome(mine, self.config(name), folder, rrd).run_dir
        return self._dirs[key]
