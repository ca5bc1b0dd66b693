"""Bad input on the command line: every case ends with exit code 2, exactly one line on stderr that
names the field or option, and nothing written anywhere (the output folder, the working directory —
including ``MUJOCO_LOG.TXT`` — and every other folder of the test's tree).

The schema's bad values (every leaf, per type) are judged in-process by the config validator
(``tests/config/test_bad_values.py``); here a representative set of them (one per kind of value and
per kind of check) drives the real CLI end to end, beside the cases only the CLI has: its options,
model files MuJoCo rejects, study files and options, cluster addresses, compare/view/paper. All run
in-process (``CliRunner``); a case that got past validation would reach the simulation, which is
replaced by a sentinel that builds the plant (model files are checked there) and then fails the test.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from ftc_mj import resources
from ftc_mj.cli import app
from ftc_mj.config import RunConfig
from tests.config.bad_values import file_cases, schema_cases

MODEL = resources.resource_path("models", "diffdrive.xml")


# ------------------------------------------------------------------------------------------ fixtures
@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Input files the cases refer to (relative to the working directory)."""
    d = tmp_path_factory.mktemp("inputs")
    (d / "afile").write_text("not a folder\n")
    (d / "bad.toml").write_text("duration = = 3\n")
    (d / "binary.toml").write_bytes(bytes(range(256)) * 4)
    (d / "huge.toml").write_text("# " + "x" * (5 * 2**20) + "\n")
    (d / "badname.toml").write_text('name = "../../escape"\n')
    (d / "broken.xml").write_text("<mujoco><worldbody><body name='x'></worldbody></mujoco>")
    (d / "noname.xml").write_text("<mujoco><worldbody><body name='x'><geom size='1'/></body></worldbody></mujoco>")
    (d / "binary.xml").write_bytes(bytes(range(256)))
    (d / "tiny.xml").write_text(MODEL.read_text().replace(
        '<mujoco model="ftc_mj_diffdrive">', '<mujoco model="ftc_mj_diffdrive">\n  <size memory="4K"/>', 1))
    (d / "models").mkdir()
    study_head = 'name = "s"\nscenario = "scenario1"\n[base]\nduration = 1.0\n'
    for name, body in {
        "unknown.study.toml": study_head + "bogus = 1\n",
        "axis.study.toml": study_head + '[[axes]]\nkey = "sensors.yaw_rat"\nvalues = [0.1]\n',
        "empty.study.toml": study_head + '[[axes]]\nkey = "duration"\nvalues = []\n',
        "badval.study.toml": study_head + '[[axes]]\nkey = "duration"\nvalues = [1.0, inf]\n',
        "badtype.study.toml": study_head + '[[axes]]\nkey = "output.rrd"\nvalues = ["yes"]\n',
        "grid.study.toml": study_head + "".join(
            f'[[axes]]\nkey = "{k}"\nvalues = [{", ".join(str(1.0 + i / 1000) for i in range(1000))}]\n'
            for k in ("sensors.speed_sigma", "reference.radius")),
        "seeds.study.toml": study_head.replace("[base]", "seeds = 0\n[base]"),
        "escape.study.toml": study_head.replace('name = "s"', 'name = "../../escape"'),
        "scen.study.toml": study_head.replace('"scenario1"', '"nope.toml"'),
        "badsyntax.study.toml": "name = \n",
        "nested.study.toml": "name = " + "[" * 4000 + "]" * 4000 + "\n",
    }.items():
        (d / name).write_text(body)
    (d / "study_ok.toml").write_text(study_head)
    (d / "notarun").mkdir()
    (d / "notarun" / "trace.parquet").write_text("not parquet")
    (d / "fake.rrd").write_text("not a recording")
    return d


@pytest.fixture()
def cwd(inputs: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The inputs folder as working directory; the simulation replaced by a sentinel."""
    import ftc_mj.sim.run as run_mod
    from ftc_mj.sim.cache import plant_for

    monkeypatch.chdir(inputs)

    def sentinel(cfg: RunConfig, progress: Any = None, **kw: Any) -> Any:
        plant_for(cfg)  # model files are compiled (and rejected) here, before the first step
        raise AssertionError("bad input reached the simulation")

    monkeypatch.setattr(run_mod, "simulate", sentinel)
    return inputs


def snapshot(root: Path) -> tuple[dict[str, int], list[str]]:
    """Every file and folder under ``root`` (with sizes), and the names beside it."""
    tree = {str(p.relative_to(root)): (p.stat().st_size if p.is_file() else -1) for p in root.rglob("*")}
    return tree, sorted(p.name for p in root.parent.iterdir())


def check_rejected(root: Path, args: list[str], needle: str) -> None:
    """Run ``ftc-mj ARGS`` in-process from ``root``: exit 2, one stderr line naming ``needle``,
    nothing written under ``root`` or beside it."""
    before = snapshot(root)
    res = CliRunner().invoke(app, args)
    err = res.stderr
    assert res.exit_code == 2, (args, res.exit_code, res.output, err, res.exception)
    lines = err.splitlines()
    assert len(lines) == 1 and err.endswith("\n"), (args, err)
    assert lines[0].startswith("ftc-mj: error: ") and needle in lines[0], (args, lines[0], needle)
    after = snapshot(root)
    assert after == before, (args, set(after[0]) ^ set(before[0]), set(after[1]) ^ set(before[1]))
    assert not (root / "MUJOCO_LOG.TXT").exists()


# ------------------------------------------------------------------------------------------ cases
RUN = ["run", "scenario1", "--out", "out"]

HAND_CASES: list[tuple[str, list[str], str]] = [
    # TOML syntax and encodings
    ("toml:syntax", ["run", "bad.toml", "--out", "out"], "invalid TOML"),
    ("toml:huge", ["run", "huge.toml", "--out", "out"], "larger than 4 MiB"),
    ("toml:missing", ["run", "none.toml", "--out", "out"], "scenario: no such built-in scenario or file"),
    ("toml:name", ["run", "badname.toml", "--out", "out"], "name: must be a plain file name"),
    # fault schedules
    ("fault:unknown-wheel", [*RUN, "--set", "faults.front=[[1.0, 1.0]]"], "faults.front: unknown key"),
    # model files
    ("model:missing", [*RUN, "--set", "plant.model_file='models/nope.xml'"], "plant.model_file"),
    ("model:broken", [*RUN, "--set", "plant.model_file='broken.xml'"], "plant.model_file"),
    ("model:names", [*RUN, "--set", "plant.model_file='noname.xml'"], "plant.model_file"),
    ("model:binary", [*RUN, "--set", "plant.model_file='binary.xml'"], "plant.model_file"),
    ("model:arena", [*RUN, "--set", "plant.model_file='tiny.xml'"], "plant.model_file"),
    # --set syntax
    ("set:no-equals", [*RUN, "--set", "novalue"], "--set novalue"),
    ("set:newline", [*RUN, "--set", "duration=1\nseed=3"], "--set duration"),
    ("set:unknown", [*RUN, "--set", "bogus=1"], "bogus: unknown key"),
    ("set:feedback-contradiction", [*RUN, "--set", "feedback=false", "--set", "reconfiguration.policy=direct"],
     "feedback: false"),
    ("set:rate", [*RUN, "--set", "estimator.rate=33"], "estimator.rate"),
    # CLI arguments
    ("cli:unknown-flag", [*RUN, "--bogus"], "No such option: --bogus"),
    ("cli:bad-choice", [*RUN, "--estimator", "kalman"], "--estimator"),
    ("cli:bad-reconfig", [*RUN, "--reconfig", "sometimes"], "--reconfig"),
    ("cli:bad-controller", [*RUN, "--controller", "pid"], "--controller"),
    ("cli:seed-abc", [*RUN, "--seed", "abc"], "--seed"),
    ("cli:seed-negative", [*RUN, "--seed", "-1"], "seed"),
    ("cli:duration-abc", [*RUN, "--duration", "abc"], "--duration"),
    ("cli:duration-inf", [*RUN, "--duration", "inf"], "duration"),
    ("cli:duration-zero", [*RUN, "--duration", "0"], "duration"),
    ("cli:duration-huge", [*RUN, "--duration", "1e15"], "duration"),
    ("cli:imm-models", [*RUN, "--imm-models", "7"], "--imm-models"),
    ("cli:imm-non-imm", [*RUN, "--imm-models", "5"], "--imm-models: not a setting of estimator 'ukf' (a setting of"),
    ("cli:imm-variant-non-imm", [*RUN, "--imm-variant", "paper", "--estimator", "ekf"], "--imm-variant"),
    ("cli:imm-set-non-imm", [*RUN, "--set", "estimator.imm_models=5"],
     "estimator.imm_models: not a setting of estimator 'ukf'"),  # the key as the user wrote it
    ("cli:flag-vs-set", [*RUN, "--duration", "3", "--set", "duration=4"], "--duration: 3.0 contradicts --set"),
    ("cli:estimator-vs-set", [*RUN, "--estimator", "ekf", "--set", "estimator.kind=ukf"], "--estimator"),
    ("cli:seed-vs-set", [*RUN, "--seed", "1", "--set", "seed=2"], "--seed"),
    ("cli:reconfig-and-feedback", [*RUN, "--reconfig", "safe", "--no-feedback"], "--feedback/--no-feedback"),
    ("cli:feedback-vs-set", [*RUN, "--feedback", "--set", "reconfiguration.policy=none"], "feedback"),
    ("cli:missing-scenario", ["run"], "Missing argument 'SCENARIO'"),
    ("cli:unknown-command", ["runn"], "No such command 'runn'"),
    ("cli:extra-argument", [*RUN, "scenario2"], "unexpected extra argument"),
    ("cli:out-empty", ["run", "scenario1", "--out", ""], "--out: expected a folder path"),
    ("cli:out-blank", ["run", "scenario1", "--out", "  "], "--out: expected a folder path"),
    ("cli:out-below-file", ["run", "scenario1", "--out", "afile/sub"], "--out:"),
    ("cli:out-is-file", ["run", "scenario1", "--out", "afile"], "--out:"),
    ("cli:out-unwritable", ["run", "scenario1", "--out", "/sys/ftc-mj-out"], "--out: cannot write in /sys"),
    ("cli:out-component", ["run", "scenario1", "--out", "o" * 300], "--out: a path component is longer"),
    ("cli:out-4096", ["run", "scenario1", "--out", "/".join(["p" * 200] * 21)], "--out: the path is too long"),
    ("cli:out-nul", ["run", "scenario1", "--out", "a\0b"], "--out"),
    ("cli:output-dir-empty", [*RUN[:2], "--set", "output.dir=''"], "output.dir"),
    # studies
    ("study:missing", ["study", "none.toml", "--out", "sout"], "STUDY_FILE: no such built-in study or file"),
    ("study:directory", ["study", "models", "--out", "sout"], "STUDY_FILE"),
    ("study:syntax", ["study", "badsyntax.study.toml", "--out", "sout"], "invalid TOML"),
    ("study:nested", ["study", "nested.study.toml", "--out", "sout"], "nested too deeply"),
    ("study:binary", ["study", "binary.toml", "--out", "sout"], "not UTF-8"),
    ("study:unknown", ["study", "unknown.study.toml", "--out", "sout"], "bogus: unknown key"),
    ("study:axis-key", ["study", "axis.study.toml", "--out", "sout"], "axes[0].key (sensors.yaw_rat)"),
    ("study:empty-axis", ["study", "empty.study.toml", "--out", "sout"], "axes[0].values: empty axis"),
    ("study:inf-value", ["study", "badval.study.toml", "--out", "sout"], "duration: must be a finite number"),
    ("study:strict-type", ["study", "badtype.study.toml", "--out", "sout"], "output.rrd"),
    ("study:grid-size", ["study", "grid.study.toml", "--out", "sout", "--limit", "1"], "1000000 runs"),
    ("study:seeds", ["study", "seeds.study.toml", "--out", "sout"], "seeds"),
    ("study:seeds-option", ["study", "study_ok.toml", "--out", "sout", "--seeds", "0"], "--seeds"),
    ("study:name-escape", ["study", "escape.study.toml"], "name: must be a plain file name"),
    ("study:scenario", ["study", "scen.study.toml", "--out", "sout"], "scenario"),
    ("study:set", ["study", "study_ok.toml", "--out", "sout", "--set", "duration=inf"], "duration"),
    ("study:out-empty", ["study", "study_ok.toml", "--out", ""], "--out: expected a folder path"),
    ("study:out-file", ["study", "study_ok.toml", "--out", "afile"], "--out:"),
    ("study:out-below-file", ["study", "study_ok.toml", "--out", "afile/sub"], "is a file, not a folder"),
    ("study:out-unwritable", ["study", "study_ok.toml", "--out", "/sys/ftc-mj-study"], "--out: cannot write in /sys"),
    ("study:out-5000-chars", ["study", "study_ok.toml", "--out", "x" * 5000], "--out: a path component is longer"),
    ("study:out-path-too-long", ["study", "study_ok.toml", "--out", "/".join(["d" * 200] * 25)], "--out"),
    ("bench:out-5000-chars", ["bench", "safe", "--draws", "1", "--out", "x" * 5000],
     "--out: a path component is longer"),
    ("bench:out-path-too-long", ["bench", "safe", "--draws", "1", "--out", "/".join(["d" * 200] * 25)], "--out"),
    ("bench:start-beyond-last-draw", ["bench", "safe", "--start", "1000000000", "--out", "bout"], "--start: the draws"),
    ("bench:address-unreachable", ["bench", "safe", "--draws", "1", "--out", "bout", "--address",
                                   "tcp://127.0.0.1:1"], "--address tcp://127.0.0.1:1"),
    ("study:workers", ["study", "study_ok.toml", "--out", "sout", "--workers", "0"], "--workers"),
    ("study:limit", ["study", "study_ok.toml", "--out", "sout", "--limit", "-1"], "--limit"),
    ("study:rrd", ["study", "study_ok.toml", "--out", "sout", "--rrd", "some"], "--rrd"),
    ("study:dashboard", ["study", "study_ok.toml", "--out", "sout", "--dashboard", "everywhere"], "--dashboard"),
    ("study:dashboard-port", ["study", "study_ok.toml", "--out", "sout", "--dashboard", ":99999"], "--dashboard"),
    ("address:no-port", ["study", "study_ok.toml", "--out", "sout", "--address", "tcp://host"], "--address"),
    ("address:scheme", ["study", "study_ok.toml", "--out", "sout", "--address", "http://h:80"], "--address"),
    ("address:port-0", ["study", "study_ok.toml", "--out", "sout", "--address", "tcp://h:0"], "--address"),
    ("address:port-big", ["study", "study_ok.toml", "--out", "sout", "--address", "tcp://h:70000"], "--address"),
    ("address:empty", ["study", "study_ok.toml", "--out", "sout", "--address", ""], "--address"),
    ("address:spaces", ["study", "study_ok.toml", "--out", "sout", "--address", "tcp://a b:1"], "--address"),
    ("address:path", ["study", "study_ok.toml", "--out", "sout", "--address", "tcp://h:1/x"], "--address"),
    # compare and view
    ("compare:missing", ["compare", "nope", "nope2"], "RUN_DIR: nope is not a run directory"),
    ("compare:not-parquet", ["compare", "notarun", "notarun"], "not a readable Parquet file"),
    ("compare:none", ["compare"], "Missing argument"),
    ("compare:out-suffix", ["compare", "notarun", "--out", "x.png"], "--out: x.png: the file name must end in .rrd"),
    ("compare:out-folder", ["compare", "notarun", "--out", "models"], "--out"),
    ("compare:out-exists", ["compare", "notarun", "--out", "fake.rrd"], "--out: fake.rrd exists"),
    ("compare:out-empty", ["compare", "notarun", "--out", ""], "--out"),
    ("view:missing", ["view", "nope"], "RUN_DIR: recording not found"),
    ("view:folder", ["view", "models"], "RUN_DIR: recording not found"),
    ("view:not-recording", ["view", "fake.rrd"], "RUN_DIR: fake.rrd is not a Rerun recording"),
    ("view:several-missing", ["view", "nope", "nope2"], "RUN_DIR: nope is not a run directory"),
    ("view:none", ["view"], "Missing argument"),
    ("paper:jobs", ["paper", "--out", "pout", "--jobs", "0"], "--jobs"),
    ("paper:duration", ["paper", "--out", "pout", "--duration", "-1"], "--duration"),
    ("paper:duration-inf", ["paper", "--out", "pout", "--duration", "inf"],
     "--duration: must be a finite number in (0, 3600] s, got inf"),
    ("paper:only", ["paper", "--out", "pout", "--only", "zzz*"], "--only"),
    ("paper:rrd", ["paper", "--out", "pout", "--rrd", "x"], "--rrd"),
    ("paper:rrd-contradiction", ["paper", "--out", "pout", "--rrd", "compare", "--no-rrd"], "--no-rrd"),
    ("paper:out-file", ["paper", "--out", "afile"], "--out"),
]

SCHEMA_IDS = {
    # one per kind of value (float, int, bool, literal, tuple, list, path, str, dict) and per check
    "set:duration=inf", "set:controller.horizon=1e308", "set:sensors.speed_sigma=true", "set:seed=1.5",
    "set:controller.nodes=\"3\"", "set:output.rrd=\"yes\"", "set:plant.variant=\"bogus\"",
    "set:estimator.p0_sigma=[1.0]", "set:controller.robust.scenarios=[[inf, 1.0]]", "set:output.dir=\"\"",
    "set:plant.timestep=nan", "set:description=1", "set:estimator.options={ a = 1 }",
    "set:estimator.kind=\"bogus\"", "set:reconfiguration.policy=\"bogus\"",
    "set:plugins=[\"no_such_module_xyz\"]", "set:name=\"../../../x\"", "set:name=\"a\\u0000b\"",
}
SCHEMA_CASES = [c for c in schema_cases() if c[0] in SCHEMA_IDS]
FILE_IDS = {"file:estimator.rate=inf", "file:output.rrd=\"yes\"", "file:name=true", "file:faults.left=3"}
FILE_CASES = [c for c in file_cases() if c[0] in FILE_IDS]
CASES = [(case, ["--set", item], needle) for case, item, needle in SCHEMA_CASES] + HAND_CASES


def test_the_representative_cases_exist() -> None:
    assert len(SCHEMA_CASES) == len(SCHEMA_IDS) and len(FILE_CASES) == len(FILE_IDS)


@pytest.mark.parametrize(("case", "args", "needle"), CASES, ids=[c[0] for c in CASES])
def test_bad_input(cwd: Path, case: str, args: list[str], needle: str) -> None:
    check_rejected(cwd, args if args[0] != "--set" else [*RUN, *args], needle)


@pytest.mark.parametrize(("case", "body", "needle"), FILE_CASES, ids=[c[0] for c in FILE_CASES])
def test_bad_scenario_file(cwd: Path, case: str, body: str, needle: str) -> None:
    name = re.sub(r"[^A-Za-z0-9_]+", "_", case)[:60] + ".toml"
    (cwd / name).write_text(f'name = "case"\n{body}' if not case.startswith("file:name=") else body)
    try:
        check_rejected(cwd, ["run", name, "--out", "out"], needle)
    finally:
        (cwd / name).unlink()
