"""Configuration loading and bad-input handling (one-line error naming the field, exit 2,
nothing written)."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from ftc_mj.cli import app
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


BAD = [
    (["--set", "bogus=1"], "bogus: unknown key"),
    (["--set", "sensors.colour=1"], "sensors.colour: unknown key"),
    (["--set", "duration=-1"], "duration:"),
    (["--set", "duration='abc'"], "duration:"),
    (["--set", "seed=1.5"], "seed:"),
    (["--set", "faults.left=[[10.0, 2.0], [5.0, 1.0]]"], "faults.left:"),
    (["--set", "faults.left=[[10.0, 2.0], [12.0, -1.0]]"], "faults.left:"),
    (["--set", "plant.model_file='models/nope.xml'"], "plant.model_file:"),
    (["--set", "estimator.rate=33"], "estimator.rate"),
    (["--set", "novalue"], "--set novalue"),
    (["--estimator", "kalman"], ""),
]


@pytest.mark.parametrize("args,needle", BAD)
def test_bad_input_exit_2_nothing_written(tmp_path: Path, args: list[str], needle: str) -> None:
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["run", "scenario1", "--out", str(out), *args])
    assert res.exit_code == 2, res.output
    assert not out.exists()
    if needle:
        lines = [ln for ln in res.stderr.strip().splitlines() if ln]
        assert len(lines) == 1, res.stderr
        assert needle in lines[0]


def test_missing_scenario_file(tmp_path: Path) -> None:
    res = CliRunner().invoke(app, ["run", str(tmp_path / "none.toml"), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2
    assert "scenario" in res.stderr
    assert not (tmp_path / "o").exists()


def test_invalid_toml_file(tmp_path: Path) -> None:
    p = tmp_path / "bad.toml"
    p.write_text("duration = = 3\n")
    res = CliRunner().invoke(app, ["run", str(p), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and "invalid TOML" in res.stderr
    assert not (tmp_path / "o").exists()


def test_broken_model_file(tmp_path: Path) -> None:
    bad = tmp_path / "broken.xml"
    bad.write_text("<mujoco><worldbody><body name='x'></worldbody></mujoco>")
    res = CliRunner().invoke(app, ["run", "scenario1", "--out", str(tmp_path / "o"),
                                   "--set", f"plant.model_file='{bad}'"])
    assert res.exit_code == 2, res.output
    assert "plant.model_file" in res.stderr
    assert not (tmp_path / "o").exists()


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
