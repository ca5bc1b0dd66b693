"""Short simulated runs the tests share (written once per session by fixtures in ``tests/conftest.py``)."""

from __future__ import annotations

from pathlib import Path

PUNCTURE_RUN = {"duration": 5.0, "faults.left": [[3.0, 2.0], [3.0, 1.0]], "sensors.yaw_rate_sigma": 0.01,
                "controller.rate_penalty": 1}
"""Scenario 2 shortened to 5 s with the left puncture moved from 10 s to 3 s, a gyro and the rate
penalty: the fault is declared at about 3.7 s and the safe policy hands the estimate over at about 3.8 s."""


def write_policy_runs(out: Path, policies: tuple[str, ...] = ("none", "safe")) -> list[Path]:
    """One :data:`PUNCTURE_RUN` per reconfiguration policy written (with ``run.rrd``) under ``out``;
    their run directories, in the order of ``policies``."""
    import ftc_mj

    return [ftc_mj.run("scenario2", out, overrides={**PUNCTURE_RUN, "reconfiguration.policy": p}, rrd=True).path
            for p in policies]
