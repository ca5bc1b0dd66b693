"""Fixtures of the control tests: the default circle, and MPCs built once per session.

Building an MPC (CasADi graphs, IPOPT, the QP plugin) costs seconds; solving costs milliseconds. A
reset MPC behaves exactly like a new one (what the simulation's solver cache relies on, checked by
``test_reset_controller_repeats_a_new_ones_loop``), so tests that only solve share their builds.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from ftc_mj.config import RunConfig
from ftc_mj.wiring.control import build_reference


@pytest.fixture(scope="session")
def circle():
    """The default reference: the 50 m counter-clockwise circle at 10 m/s from the origin."""
    return build_reference(RunConfig())


@pytest.fixture(scope="session")
def built() -> Callable:
    """``built(cls, *args, tag=None, **kwargs)``: ``cls(*args, **kwargs)`` built once per session and reset
    before each hand-out (``tag`` tells apart two instances a test needs at once). Not for tests that
    change a controller's attributes."""
    cache: dict[tuple, object] = {}

    def get(cls, *args, tag: str | None = None, **kwargs):
        key = (cls, tag, tuple(map(repr, args)), repr(sorted(kwargs.items())))
        ctl = cache.get(key)
        if ctl is None:
            ctl = cache[key] = cls(*args, **kwargs)
        else:
            ctl.reset()
        return ctl

    return get
