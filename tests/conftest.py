"""Test-suite settings: strict mode, so that an exception inside a simulation fails the test that
caused it instead of being recorded as a failed run (the tests of the recorded failure turn it off)."""

from __future__ import annotations

import os

from ftc_mj.sim.loop import STRICT_ENV

os.environ[STRICT_ENV] = "1"
