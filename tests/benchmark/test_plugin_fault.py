"""A plug-in fault class (``examples/grip_fault.py``: ``grip_loss``, a tyre losing grip) registered by a
module that a benchmark definition file names: validated in a run config, injected into the MuJoCo plant
through its own effect, drawn, run and scored by ``ftc-mj bench --benchmark FILE``, and listed by
``ftc-mj components``."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import polars as pl
import pytest
import tomli_w
from typer.testing import CliRunner

from ftc_mj.benchmark.definition import definition_path, parse_definition
from ftc_mj.benchmark.methods import load_methods
from ftc_mj.benchmark.run import bench_run, plan_bench
from ftc_mj.cli import app
from ftc_mj.config import validate_config
from ftc_mj.errors import BadInput
from ftc_mj.plant.faults import fault_list
from ftc_mj.wiring.plant import build_plant

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
LOST = 0.6


@pytest.fixture
def grip_fault(monkeypatch: pytest.MonkeyPatch) -> str:
    """``examples/`` on ``sys.path`` (inherited by spawned Dask workers); the plug-in module's name."""
    monkeypatch.syspath_prepend(str(EXAMPLES))
    return "grip_fault"


def _config(module: str, **table: object) -> dict:
    fault = {"fault_class": "grip_loss", "target": "right", "onset": 0.1, "size": LOST, **table}
    return {"plugins": [module], "duration": 1.0, "faults": {"plugin": [fault]}}


def test_a_plugin_fault_scales_the_target_tyres_friction_from_its_onset(grip_fault: str) -> None:
    """Before the onset both tyres keep the MJCF's friction; from the onset step the right one has
    ``1 − size`` of it and the left one all of it; the truth columns say so; a reset heals the plant."""
    cfg = validate_config(_config(grip_fault))
    assert [(s.fault_class, s.target, s.onset, s.size) for s in fault_list(cfg.faults, 2.0)] == [
        ("grip_loss", "right", 0.1, LOST)]
    p = build_plant(cfg)
    tyres = list(p.layout.sphere_geoms)
    mu0 = p.model.geom_friction[tyres, 0].copy()
    p.advance(99)  # physics steps 0-98 (0.099 s): before the onset
    np.testing.assert_array_equal(p.model.geom_friction[tyres, 0], mu0)
    p.advance(2)
    np.testing.assert_allclose(p.model.geom_friction[tyres, 0], [(1 - LOST) * mu0[0], mu0[1]], rtol=0, atol=1e-15)
    assert p.fault_truth() == pytest.approx({"fault_grip_R": 1 - LOST, "fault_grip_L": 1.0})
    p.reset()
    np.testing.assert_array_equal(p.model.geom_friction[tyres, 0], mu0)


@pytest.mark.parametrize(("table", "field"), [
    ({"target": "speed"}, "faults.plugin[0].target"),
    ({"size": 1.5}, "faults.plugin[0].size"),
    ({"fault_class": "wheel_lock"}, "faults.plugin[0].fault_class"),
    ({"fault_class": "no_such_fault"}, "faults.plugin[0].fault_class"),
])
def test_bad_plugin_fault_tables_name_the_field(grip_fault: str, table: dict, field: str) -> None:
    with pytest.raises(BadInput) as err:
        validate_config(_config(grip_fault, **table))
    assert str(err.value).startswith(field) and "\n" not in str(err.value), str(err.value)
    with pytest.raises(BadInput, match="^faults.plugin\\[0\\].fault_class: 'grip_loss' acts on the mujoco plant"):
        validate_config({**_config(grip_fault), "plant": {"kind": "kinematic"}})


def _definition(module: str) -> dict:
    """ftc-v1 with 2 s runs whose every draw is a grip loss early in the run."""
    data = tomllib.loads(definition_path("ftc-v1").read_text())
    data.update(version="grip-test", duration=2.0, plugins=[module])
    data["fault"] = {"classes": {"grip_loss": 1.0}, "double": 0.0, "onset": [0.5, 0.8], "second_delay": [1.0, 2.0],
                     "grip_loss": [0.5, 0.7]}
    return data


def test_a_definition_checks_the_ranges_its_classes_read(grip_fault: str) -> None:
    data = _definition(grip_fault)
    del data["fault"]["grip_loss"]
    with pytest.raises(BadInput, match="^benchmark x.toml: fault.grip_loss: grip_loss draws from this range"):
        parse_definition(data, "benchmark x.toml")
    data = _definition(grip_fault)
    data["fault"]["speed_bias"] = [0.1, 0.2]
    with pytest.raises(BadInput, match="^benchmark x.toml: fault.speed_bias: unknown key"):
        parse_definition(data, "benchmark x.toml")
    data = _definition(grip_fault)
    data["fault"]["classes"] = {"mud_patch": 1.0}  # no module registers it
    with pytest.raises(BadInput, match="^benchmark x.toml: fault: unknown name 'mud_patch'"):
        parse_definition(data, "benchmark x.toml")
    with pytest.raises(BadInput, match="^benchmark x.toml: plugins: cannot import 'no_such_fault_mod'"):
        parse_definition({**_definition(grip_fault), "plugins": ["no_such_fault_mod"]}, "benchmark x.toml")


def test_bench_draws_injects_and_scores_a_plugin_fault_class(grip_fault: str, tmp_path: Path) -> None:
    """``ftc-mj bench feedback-off --benchmark FILE`` on one draw: the draw names the plug-in class, the run
    carries the definition's plugin and its fault (truth columns and event), the scorer judges it (not a
    radius fault: any declared wheel is a wrong isolation), and ``ftc-mj components`` lists it."""
    path = tmp_path / "grip-test.toml"
    path.write_text(tomli_w.dumps(_definition(grip_fault)))
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["bench", "feedback-off", "--benchmark", str(path), "--draws", "1", "--workers",
                                   "1", "--compare", "0", "--out", str(out), "-q"])
    assert res.exit_code == 0, res.stderr + res.stdout
    draws = pl.read_parquet(out / "draws.parquet").to_dicts()
    assert draws[0]["fault_class"] == "grip_loss" and 0.5 <= draws[0]["fault1_size"] <= 0.7
    row = pl.read_parquet(out / "scores.parquet").to_dicts()[0]
    assert row["fault_class"] == "grip_loss" and row["status"] == "ok" and row["isolation"] in ("none", "wrong")
    assert row["benchmark"] == "grip-test"
    # the bench keeps no run folders: the same run again, in-process, through the bench's own worker function
    planned = plan_bench(load_methods(["feedback-off"]), "dev", 1, version=str(path)).plan.runs[0]
    assert planned.config["plugins"] == [grip_fault]
    assert planned.config["faults"]["plugin"][0]["fault_class"] == "grip_loss"
    outcome = bench_run(validate_config(planned.config), None, False)
    assert {k: outcome.metrics[k] for k in ("contouring_max", "isolation", "lorden_delay_bound")} == {
        k: row[k] for k in ("contouring_max", "isolation", "lorden_delay_bound")}
    tr, d = outcome.result.trace, draws[0]
    t, grip = np.asarray(tr["t"]), np.asarray(tr[f"fault_grip_{'R' if d['fault1_target'] == 'right' else 'L'}"])
    assert np.all(grip[t < d["fault1_onset"] - 0.011] == 1.0)
    assert np.allclose(grip[t > d["fault1_onset"]], 1 - d["fault1_size"])
    assert any(e.text.startswith(f"fault injected: grip_loss on {d['fault1_target']}") for e in outcome.result.events)
    res = CliRunner().invoke(app, ["components", "--plugin", grip_fault])
    assert res.exit_code == 0 and "  grip_loss: grip loss of the tyre" in res.stdout
    assert "drawn as grip_loss" in res.stdout

