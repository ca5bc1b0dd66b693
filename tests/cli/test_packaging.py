"""Installs anywhere: package data read through importlib.resources, configs and run ids that do not
depend on where the package or the working directory is, the model file's contents in the identity,
the simulation without Rerun, and the declared dependencies."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from typer.testing import CliRunner

import ftc_mj
from ftc_mj import resources
from ftc_mj.cli import app
from ftc_mj.config import load_config
from ftc_mj.identity import run_digest, run_id, run_identity
from ftc_mj.study.plan import plan_study, run_key

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = Path(ftc_mj.__file__).resolve().parent
SHORT = ["--duration", "1", "--set", "sensors.yaw_rate_sigma=0.01", "--no-rrd", "-q"]


def test_package_data_is_found_through_importlib_resources() -> None:
    assert resources.builtin_scenarios() == ("actuator_loss", "gyro_bias", "scenario1", "scenario2", "scenario3",
                                             "scenario4", "servo_loss30", "speed_bias")
    assert {"observability", "severity", "reconfiguration"} <= set(resources.builtin_studies())
    assert resources.builtin_models() == ("diffdrive.xml",)
    assert resources.model_path("builtin:diffdrive.xml").read_text().lstrip().startswith("<!--")
    with pytest.raises(ValueError, match=r"no built-in model 'nope.xml' \(built-in: diffdrive.xml\)"):
        resources.model_path("builtin:nope.xml")
    assert plan_study("severity").spec.name == "severity"  # a built-in study by name
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["ftc_mj"]
    shipped = {str(p.relative_to(PACKAGE)) for p in (PACKAGE / "data").rglob("*") if p.is_file()}
    assert shipped and all(any(Path(f).match(g) for g in declared) for f in shipped), shipped


def test_config_toml_reruns_elsewhere_with_the_same_id_and_trace(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """``ftc-mj run scenario2`` from one folder, its ``config.toml`` from another: the same run id and a
    bitwise identical trace (wall-clock solve times excepted); the config names the shipped model as
    ``builtin:diffdrive.xml`` and holds no path of the checkout or of either folder."""
    first, second = tmp_path / "a", tmp_path / "b"
    first.mkdir()
    second.mkdir()
    monkeypatch.chdir(first)
    res = CliRunner().invoke(app, ["run", "scenario2", "--out", "out", *SHORT])
    assert res.exit_code == 0, res.stderr
    run_a = first / res.stdout.strip()
    text = (run_a / "config.toml").read_text()
    assert 'model_file = "builtin:diffdrive.xml"' in text
    assert str(ROOT) not in text and str(tmp_path) not in text
    monkeypatch.chdir(second)
    res = CliRunner().invoke(app, ["run", str(run_a / "config.toml"), "--out", "out", "--no-rrd", "-q"])
    assert res.exit_code == 0, res.stderr
    run_b = second / res.stdout.strip()
    assert run_b.name == run_a.name
    a, b = ftc_mj.load_run(run_a), ftc_mj.load_run(run_b)
    assert a.trace.drop("solve_time_ms").equals(b.trace.drop("solve_time_ms"), null_equal=True)


def test_identity_has_no_paths_and_names_the_model_by_its_contents(tmp_path: Path) -> None:
    cfg = load_config("scenario2")
    ident = json.dumps(run_identity(cfg))
    assert "/" not in ident and "model_file" not in ident
    assert run_identity(cfg)["plant"]["model_digest"] == resources.model_digest("builtin:diffdrive.xml")
    copy = tmp_path / "robot.xml"
    copy.write_text(resources.model_path("builtin:diffdrive.xml").read_text())
    same = load_config("scenario2", {"plant.model_file": str(copy)})
    assert same.plant.model_file == str(copy) and run_id(same) == run_id(cfg) and run_key(same) == run_key(cfg)
    copy.write_text(copy.read_text().replace('<mujoco model="ftc_mj_diffdrive">',
                                             '<mujoco model="ftc_mj_diffdrive_edited">', 1))
    edited = load_config("scenario2", {"plant.model_file": str(copy)})
    assert run_id(edited) != run_id(cfg) and run_key(edited) != run_key(cfg)
    assert run_key(cfg) == run_digest(cfg, 16) and run_id(cfg).endswith(run_digest(cfg, 8))


def test_a_relative_model_path_is_stored_absolute(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "m.xml").write_text(resources.model_path("builtin:diffdrive.xml").read_text())
    monkeypatch.chdir(tmp_path)
    cfg = load_config("scenario1", {"plant.model_file": "m.xml"})
    assert cfg.plant.model_file == str(tmp_path / "m.xml")


def test_the_simulation_and_reading_a_run_do_not_import_rerun(tmp_path: Path, policy_runs: list[Path]) -> None:
    """Importing the loop, a whole run without a recording, and reading back a run directory that has a
    recording (:func:`ftc_mj.load_run`) leave rerun-sdk and ``ftc_mj.rerun`` unimported (and a run leaves
    Gymnasium unimported: only ``ftc_mj.envs`` needs it). One fresh
    interpreter for the three checks (the suite itself has imported rerun long before; a module once
    imported stays in ``sys.modules``, so each check sees what the steps before it imported)."""
    code = ("import sys, ftc_mj.sim.loop; assert 'rerun' not in sys.modules, 'loop'\n"
            "import ftc_mj\n"
            "ov = {'duration': 0.3, 'plant.kind': 'kinematic'}\n"
            "r = ftc_mj.run('scenario1', sys.argv[1], overrides=ov, rrd=False)\n"
            "assert r.status == 'ok' and 'rerun' not in sys.modules, 'run'\n"
            "assert 'gymnasium' not in sys.modules, 'a run imports gymnasium'\n"
            "ftc_mj.load_run(sys.argv[2])\n"
            "assert 'rerun' not in sys.modules and 'ftc_mj.rerun' not in sys.modules, 'load_run'\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.run([sys.executable, "-c", code, str(tmp_path), str(policy_runs[0])], env=env,
                          capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]


def test_dependencies_are_declared_once_and_filterpy_only_for_tests() -> None:
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]

    def name(req: str) -> str:
        return req.split(";")[0].split("[")[0].split("=")[0].split(">")[0].split("<")[0].strip().lower()

    runtime = [name(r) for r in meta["dependencies"]]
    test = [name(r) for r in meta["optional-dependencies"]["test"]]
    assert len(set(runtime)) == len(runtime) and not set(runtime) & set(test)
    assert "filterpy" not in runtime and "filterpy" in test
    assert "distributed" not in runtime  # dask[distributed] declares it
    res = CliRunner().invoke(app, ["--version"])
    assert res.exit_code == 0 and res.stdout == f"ftc-mj {ftc_mj.__version__}\n"
    assert meta["dynamic"] == ["version"]  # the version has one source: ftc_mj.__version__
