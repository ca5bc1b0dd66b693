"""Plug-ins: the registries, entry points, ``plugins = [...]``, component options, and components
defined outside the package (``examples/my_components.py``: the ``textbook-ekf`` estimator and the
``late-handover`` policy) run from the CLI (``--plugin``) and in a study on a 2-worker LocalCluster."""

from __future__ import annotations

import json
import sys
import textwrap
import tomllib
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

import ftc_mj
from ftc_mj import registry
from ftc_mj.cli import app
from ftc_mj.config import load_config, validate_config
from ftc_mj.errors import BadInput

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture
def my_components(monkeypatch: pytest.MonkeyPatch) -> str:
    """``examples/`` on ``sys.path`` (inherited by spawned Dask workers); the plug-in module's name."""
    monkeypatch.syspath_prepend(str(EXAMPLES))
    return "my_components"


def test_registry_names_are_unique_checked_and_listed() -> None:
    reg = registry.estimators
    assert {"ekf", "ukf", "imm-ekf", "imm-ukf", "none"} <= set(reg.names())
    with pytest.raises(ValueError, match="'ukf' is already registered \\(built-in\\)"):
        ftc_mj.register_estimator("ukf", lambda cfg: None)
    with pytest.raises(ValueError, match="lower-case letters"):
        ftc_mj.register_estimator("My Filter", lambda cfg: None)
    with pytest.raises(TypeError, match="callable"):
        ftc_mj.register_estimator("not-callable", 3)  # type: ignore[arg-type]
    with pytest.raises(BadInput, match=r"^estimator.kind: unknown estimator 'nope' \(did you mean 'none'\?\); "
                                       "registered: ekf, imm-ekf"):
        validate_config({"estimator": {"kind": "nope"}})
    try:
        ftc_mj.register_estimator("probe-filter", lambda cfg: None)
        assert validate_config({"estimator": {"kind": "probe-filter"}}).estimator.kind == "probe-filter"
        assert registry.estimators.get("probe-filter").origin == __name__
        ftc_mj.register_estimator("probe-filter", lambda cfg: None, replace=True)
    finally:
        registry.estimators.unregister("probe-filter")
    assert "probe-filter" not in ftc_mj.components()["estimators"]


def test_entry_point_of_an_installed_package_registers(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A distribution on sys.path whose entry point ``ftc_mj.policies: ep-policy = ep_pkg:factory``
    registers ``ep-policy`` when the registry first loads; a broken one is named in one line."""
    (tmp_path / "ep_pkg.py").write_text("def factory(cfg):\n    return 'built by ep_pkg'\n"
                                        "def broken(cfg):\n    return None\n")
    dist = tmp_path / "ep_pkg-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: ep-pkg\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[ftc_mj.policies]\nep-policy = ep_pkg:factory\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    fresh = registry.Registry("policy", "ftc_mj.policies", "ftc_mj.reconfiguration.policies", "reconfiguration.policy")
    assert "ep-policy" in fresh.names() and "safe" not in fresh.names()  # built-ins registered in the global one
    assert fresh.build("ep-policy", None) == "built by ep_pkg"
    assert fresh.get("ep-policy").origin == "entry point ep_pkg:factory"
    (dist / "entry_points.txt").write_text("[ftc_mj.policies]\nbad-policy = ep_pkg:missing\n")
    broken = registry.Registry("policy", "ftc_mj.policies", "ftc_mj.reconfiguration.policies", "reconfiguration.policy")
    with pytest.raises(BadInput, match=r"entry point ftc_mj.policies:bad-policy = 'ep_pkg:missing' cannot be loaded"):
        broken.names()


def test_plugins_are_imported_before_the_names_are_checked(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "probe_plugin_mod.py").write_text(textwrap.dedent("""
        import ftc_mj
        ftc_mj.register_reference("probe-line", lambda cfg: None)
    """))
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        with pytest.raises(BadInput, match="reference.kind: unknown reference 'probe-line'"):
            validate_config({"reference": {"kind": "probe-line"}})
        cfg = validate_config({"plugins": ["probe_plugin_mod"], "reference": {"kind": "probe-line"}})
        assert cfg.plugins == ["probe_plugin_mod"] and cfg.reference.kind == "probe-line"
    finally:
        registry.references.unregister("probe-line")
        sys.modules.pop("probe_plugin_mod", None)
        registry._loaded_plugins.discard("probe_plugin_mod")
    with pytest.raises(BadInput, match=r"^plugins: cannot import 'no_such_mod_q': ModuleNotFoundError"):
        validate_config({"plugins": ["no_such_mod_q"]})
    with pytest.raises(BadInput, match=r"^plugins: 'a b' is not a module name"):
        validate_config({"plugins": ["a b"]})


def test_component_options_are_validated_by_their_settings(my_components: str) -> None:
    base = {"estimator.kind": "textbook-ekf"}
    cfg = load_config("scenario1", base, plugins=[my_components])
    assert cfg.estimator.options == {"q_scale": 1.0}  # resolved: the settings' defaults filled in
    for opts, msg in (({"q_scale": -1.0}, "estimator.options.q_scale: Input should be greater than 0"),
                      ({"bogus": 1}, "estimator.options.bogus: unknown key")):
        with pytest.raises(BadInput, match=f"^{msg}"):
            load_config("scenario1", {**base, "estimator.options": opts}, plugins=[my_components])
    with pytest.raises(BadInput, match=r"^controller.options: controller 'nmpc' takes no options \(got a\)"):
        load_config("scenario1", {"controller.options": {"a": 1}})


def test_cli_runs_a_plugin_estimator_and_policy(my_components: str, tmp_path: Path) -> None:
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["run", "scenario2", "--plugin", my_components, "--estimator", "textbook-ekf",
                                   "--reconfig", "late-handover", "--set", "estimator.options.q_scale=2.0",
                                   "--set", "plant.kind='kinematic'", "--set", "faults.left=[[0.5, 2.0], [0.5, 1.0]]",
                                   "--duration", "3", "--out", str(out), "--no-rrd", "-q"])
    assert res.exit_code == 0, res.stderr
    run_dir = Path(res.stdout.strip())
    m = json.loads((run_dir / "metrics.json").read_text())
    assert m["status"] == "ok" and m["estimator"] == "textbook-ekf" and m["policy"] == "late-handover"
    cfg = tomllib.loads((run_dir / "config.toml").read_text())
    assert cfg["plugins"] == [my_components] and cfg["estimator"]["options"] == {"q_scale": 2.0}
    run = ftc_mj.load_run(run_dir)
    assert run.config.estimator.kind == "textbook-ekf" and np.isfinite(run.trace["R_L_hat"].to_numpy()).all()
    res = CliRunner().invoke(app, ["run", "scenario2", "--plugin", "no_such_mod_q", "--out", str(out)])
    assert res.exit_code == 2 and res.stderr.startswith("ftc-mj: error: --plugin: cannot import 'no_such_mod_q'")
    res = CliRunner().invoke(app, ["components", "--plugin", my_components])
    assert res.exit_code == 0 and "textbook-ekf" in res.stdout and "late-handover" in res.stdout


STUDY = """
name = "plugins"
scenario = "scenario2"
seeds = 1
[base]
duration = 3.0
plugins = ["my_components"]
"plant.kind" = "kinematic"
"sensors.yaw_rate_sigma" = 0.01
"faults.left" = [[1.0, 2.0], [1.0, 1.0]]
[[axes]]
key = "estimator.kind"
values = ["ukf", "textbook-ekf"]
[[axes]]
key = "reconfiguration.policy"
values = ["safe", "late-handover"]
[analysis]
figures = false
"""


@pytest.mark.slow
def test_study_on_local_cluster_carries_plugin_components(my_components: str, dask_client: Any,
                                                          tmp_path: Path) -> None:
    """The workers know the plug-ins from the runs' ``plugins`` (imported when they validate a run).

    Runs on the session's LocalCluster, whose workers were spawned before ``examples/`` was on this
    process's ``sys.path``: the folder is put on theirs (not imported there), as a LocalCluster
    started now would inherit it, and taken off again afterwards."""
    study = tmp_path / "plugins.toml"
    study.write_text(STUDY)
    dask_client.run(_worker_sys_path, str(EXAMPLES), True)
    try:
        result = ftc_mj.run_study(study, tmp_path / "out", client=dask_client)
    finally:
        dask_client.run(_worker_sys_path, str(EXAMPLES), False)
    df = result.results.sort("run_index")
    assert df.height == 4 and df["status"].to_list() == ["ok"] * 4, df.select("status", "error")
    assert df["estimator"].to_list() == ["ukf", "ukf", "textbook-ekf", "textbook-ekf"]
    assert df["policy"].to_list() == ["safe", "late-handover"] * 2
    # the plug-in's runs are real estimates: the puncture at 1 s is seen in the left radius
    assert (df.filter(df["estimator"] == "textbook-ekf")["radius_final_error_L"].abs() < 0.3).all()
    assert ftc_mj.load_study(tmp_path / "out").results.height == 4


def _worker_sys_path(folder: str, add: bool) -> None:
    """Put ``folder`` first on (or take it off) the ``sys.path`` of the process this runs in."""
    if add:
        sys.path.insert(0, folder)
    else:
        sys.path.remove(folder)


def test_a_study_sweeps_a_plugin_setting(my_components: str, tmp_path: Path) -> None:
    study = tmp_path / "q.toml"
    study.write_text(textwrap.dedent("""
        name = "q"
        scenario = "scenario1"
        [base]
        plugins = ["my_components"]
        "estimator.kind" = "textbook-ekf"
        [[axes]]
        key = "estimator.options.q_scale"
        values = [1.0, 4.0]
    """))
    plan = ftc_mj.plan_study(study)
    assert [r.config["estimator"]["options"] for r in plan.runs] == [{"q_scale": 1.0}, {"q_scale": 4.0}]
    assert len({r.key for r in plan.runs}) == 2
    bad = study.read_text().replace("4.0]", "-4.0]")
    study.write_text(bad)
    with pytest.raises(BadInput, match=r"estimator.options.q_scale: Input should be greater than 0"):
        ftc_mj.plan_study(study)


class LeftBelow:
    """A plug-in decision rule: the left wheel once its estimate is below ``level`` (m), after 0.1 s."""

    dwell = 0.1

    def __init__(self, level: float) -> None:
        self.level = level

    def candidate(self, step: ftc_mj.estimation.DecisionStep) -> str | None:
        return "left" if step.out.x[4] < self.level else None


def test_a_plugin_decision_rule_decides_a_run() -> None:
    ftc_mj.register_decision_rule("left-below", lambda cfg: LeftBelow(0.8 * cfg.model_wheel_radius))
    try:
        run = ftc_mj.run("scenario2", overrides={
            "duration": 3.0, "plant.kind": "kinematic", "sensors.yaw_rate_sigma": 0.01,
            "faults.left": [[1.0, 2.0], [1.0, 1.0]], "estimator.decision.rule": "left-below"})
    finally:
        registry.decision_rules.unregister("left-below")
    m = run.metrics
    assert m["status"] == "ok" and m["isolated_wheel"] == "left"
    t_decl = m["detection_time"]
    # declared the 0.1 s dwell after the estimate first fell below 1.6 m (trace times are exact steps)
    t_below = float(run.trace.filter(run.trace["R_L_hat"] < 1.6)["t"][0])
    assert abs(t_decl - (t_below + 0.1)) < 1e-6, (t_decl, t_below)


def test_factories_get_their_settings_and_the_run_context() -> None:
    """The contract: ``factory(settings, context, *extra)``; an old plug-in's ``factory(cfg, *extra)`` is
    still called, with the whole run config, behind one one-line DeprecationWarning per component."""
    from ftc_mj.config import run_context

    cfg = load_config("scenario2")
    ctx = run_context(cfg)
    assert ctx.estimator_dt == 0.01 and ctx.nominal_radii == (2.0, 2.0) and ctx.sensors is cfg.sensors
    reg = registry.Registry("estimator", "ftc_mj.no_such_group", "ftc_mj.context", "estimator.kind")
    reg.register("new-probe", lambda settings, context, *extra: (settings, context, extra))
    reg.register("old-probe-for-warning", lambda cfg, *extra: (cfg, extra))
    assert reg.create("new-probe", cfg.estimator, ctx, "x", run_config=cfg) == (cfg.estimator, ctx, ("x",))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(3):
            assert reg.create("old-probe-for-warning", cfg.estimator, ctx, "x", run_config=cfg) == (cfg, ("x",))
    (w,) = caught
    assert w.category is DeprecationWarning and "\n" not in str(w.message)
    assert str(w.message) == ("estimator 'old-probe-for-warning' (tests.registry.test_plugins): factory(cfg) is "
                              "the old contract; take (settings, context) instead (docs/plugins.md of the source "
                              "repository)")


def test_an_old_style_plugin_still_runs(my_components: str) -> None:
    """A plug-in estimator written for the old contract (``factory(cfg)``) still runs a whole run."""
    import my_components as mc

    from ftc_mj.config import run_context

    ftc_mj.register_estimator("old-textbook-ekf", lambda cfg: mc.TextbookEKF(cfg.estimator, run_context(cfg)),
                              settings=mc.TextbookEKFSettings)
    try:
        with pytest.warns(DeprecationWarning, match="'old-textbook-ekf'.*take \\(settings, context\\) instead"):
            run = ftc_mj.run("scenario2", overrides={
                "duration": 2.0, "plant.kind": "kinematic", "sensors.yaw_rate_sigma": 0.01,
                "faults.left": [[1.0, 2.0], [1.0, 1.0]], "estimator.kind": "old-textbook-ekf"})
    finally:
        registry.estimators.unregister("old-textbook-ekf")
    assert run.metrics["status"] == "ok" and run.metrics["estimator"] == "old-textbook-ekf"
    assert np.isfinite(run.trace["R_L_hat"].to_numpy()).all()
