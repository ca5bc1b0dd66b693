"""Every kind of bad config value, judged in-process by the config validator: :class:`BadInput` with
one line that names the field, nothing written. The generated cases (every leaf of the schema, per
type, through ``--set`` and through scenario files: ``tests/config/bad_values.py``) and the
hand-listed ones (TOML files, fault schedules, ``--set`` syntax, checks across sections). The same
contract through the command line (exit 2, ``ftc-mj: error: …``) is ``tests/cli/test_bad_input.py``."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from pydantic import BaseModel, ValidationError

from ftc_mj.config import NonNegFloat, PosFloat, load_config, one_line, parse_override
from ftc_mj.errors import BadInput
from tests.config.bad_values import file_cases, leaves, schema_cases


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Scenario files the cases refer to."""
    d = tmp_path_factory.mktemp("inputs")
    (d / "bad.toml").write_text("duration = = 3\n")
    (d / "binary.toml").write_bytes(bytes(range(256)) * 4)
    (d / "latin1.toml").write_bytes('description = "caf\xe9"\n'.encode("latin-1"))
    (d / "nested.toml").write_text("a = " + "[" * 4000 + "]" * 4000 + "\n")
    (d / "dupkey.toml").write_text("duration = 3.0\nduration = 4.0\n")
    (d / "huge.toml").write_text("# " + "x" * (5 * 2**20) + "\n")
    (d / "badname.toml").write_text('name = "../../escape"\n')
    (d / "my scenario.toml").write_text("duration = 3.0\n")
    (d / "models").mkdir()
    return d


@pytest.fixture()
def cwd(inputs: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(inputs)
    return inputs


def _tree(root: Path) -> dict[str, int]:
    return {str(p.relative_to(root)): (p.stat().st_size if p.is_file() else -1) for p in root.rglob("*")}


def check_rejected(root: Path, call: Callable[[], Any], needle: str) -> str:
    """``call()`` raises :class:`BadInput` whose message is one line containing ``needle``; nothing is
    written under ``root``. Returns the message."""
    before = _tree(root)
    with pytest.raises(BadInput) as info:
        call()
    msg = str(info.value)
    assert msg and "\n" not in msg and "\r" not in msg, msg
    assert needle in msg, (msg, needle)
    assert _tree(root) == before
    return msg


def load_with_sets(*items: str) -> Any:
    """``ftc-mj run scenario1 --set ITEM …`` without the command line."""
    return load_config("scenario1", dict(parse_override(it) for it in items))


# ------------------------------------------------------------------------------------------ generated
CASES = schema_cases()


def test_the_cases_cover_every_config_leaf() -> None:
    keys = {k for k, _ in leaves()}
    assert keys <= {c[2] for c in CASES} and keys <= {c[2] for c in file_cases()}
    assert len(CASES) + len(file_cases()) >= 200


@pytest.mark.parametrize(("case", "item", "needle"), CASES, ids=[c[0] for c in CASES])
def test_bad_value_through_set(cwd: Path, case: str, item: str, needle: str) -> None:
    check_rejected(cwd, lambda: load_with_sets(item), needle)


@pytest.mark.parametrize(("case", "body", "needle"), file_cases(), ids=[c[0] for c in file_cases()])
def test_bad_value_through_a_scenario_file(tmp_path: Path, case: str, body: str, needle: str) -> None:
    path = tmp_path / "case.toml"
    path.write_text(f'name = "case"\n{body}' if not case.startswith("file:name=") else body)
    check_rejected(tmp_path, lambda: load_config(path), needle)


# ------------------------------------------------------------------------------------------ hand-listed
FILE_CASES = [
    ("toml:syntax", "bad.toml", "invalid TOML"),
    ("toml:binary", "binary.toml", "scenario binary.toml: not UTF-8 text: byte 0x80 at line 2, column 118; it is "
                                   "not a text file (it holds NUL bytes)"),
    ("toml:latin1", "latin1.toml", "not UTF-8 text: byte 0xe9 at line 1, column 19; save it with the UTF-8 encoding"),
    ("toml:nested", "nested.toml", "nested too deeply"),
    ("toml:duplicate", "dupkey.toml", "invalid TOML"),
    ("toml:huge", "huge.toml", "larger than 4 MiB"),
    ("toml:missing", "none.toml", "scenario: no such built-in scenario or file"),
    ("toml:directory", "models", "scenario: no such built-in scenario or file"),
    ("toml:nul", "a\0b.toml", "scenario:"),
    ("toml:longname", "x" * 300 + ".toml", "scenario:"),
    ("toml:name", "badname.toml", "name: must be a plain file name"),
    ("toml:stem", "my scenario.toml", "name: the scenario file's stem"),
]


@pytest.mark.parametrize(("case", "name", "needle"), FILE_CASES, ids=[c[0] for c in FILE_CASES])
def test_bad_scenario_file(cwd: Path, case: str, name: str, needle: str) -> None:
    check_rejected(cwd, lambda: load_config(name), needle)


SET_CASES = [
    # fault schedules
    ("fault:negative-time", ["faults.left=[[-1.0, 2.0]]"], "faults.left"),
    ("fault:decreasing", ["faults.left=[[10.0, 2.0], [5.0, 1.0]]"], "faults.left"),
    ("fault:zero-radius", ["faults.left=[[10.0, 0.0]]"], "faults.left"),
    ("fault:negative-radius", ["faults.right=[[1.0, -1.0]]"], "faults.right"),
    ("fault:negative-radius-later", ["faults.left=[[10.0, 2.0], [12.0, -1.0]]"], "faults.left:"),
    ("fault:triple", ["faults.left=[[1.0, 2.0], [1.0, 1.5], [1.0, 1.0]]"], "faults.left"),
    ("fault:three-values", ["faults.left=[[1.0, 2.0, 3.0]]"], "faults.left"),
    ("fault:inf-time", ["faults.left=[[inf, 1.0]]"], "faults.left"),
    ("fault:nan-radius", ["faults.left=[[1.0, nan]]"], "faults.left"),
    ("fault:string", ["faults.left=\"10 s\""], "faults.left"),
    ("fault:table", ["faults.left={t = 1.0}"], "faults.left"),
    ("fault:unknown-wheel", ["faults.front=[[1.0, 1.0]]"], "faults.front: unknown key"),
    # servo and sensor faults (one table each; the checks across sections below)
    ("fault:actuator-kind", ["faults.actuator=[{wheel='left', kind='burnt', onset=1.0}]"], "faults.actuator[0].kind"),
    ("fault:actuator-wheel", ["faults.actuator=[{wheel='front', kind='lock', onset=1.0}]"],
     "faults.actuator[0].wheel"),
    ("fault:actuator-onset", ["faults.actuator=[{wheel='left', kind='lock', onset=-1.0}]"],
     "faults.actuator[0].onset: must be a finite number in [0, 1e+06] s"),
    ("fault:actuator-no-onset", ["faults.actuator=[{wheel='left', kind='lock'}]"], "faults.actuator[0].onset"),
    ("fault:loss-without-size", ["faults.actuator=[{wheel='left', kind='loss', onset=1.0}]"],
     "faults.actuator[0].effectiveness: a 'loss' needs"),
    ("fault:loss-whole", ["faults.actuator=[{wheel='left', kind='loss', onset=1.0, effectiveness=1.0}]"],
     "faults.actuator[0].effectiveness: must be a finite number in [0, 1)"),
    ("fault:lock-with-size", ["faults.actuator=[{wheel='left', kind='lock', onset=1.0, effectiveness=0.5}]"],
     "faults.actuator[0].effectiveness: only a 'loss'"),
    ("fault:actuator-key", ["faults.actuator=[{wheel='left', kind='lock', onset=1.0, torque=3}]"],
     "faults.actuator[0].torque: unknown key"),
    ("fault:sensor-kind", ["faults.sensor=[{sensor='speed', kind='spike', onset=1.0, size=1.0}]"],
     "faults.sensor[0].kind"),
    ("fault:sensor-name", ["faults.sensor=[{sensor='gps', kind='bias', onset=1.0, size=1.0}]"],
     "faults.sensor[0].sensor"),
    ("fault:bias-without-size", ["faults.sensor=[{sensor='speed', kind='bias', onset=1.0}]"],
     "faults.sensor[0].size: a 'bias' needs"),
    ("fault:dropout-with-size", ["faults.sensor=[{sensor='speed', kind='dropout', onset=1.0, size=1.0}]"],
     "faults.sensor[0].size: a 'dropout' has no size"),
    ("fault:sensor-duration", ["faults.sensor=[{sensor='speed', kind='dropout', onset=1.0, duration=0.0}]"],
     "faults.sensor[0].duration: must be a finite number in (0, 1e+09] s"),
    ("fault:sensor-size-nan", ["faults.sensor=[{sensor='speed', kind='bias', onset=1.0, size=nan}]"],
     "faults.sensor[0].size"),
    # model files the schema checks (those MuJoCo rejects: tests/cli/test_bad_input.py)
    ("model:missing", ["plant.model_file='models/nope.xml'"], "plant.model_file"),
    ("model:directory", ["plant.model_file='models'"], "plant.model_file"),
    ("model:longname", [f"plant.model_file='{'m' * 300}.xml'"], "plant.model_file"),
    # --set syntax
    ("set:no-equals", ["novalue"], "--set novalue"),
    ("set:empty-key", ["=3"], "--set =3: empty key"),
    ("set:empty-part", ["a..b=1"], "empty key"),
    ("set:newline", ["duration=1\nseed=3"], "--set duration"),
    ("set:nested", ["duration=" + "[" * 3000 + "]" * 3000], "--set duration"),
    ("set:unknown", ["bogus=1"], "bogus: unknown key"),
    ("set:unknown-nested", ["sensors.colour=1"], "sensors.colour: unknown key"),
    ("set:table", ["sensors=1"], "sensors"),
    ("set:into-value", ["duration.x=1"], "duration"),
    ("set:negative-duration", ["duration=-1"], "duration:"),
    ("set:string-duration", ["duration='abc'"], "duration:"),
    ("set:float-seed", ["seed=1.5"], "seed:"),
    # checks across sections
    ("set:feedback-type", ["feedback=1"], "feedback"),
    ("set:feedback-contradiction", ["feedback=false", "reconfiguration.policy=direct"], "feedback: false"),
    ("set:feedback-true-none", ["feedback=true", "reconfiguration.policy=none"], "feedback: true contradicts"),
    ("set:rate", ["estimator.rate=33"], "estimator.rate"),
    ("set:controller-rate", ["controller.rate=7"], "controller.rate"),
    ("set:imm-bank-and-models", ["estimator.kind='imm-ukf'", "estimator.imm_models=5",
                                 "estimator.imm_bank=[{name='a'}, {name='b'}]"], "estimator.imm_models: give either"),
    ("set:imm-bank-names", ["estimator.kind='imm-ekf'", "estimator.imm_bank=[{name='a'}, {name='a'}]"],
     "estimator.imm_bank: hypothesis names"),
    ("set:imm-key-on-ukf", ["estimator.imm_models=5"],
     "estimator.imm_models: not a setting of estimator 'ukf' (a setting of imm-ekf, imm-ukf)"),
    ("set:kappa-on-ekf", ["estimator.kind='ekf'", "estimator.kappa=1.0"],
     "estimator.kappa: not a setting of estimator 'ekf' (a setting of ukf, imm-ukf)"),
    ("set:estimator-builtin-options", ["estimator.options={a = 1}"],
     "estimator.options: estimator 'ukf' takes no options"),
    ("set:robust-solver", ["controller.kind='robust-nmpc'", "controller.solver='rti-osqp'"], "controller.solver"),
    ("set:robust-worst", ["controller.kind='robust-nmpc'", "controller.robust.objective='worst'"],
     "controller.robust.objective"),
    ("set:robust-weights", ["controller.kind='robust-nmpc'", "controller.robust.weights=[1.0]"],
     "controller.robust.weights"),
    ("set:robust-posterior", ["controller.kind='robust-nmpc'", "controller.robust.weighting='posterior'",
                              "estimator.kind='none'"], "controller.robust.weighting"),
    ("set:builtin-options", ["controller.options={a = 1}"], "controller.options: controller 'nmpc' takes no options"),
    ("set:other-kinds-key", ["controller.kind='open-loop'", "controller.nodes=20"],
     "controller.nodes: not a setting of controller 'open-loop' (a setting of nmpc, lmpc, pf-nmpc, robust-nmpc)"),
    ("set:other-kinds-table", ["controller.path_following.q_lag=1.0"],
     "controller.path_following: not a setting of controller 'nmpc' (a setting of pf-nmpc)"),
    ("set:gyro-fault-without-gyro", ["faults.sensor=[{sensor='yaw_rate', kind='bias', onset=1.0, size=0.1}]"],
     "faults.sensor[0].sensor: 'yaw_rate' needs a gyro"),
    ("set:servo-fault-on-kinematic", ["plant.kind='kinematic'",
                                      "faults.actuator=[{wheel='left', kind='loss', onset=1.0, effectiveness=0.5}]"],
     "faults.actuator[0].kind: 'loss' needs a servo"),
]


@pytest.mark.parametrize(("case", "items", "needle"), SET_CASES, ids=[c[0] for c in SET_CASES])
def test_bad_override(cwd: Path, case: str, items: list[str], needle: str) -> None:
    check_rejected(cwd, lambda: load_with_sets(*items), needle)


# ------------------------------------------------------------------------------------------ messages
@pytest.mark.parametrize(("key", "value", "msg"), [
    ("duration", "inf", "duration: must be a finite number in (0, 3600] s, got inf"),
    ("duration", "1e308", "duration: must be a finite number in (0, 3600] s"),
    ("duration", "1e15", "duration: must be a finite number in (0, 3600] s"),
    ("controller.horizon", "inf", "controller.horizon: must be a finite number in (0, 60] s"),
    ("plant.chassis_mass", "inf", "plant.chassis_mass: must be a finite number in (0, 1e+06]"),
    ("plant.wheel_mass", "1e308", "plant.wheel_mass: must be a finite number in (0, 1e+06]"),
    ("plant.actuator_gain", "inf", "plant.actuator_gain: must be a finite number"),
    ("plant.tyre_friction", "1e308", "plant.tyre_friction: must be a finite number"),
    ("plant.initial_pose", "[nan, 0.0, 0.0]", "plant.initial_pose: must be a finite number"),
    # an infinite radius used to be blamed on the model file
    ("robot.wheel_radius", "inf", "robot.wheel_radius: must be a finite number in [0.001, 100] m"),
    ("plant.wheel_radius", "inf", "plant.wheel_radius: must be a finite number in [0.001, 100] m"),
    # strict types: the value as written is shown
    ("duration", "true", "duration: Input should be a valid number, got true"),
    ("output.rrd", '"yes"', 'output.rrd: Input should be a valid boolean, got "yes"'),
    ("seed", "true", "seed: Input should be a valid integer, got true"),
])
def test_messages_name_the_range_and_the_value(tmp_path: Path, key: str, value: str, msg: str) -> None:
    assert check_rejected(tmp_path, lambda: load_with_sets(f"{key}={value}"), msg).startswith(msg)


def test_float_bounds_are_shared() -> None:
    """Other modules' new fields inherit the finite bound by using the shared types."""
    class M(BaseModel):
        a: PosFloat = 1.0
        b: NonNegFloat = 0.0

    for bad in ({"a": math.inf}, {"a": 0.0}, {"a": 2e6}, {"b": -1.0}, {"b": math.nan}, {"a": True}):
        with pytest.raises(ValueError):
            M(**bad)
    assert M(a=3, b=0).a == 3.0


def test_one_line_names_items_keys_and_counts_the_rest() -> None:
    """The one formatting of a validation error (config, plug-in options, study files): an item's index
    before its field (``items[1].weights``, not a trailing one), an unknown key as written (dashes too),
    union member tags left out, the rest counted."""
    class Item(BaseModel, extra="forbid"):
        value: PosFloat | str
        weights: list[PosFloat] = []

    class Doc(BaseModel, extra="forbid"):
        items: list[Item]

    def line(data: Any) -> str:
        with pytest.raises(ValidationError) as info:
            Doc.model_validate(data)
        return one_line(info.value)

    assert line({"items": [{"value": 1.0}, {"value": 1.0, "weights": [1.0, -2.0]}]}) == (
        "items[1].weights: must be a finite number in (0, 1e+06], got -2.0")
    assert line({"items": [{"value": 1.0, "my-key": 1}]}) == "items[0].my-key: unknown key"
    assert line({"items": [{"value": [1]}]}) == "items[0].value: Input should be a valid number, got [1] (and 1 more)"
    assert line({"items": 3}) == "items: Input should be a valid list, got 3"
