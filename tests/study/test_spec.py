"""Study files: validation (one-line errors naming the field), plan expansion, CLI bad input.

Fast: nothing here simulates.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from ftc_mj import resources
from ftc_mj.cli import app
from ftc_mj.errors import BadInput
from ftc_mj.study.cluster import validate_address
from ftc_mj.study.plan import plan_study
from ftc_mj.study.rows import flatten_metrics
from ftc_mj.study.spec import key_error
from ftc_mj.study.stats import mean_ci, rate_ci

STUDIES = resources.resource_path("studies")


def write(tmp_path: Path, text: str, name: str = "s.toml") -> Path:
    p = tmp_path / name
    p.write_text(textwrap.dedent(text))
    return p


def test_grid_presets_seeds_expand(tmp_path: Path) -> None:
    p = write(tmp_path, """
        name = "t"
        scenario = "scenario2"
        seeds = [3, 4]
        [base]
        duration = 3.0
        estimator.kind = "ekf"
        [[axes]]
        key = "controller.kind"
        values = ["open-loop", "nmpc"]
        [[axes]]
        name = "sensors"
        labels = ["speed", "speed+yaw"]
        values = [{}, { "sensors.yaw_rate_sigma" = 0.01 }]
        """)
    plan = plan_study(p)
    assert len(plan.runs) == 2 * 2 * 2
    r = plan.runs[-1]
    assert r.labels == {"controller.kind": "nmpc", "sensors": "speed+yaw"} and r.seed == 4
    assert r.config["sensors"]["yaw_rate_sigma"] == 0.01 and r.config["duration"] == 3.0
    assert r.config["estimator"]["kind"] == "ekf" and r.config["faults"]["left"] == [[10.0, 2.0], [10.0, 1.0]]
    assert plan.runs[0].config["sensors"]["yaw_rate_sigma"] is None
    assert len({r.key for r in plan.runs}) == 8
    # stable keys and identity
    again = plan_study(p)
    assert [r.key for r in again.runs] == [r.key for r in plan.runs] and again.study_hash == plan.study_hash
    assert plan_study(p, seeds=1).study_hash != plan.study_hash


def test_list_axes_zip_and_random_draws_are_seeded(tmp_path: Path) -> None:
    p = write(tmp_path, """
        name = "t"
        scenario = "scenario1"
        [[axes]]
        key = "duration"
        kind = "list"
        values = [3.0, 4.0, 5.0]
        [[axes]]
        key = "sensors.speed_sigma"
        kind = "list"
        values = [0.1, 0.2, 0.3]
        [[axes]]
        key = "plant.tyre_friction"
        kind = "random"
        dist = "uniform"
        low = 0.5
        high = 1.0
        n = 4
        seed = 7
        [[axes]]
        key = "sensors.encoder_sigma"
        kind = "random"
        dist = "choice"
        choices = [0.1, 0.5]
        n = 4
        """)
    plan = plan_study(p)
    assert len(plan.runs) == 3 * 4  # list group (3, zipped) × random group (4, zipped)
    assert [(r.config["duration"], r.config["sensors"]["speed_sigma"]) for r in plan.runs[::4]] == [
        (3.0, 0.1), (4.0, 0.2), (5.0, 0.3)]
    fr = [r.config["plant"]["tyre_friction"] for r in plan.runs[:4]]
    assert all(0.5 <= f <= 1.0 for f in fr) and len(set(fr)) == 4
    assert fr == [r.config["plant"]["tyre_friction"] for r in plan_study(p).runs[:4]]


def test_placeholders_fill_fault_schedules() -> None:
    plan = plan_study(STUDIES / "severity.toml")
    by = {(r.labels["severity"], r.labels["wheel"], r.labels["estimator"], r.seed): r for r in plan.runs}
    r = by[(0.3, "right", "ukf", 1)]
    assert r.config["faults"]["right"] == [[8.0, 2.0], [8.0, 1.4]] and r.config["faults"]["left"] == []
    assert len(plan.runs) == 9 * 2 * 3 * 2


@pytest.mark.parametrize("name", ["observability", "mismatch", "severity"])
def test_shipped_studies_validate(name: str) -> None:
    plan = plan_study(STUDIES / f"{name}.toml")
    assert plan.spec.name == name and len(plan.runs) >= 8
    assert plan.spec.analysis.findings


@pytest.mark.parametrize(("body", "expect"), [
    ('[[axes]]\nkey = "sensors.yaw_rat"\nvalues = [0.1]', "axes[0].key (sensors.yaw_rat): unknown key 'yaw_rat'"),
    ('[[axes]]\nkey = "sensors.yaw_rate_sigma"\nvalues = []', "axes[0].values: empty axis"),
    ('[[axes]]\nkey = "sensors.speed_sigma"\nvalues = [-1.0]', "sensors.speed_sigma: must be a finite number in (0"),
    ('[[axes]]\nkey = "estimator.kind"\nvalues = ["kalman"]', "estimator.kind: unknown estimator 'kalman'; registered"),
    ('bogus = 1', "bogus: unknown key"),
    ('[base]\n"plant.frction" = 1.0', "base.plant.frction: unknown key 'frction'"),
    ('[[axes]]\nname = "a"\nvalues = [{ "sensors.yaw_rate_sigma" = 0.1 }, { "sensors.yaw" = 1 }]',
     "axes[0] (a) preset key sensors.yaw"),
    ('[[axes]]\nkey = "duration"\nkind = "random"\ndist = "normal"\nmean = 3.0\nn = 2', "axes[0].std: required"),
    ('[[axes]]\nkey = "duration"\nkind = "list"\nvalues = [3.0, 4.0]\n[[axes]]\nkey = "sensors.speed_sigma"\n'
     'kind = "list"\nvalues = [1.0]', "differ in length"),
    ('[[axes]]\nkey = "seed"\nvalues = [1, 2]', "axes[0].name: 'seed' is reserved"),
    ('[[axes]]\nkey = "duration"\nvalues = [3.0, 3.0]', "duplicate values"),
    ('[[axes]]\nname = "w"\nvalues = ["left"]', "sets no key and no placeholder uses it"),
    ('[base]\n"faults.left" = [[1.0, "{nope}"]]', "placeholder {nope} names no label axis"),
    ('seeds = 0', "seeds: Input should be greater than or equal to 1"),
])
def test_bad_study_one_line(tmp_path: Path, body: str, expect: str) -> None:
    p = write(tmp_path, f'name = "t"\nscenario = "scenario1"\n{body}\n')
    with pytest.raises(BadInput) as ei:
        plan_study(p)
    msg = str(ei.value)
    assert expect in msg and "\n" not in msg


def test_key_error() -> None:
    assert key_error("sensors.yaw_rate_sigma") is None
    assert key_error("faults.left") is None
    assert "unknown key" in (key_error("sensor.yaw") or "")
    assert "not a table" in (key_error("duration.x") or "")


@pytest.mark.parametrize("addr", ["tcp://foo", "http://a:1", "tcp://a:0", "tcp://a:70000", "a:1", "tcp://:80"])
def test_malformed_address(addr: str) -> None:
    with pytest.raises(BadInput):
        validate_address(addr)


def test_good_address() -> None:
    assert validate_address("tcp://127.0.0.1:8786") == "tcp://127.0.0.1:8786"
    assert validate_address("tcp://node-3.cluster:8786")


def test_flatten_metrics() -> None:
    f = flatten_metrics({"solve_time_ms": {"median": 1.0, "p95": float("nan")}, "a": [1, 2], "b": None})
    assert f == {"solve_time_ms_median": 1.0, "solve_time_ms_p95": None, "a": "[1, 2]", "b": None}


def test_confidence_intervals() -> None:
    e = mean_ci([1.0, 2.0, 3.0])
    assert e.mean == 2.0 and e.half == pytest.approx(4.302653 * 1.0 / 3**0.5, rel=1e-5)
    r = rate_ci([True, False, True, True, None])
    assert r.n == 4 and r.mean == 0.75 and 0.3 < r.lo < 0.75 < r.hi <= 1.0


def test_cli_bad_inputs_exit_2_and_touch_nothing(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("earlier")
    bad = write(tmp_path, 'name = "t"\nscenario = "scenario1"\n[[axes]]\nkey = "sensors.nope"\nvalues = [1]\n')
    empty = write(tmp_path, 'name = "t"\nscenario = "scenario1"\n[[axes]]\nkey = "duration"\nvalues = []\n', "e.toml")
    good = STUDIES / "severity.toml"
    runner = CliRunner()
    for args in ([str(bad)], [str(empty)], [str(good), "--address", "tcp://nohost"],
                 [str(good), "--address", "tcp://127.0.0.1:1"], [str(good), "--rrd", "some"]):
        res = runner.invoke(app, ["study", *args, "--out", str(out)])
        assert res.exit_code == 2, (args, res.output)
        lines = [ln for ln in res.output.splitlines() if ln.strip()]
        assert len(lines) <= 1 or "Usage" in res.output
        if "Usage" not in res.output:
            assert lines[0].startswith("ftc-mj: error:")
    assert sorted(p.name for p in out.iterdir()) == ["keep.txt"]


@settings(max_examples=15, deadline=None)
@given(grid=st.lists(st.integers(1, 3), min_size=0, max_size=2), zipped=st.integers(0, 3), seeds=st.integers(1, 3))
def test_plan_size_is_product_of_groups(tmp_path_factory: pytest.TempPathFactory, grid: list[int], zipped: int,
                                        seeds: int) -> None:
    keys = ["sensors.speed_sigma", "sensors.encoder_sigma"]
    body = f'name = "h"\nscenario = "scenario1"\nseeds = {seeds}\n'
    for k, n in zip(keys, grid, strict=False):
        body += f'[[axes]]\nkey = "{k}"\nvalues = {[0.1 * (i + 1) for i in range(n)]}\n'
    for k in ("duration", "plant.caster_friction")[: 2 if zipped else 0]:
        body += f'[[axes]]\nkey = "{k}"\nkind = "list"\nvalues = {[1.0 + i for i in range(zipped)]}\n'
    p = tmp_path_factory.mktemp("h") / "h.toml"
    p.write_text(body)
    plan = plan_study(p)
    expect = seeds * (zipped or 1)
    for n in grid:
        expect *= n
    assert len(plan.runs) == expect == len({r.key for r in plan.runs})
