"""A plug-in that returns a NaN or an infinity fails the run (one line naming the component and the
time; status failed, exit 1, the run folder kept with ``error_where``), in ``ftc-mj run`` and in a
study's row; nothing non-finite reaches the plant or the trace as data."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest
from typer.testing import CliRunner

import ftc_mj
from ftc_mj import registry
from ftc_mj.cli import app
from ftc_mj.sim.loop import STRICT_ENV

PLUGIN = textwrap.dedent('''
    """Components that go wrong at 1 s: controllers commanding NaN / +inf / -inf, an estimator whose
    left-radius estimate becomes NaN and one whose covariance becomes infinite."""
    import numpy as np

    import ftc_mj

    BAD = {"nan": float("nan"), "inf": float("inf"), "neg-inf": float("-inf")}


    class Poisoned:
        def __init__(self, value):
            self.value = value

        def reset(self):
            pass

        def solve(self, t, pose, radii, applied):
            bad = t >= 1.0 - 1e-9
            return ftc_mj.ControlOutput(omega=np.array([self.value if bad else 5.0, 5.0]))


    class PoisonedFilter:
        def __init__(self, context, part):
            self.x = np.array([*context.initial_pose, *context.nominal_radii], dtype=float)
            self.dt, self.k, self.part = context.estimator_dt, 0, part

        def step(self, u, z):
            self.k += 1
            x, P = self.x.copy(), 1e-4 * np.eye(5)
            if self.k * self.dt > 1.0:
                if self.part == "state":
                    x[4] = np.nan
                else:
                    P[3, 3] = np.inf
            return ftc_mj.FilterOutput(x=x, P=P, innovation=np.zeros(1), S=np.eye(1), nis=0.0,
                                       speed_innovation=0.0, speed_innovation_std=1.0)


    for name, value in BAD.items():
        ftc_mj.register_controller(f"poison-{name}", lambda s, c, ref, v=value: Poisoned(v))
    for part in ("state", "covariance"):
        ftc_mj.register_estimator(f"poison-{part}", lambda s, c, p=part: PoisonedFilter(c, p))
''')
MODULE = "poison_components_q"
BASE = ["--set", "plant.kind='kinematic'", "--duration", "2", "--no-rrd", "-q"]


@pytest.fixture
def poison(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """The plug-in module importable, strict mode off (a failure is recorded, not re-raised); its
    components unregistered afterwards."""
    folder = tmp_path / "plugin"
    folder.mkdir()
    (folder / f"{MODULE}.py").write_text(PLUGIN)
    monkeypatch.syspath_prepend(str(folder))
    monkeypatch.setenv(STRICT_ENV, "0")
    yield MODULE
    import sys

    sys.modules.pop(MODULE, None)
    registry._loaded_plugins.discard(MODULE)
    for name in ("nan", "inf", "neg-inf"):
        if f"poison-{name}" in registry.controllers.names():
            registry.controllers.unregister(f"poison-{name}")
    for part in ("state", "covariance"):
        if f"poison-{part}" in registry.estimators.names():
            registry.estimators.unregister(f"poison-{part}")


def failed_run(tmp_path: Path, args: list[str]) -> tuple[str, dict]:
    """Run the CLI with ``args``; exit 1 with one line on stderr; the one run folder's metrics."""
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["run", "scenario2", *args, *BASE, "--out", str(out)])
    assert res.exit_code == 1, res.stdout + res.stderr
    assert res.stderr.count("\n") == 1, res.stderr
    (run_dir,) = out.iterdir()
    return res.stderr, json.loads((run_dir / "metrics.json").read_text())


@pytest.mark.parametrize(("name", "shown"), [("nan", "nan"), ("inf", "inf"), ("neg-inf", "-inf")])
def test_a_plugin_controller_commanding_a_non_finite_rate_fails_the_run(poison: str, tmp_path: Path, name: str,
                                                                        shown: str) -> None:
    err, m = failed_run(tmp_path, ["--plugin", poison, "--controller", f"poison-{name}"])
    line = f"controller 'poison-{name}' returned a wheel-rate command that is not two finite numbers: [{shown}, 5]"
    assert line in err and "at t = 1.000 s" in err
    assert m["status"] == "failed" and m["error"] == f"NonFiniteOutput: {line} at t = 1.000 s"
    assert m["error_where"] == f"controller 'poison-{name}' ({poison}.Poisoned.solve)"
    assert m["exceptions"] == 1


@pytest.mark.parametrize("part", ["state", "covariance"])
def test_a_plugin_estimator_returning_a_non_finite_estimate_fails_the_run(poison: str, tmp_path: Path,
                                                                          part: str) -> None:
    err, m = failed_run(tmp_path, ["--plugin", poison, "--estimator", f"poison-{part}"])
    assert f"estimator 'poison-{part}' returned a non-finite {part}" in err and "at t = 1.000 s" in err
    assert m["status"] == "failed" and m["error_where"] == f"estimator 'poison-{part}' ({poison}.PoisonedFilter.step)"


def test_a_study_row_of_a_non_finite_plugin_is_failed(poison: str, tmp_path: Path) -> None:
    study = tmp_path / "poison.toml"
    study.write_text(textwrap.dedent(f"""
        name = "poison"
        scenario = "scenario2"
        [base]
        duration = 1.5
        plugins = ["{poison}"]
        "plant.kind" = "kinematic"
        [[axes]]
        key = "controller.kind"
        values = ["open-loop", "poison-nan"]
        [analysis]
        figures = false
    """))
    df = ftc_mj.run_study(study, tmp_path / "out", serial=True).results.sort("run_index")
    assert df["status"].to_list() == ["ok", "failed"]
    assert df["error"][1].startswith("NonFiniteOutput: controller 'poison-nan' returned")


def test_a_bench_run_of_a_non_finite_plugin_is_not_ok(poison: str) -> None:
    """The bench's worker function (:func:`ftc_mj.benchmark.run.bench_run`) on a draw-like run: the row's
    status is failed, with the error, and it is scored as a failure."""
    from ftc_mj.benchmark.run import bench_run
    from ftc_mj.config import load_config

    cfg = load_config("scenario2", {"plugins": [poison], "controller.kind": "poison-inf", "plant.kind": "kinematic",
                                    "duration": 1.5})
    m = bench_run(cfg, None, False).metrics
    assert m["status"] == "failed" and m["error"].startswith("NonFiniteOutput: controller 'poison-inf'")
    assert m["success"] is False
