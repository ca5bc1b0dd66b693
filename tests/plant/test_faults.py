"""RadiusSchedule: piecewise-linear tyre radius profiles."""

from __future__ import annotations

import math

import pytest

from ftc_mj.errors import BadInput
from ftc_mj.plant import RadiusSchedule


def test_empty_schedule_is_nominal_and_inactive() -> None:
    s = RadiusSchedule([], 2.0)
    assert not s.active
    assert s.value(0.0) == 2.0 and s.value(1e6) == 2.0
    assert not s.changing(0.0, 100.0)
    assert s.final == 2.0


def test_step_is_right_continuous_and_held() -> None:
    s = RadiusSchedule([(5.0, 2.0), (5.0, 1.0)], 2.0)
    assert s.active
    assert s.value(4.999) == 2.0
    assert s.value(5.0) == 1.0  # the new value holds at the step time
    assert s.value(100.0) == 1.0
    assert s.end_time == 5.0


def test_scenario4_ramp() -> None:
    s = RadiusSchedule([(10.0, 2.0), (29.0, 0.1)], 2.0)
    assert s.value(0.0) == 2.0
    assert s.value(10.0) == 2.0
    for t in (12.0, 15.5, 20.0, 28.9):
        assert s.value(t) == pytest.approx(2.0 - 0.1 * (t - 10.0), abs=1e-12)
    assert s.value(29.0) == pytest.approx(0.1)
    assert s.value(40.0) == pytest.approx(0.1)


def test_first_breakpoint_off_nominal_is_a_step() -> None:
    s = RadiusSchedule([(3.0, 1.5)], 2.0)
    assert s.value(2.99) == 2.0 and s.value(3.0) == 1.5
    assert s.changing(2.5, 3.5)
    assert not s.changing(3.0, 4.0)  # at exactly t0 the new value already holds


def test_step_then_ramp_back_up() -> None:
    s = RadiusSchedule([(1.0, 2.0), (1.0, 0.5), (2.0, 0.5), (4.0, 2.0)], 2.0)
    assert s.value(1.5) == 0.5
    assert s.value(3.0) == pytest.approx(1.25)
    assert s.value(5.0) == 2.0


def test_changing_windows() -> None:
    s = RadiusSchedule([(10.0, 2.0), (20.0, 1.0)], 2.0)
    assert not s.changing(0.0, 9.99)
    assert s.changing(9.995, 10.005)
    assert s.changing(15.0, 15.009)
    assert not s.changing(20.0, 30.0)
    flat = RadiusSchedule([(1.0, 2.0), (5.0, 2.0)], 2.0)  # breakpoints that do not change the value
    assert not flat.active and not flat.changing(0.0, 10.0)


@pytest.mark.parametrize(
    "bps",
    [
        [(1.0, 0.0)],
        [(1.0, -1.0)],
        [(2.0, 1.0), (1.0, 1.0)],
        [(-1.0, 1.0)],
        [(1.0, math.nan)],
        [(1.0, 2.0), (1.0, 1.5), (1.0, 1.0)],
        [(1.0,)],
    ],
)
def test_invalid_schedules_raise(bps: list) -> None:
    with pytest.raises(ValueError) as ei:
        RadiusSchedule(bps, 2.0, "faults.left")
    assert isinstance(ei.value, BadInput)
    assert "faults.left" in str(ei.value)


def test_evaluation_is_cheap() -> None:
    import timeit

    s = RadiusSchedule([(10.0, 2.0), (29.0, 0.1)], 2.0)
    per_call = timeit.timeit(lambda: s.value(15.0), number=20000) / 20000
    assert per_call < 5e-6
