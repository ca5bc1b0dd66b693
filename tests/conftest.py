"""Test-suite settings: strict mode, so that an exception inside a simulation fails the test that
caused it instead of being recorded as a failed run (the tests of the recorded failure turn it off)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from ftc_mj.sim.loop import STRICT_ENV

os.environ[STRICT_ENV] = "1"


@pytest.fixture(scope="session")
def policy_runs(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """Two short scenario-2 run directories with recordings, reconfiguration policy none and safe
    (:func:`tests.support.runs.write_policy_runs`)."""
    from tests.support.runs import write_policy_runs

    return write_policy_runs(tmp_path_factory.mktemp("policy_runs"))
