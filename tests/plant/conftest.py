"""Fixtures of the plant tests: one MuJoCo plant of the default settings, built once and reset per test
(a reset plant behaves exactly like a new one: ``test_reset_plant_equals_a_new_one``)."""

from __future__ import annotations

import pytest

from ftc_mj.plant import Plant
from tests.plant.helpers import make_cfg, mujoco_plant


@pytest.fixture(scope="session")
def _default_plant() -> Plant:
    return mujoco_plant(make_cfg())


@pytest.fixture
def default_plant(_default_plant: Plant) -> Plant:
    """The MuJoCo plant of the default settings at t = 0 (shared: reset before each test)."""
    _default_plant.reset()
    return _default_plant
