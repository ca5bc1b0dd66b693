"""Configuration loading: the built-in scenarios hold the paper's values, overrides reach any key,
unknown keys and bad fault schedules are rejected (property tests). Every kind of bad value:
``test_bad_values.py``."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ftc_mj.config import BUILTIN_SCENARIOS, RunConfig, load_config, parse_override
from ftc_mj.errors import BadInput


@pytest.mark.parametrize("name", BUILTIN_SCENARIOS)
def test_builtin_scenarios_load(name: str) -> None:
    cfg = load_config(name)
    assert cfg.name == name
    assert cfg.duration == 40.0
    # the paper's fixed values are the defaults
    assert cfg.sensors.speed_sigma == 0.5
    assert cfg.estimator.kappa == 0.001
    assert cfg.controller.nodes == 50 and cfg.controller.horizon == 5.0
    assert cfg.physics_per_estimator == 10 and cfg.estimator_per_controller == 10


def test_scenario_faults_match_paper() -> None:
    assert load_config("scenario1").faults.left == []
    assert load_config("scenario2").faults.left == [(10.0, 2.0), (10.0, 1.0)]
    s3 = load_config("scenario3").faults
    assert s3.left == [(5.0, 2.0), (5.0, 1.0)] and s3.right == [(10.0, 2.0), (10.0, 1.0)]
    # scenario 4: R_L(t) = 2 - 0.1 (t - 10) reaches 0.1 m at t = 29 s
    (t0, r0), (t1, r1) = load_config("scenario4").faults.left
    assert (r0 - r1) / (t1 - t0) == pytest.approx(0.1)


def test_overrides_reach_any_key() -> None:
    cfg = load_config("scenario2", dict([parse_override("sensors.yaw_rate_sigma=0.01"),
                                         parse_override("estimator.kind=imm-ukf"),
                                         parse_override("faults.right=[[3.0, 2.0], [3.0, 1.5]]")]))
    assert cfg.sensors.yaw_rate_sigma == 0.01
    assert cfg.estimator.kind == "imm-ukf"
    assert cfg.faults.right == [(3.0, 2.0), (3.0, 1.5)]


_KEYS = st.text(alphabet="abcdefghijklmnopqrstuvwxyz_", min_size=1, max_size=12)


@settings(max_examples=60, deadline=None)
@given(key=_KEYS, value=st.one_of(st.integers(), st.floats(allow_nan=False), st.text(max_size=5)))
def test_unknown_top_level_keys_rejected(key: str, value: object) -> None:
    if key in RunConfig.model_fields:
        return
    with pytest.raises(BadInput, match=key):
        load_config("scenario1", {key: value})


@settings(max_examples=60, deadline=None)
@given(bps=st.lists(st.tuples(st.floats(-5, 50), st.floats(-1, 3)), min_size=1, max_size=5))
def test_schedule_validation_property(bps: list[tuple[float, float]]) -> None:
    """A schedule is accepted iff times are >= 0 and non-decreasing, radii > 0, no triple points."""
    times = [t for t, _ in bps]
    ok = (all(t >= 0 for t in times) and all(r > 0 for _, r in bps)
          and all(a <= b for a, b in zip(times, times[1:], strict=False))
          and not any(a == b == c for a, b, c in zip(times, times[1:], times[2:], strict=False)))
    if ok:
        assert load_config("scenario1", {"faults.left": [list(b) for b in bps]}).faults.left == bps
    else:
        with pytest.raises(BadInput, match="faults.left"):
            load_config("scenario1", {"faults.left": [list(b) for b in bps]})
