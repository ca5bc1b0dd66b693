"""A new built-in estimator is one module plus one registration (issue 39, acceptance 2).

The module holds the class and its settings model (``Settings``, with its ``kind``); the registration is its
line in :data:`ftc_mj.estimation.kinds.BUILTIN_ESTIMATORS`. Nothing else changes: the wiring registers every
line (:mod:`ftc_mj.wiring.estimation`), the ``[estimator]`` union has a member per line
(:data:`ftc_mj.config.sections.ESTIMATOR_KINDS`), ``ftc-mj components`` lists the model's settings.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

from ftc_mj.config.sections import ESTIMATOR_KINDS
from ftc_mj.estimation.kinds import BUILTIN_ESTIMATORS
from ftc_mj.registry import BUILTIN, estimators

ROOT = Path(__file__).resolve().parents[2]
MODULE = '''"""A second EKF with a setting of its own, written as a built-in is: the class and its settings model."""

from typing import Literal

from ftc_mj.estimation.ekf import EKFSettings
from ftc_mj.estimation.single import SingleFilter


class SecondEKFSettings(EKFSettings):
    """The EKF's settings and one more."""

    kind: Literal["second-ekf"] = "second-ekf"
    gain: float = 1.0
    """A setting only this kind has."""


class SecondEKF(SingleFilter):
    """The EKF's maths under another name."""

    member = "ekf"
    Settings = SecondEKFSettings
'''
SCRIPT = """
import numpy as np
from second_ekf import SecondEKF
from ftc_mj.estimation.kinds import BUILTIN_ESTIMATORS, Kind
BUILTIN_ESTIMATORS["second-ekf"] = Kind(SecondEKF.from_context, SecondEKF.Settings)  # the one registration
from ftc_mj.config import RunConfig
from ftc_mj.estimation import EKF, Measurement
from ftc_mj.registry import estimators, settings_listing
from ftc_mj.wiring.estimation import build_estimator
cfg = RunConfig.model_validate({"estimator": {"kind": "second-ekf", "rate": 50.0, "gain": 2.0},
                                "sensors": {"yaw_rate_sigma": 0.01}})
built, ekf = build_estimator(cfg), build_estimator(RunConfig.model_validate(
    {"estimator": {"kind": "ekf", "rate": 50.0}, "sensors": {"yaw_rate_sigma": 0.01}}))
assert type(built) is SecondEKF and isinstance(ekf, EKF) and cfg.estimator.gain == 2.0 and built.setup.dt == 0.02
for k in range(20):  # the same maths: the same estimates, bit for bit
    u, z = np.array([5.0, 5.0 + 0.01 * k]), Measurement(10.0 + 0.01 * k, 0.001 * k)
    np.testing.assert_array_equal(built.step(u, z).x, ekf.step(u, z).x)
listing = chr(10).join(settings_listing(estimators))
assert "second-ekf — [estimator] SecondEKFSettings:" in listing and "gain: float" in listing, listing
try:
    RunConfig.model_validate({"estimator": {"kind": "ekf", "gain": 2.0}})
except Exception as err:
    assert "gain: not a setting of estimator 'ekf' (a setting of second-ekf)" in str(err), err
else:
    raise AssertionError("gain accepted for the ekf")
print("ok")
"""


def test_a_builtin_estimator_is_one_module_and_one_registration(tmp_path: Path) -> None:
    """In a fresh process (the table is read when the config is imported): the module and its line in the
    table make a kind the config validates with its own setting, the wiring builds (the EKF's estimates, bit
    for bit) and ``ftc-mj components`` lists; its setting is another kind's only."""
    (tmp_path / "second_ekf.py").write_text(MODULE)
    res = subprocess.run([sys.executable, "-c", textwrap.dedent(SCRIPT)], cwd=tmp_path, capture_output=True,
                         text=True, timeout=300, env={"PYTHONPATH": f"{tmp_path}:{ROOT}", "PATH": "/usr/bin:/bin"})
    assert res.returncode == 0 and res.stdout.strip() == "ok", res.stderr[-3000:]


def test_the_table_is_what_the_wiring_registers_and_the_config_composes() -> None:
    """Every line of the table is registered with its factory and model, and is a member of the section."""
    assert ESTIMATOR_KINDS == {k: kind.settings for k, kind in BUILTIN_ESTIMATORS.items()}
    builtins = {n for n in estimators.names() if estimators.get(n).origin == BUILTIN}
    assert builtins == set(BUILTIN_ESTIMATORS)
    for name, kind in BUILTIN_ESTIMATORS.items():
        entry = estimators.get(name)
        assert entry.factory == kind.factory and entry.meta["section"] is kind.settings


