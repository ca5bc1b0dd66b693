"""A new built-in estimator is one module plus one registration (issue 39, acceptance 2).

The module holds the class and names its settings model (``Settings``); the registration is one
``estimators.register(name, Class.from_context, origin=BUILTIN, section=Class.Settings)`` line in
:mod:`ftc_mj.wiring.estimation`. Nothing else changes: the config accepts the name, the wiring builds it,
``ftc-mj components`` lists its settings from the model. (A kind whose model adds settings of its own also
gives the model its line in ``ftc_mj.config.sections.ESTIMATOR_KINDS``, which makes it a member of the
``[estimator]`` union; without it, as here, the table validates as a plug-in's: the filter model's settings.)
"""

from __future__ import annotations

import ast
import importlib
import sys
from pathlib import Path

import numpy as np

import ftc_mj.wiring.estimation as wiring
from ftc_mj.config import RunConfig
from ftc_mj.estimation import EKF, Measurement
from ftc_mj.registry import BUILTIN, estimators, settings_listing
from ftc_mj.wiring.estimation import build_estimator

MODULE = '''"""A second EKF, written as a built-in is: the class and its settings model, in one module."""

from ftc_mj.estimation.setup import FilterSettings
from ftc_mj.estimation.single import SingleFilter


class SecondEKF(SingleFilter):
    """The EKF's maths under another name."""

    member = "ekf"
    Settings = FilterSettings
'''


def test_a_builtin_estimator_is_one_module_and_one_registration(tmp_path: Path, monkeypatch) -> None:
    (tmp_path / "second_ekf.py").write_text(MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    cls = importlib.import_module("second_ekf").SecondEKF
    estimators.register("second-ekf", cls.from_context, origin=BUILTIN, section=cls.Settings)  # the registration
    try:
        cfg = RunConfig.model_validate({"estimator": {"kind": "second-ekf", "rate": 50.0},
                                        "sensors": {"yaw_rate_sigma": 0.01}})
        built = build_estimator(cfg)
        assert type(built) is cls and built.setup.dt == 0.02
        ekf = build_estimator(RunConfig.model_validate({"estimator": {"kind": "ekf", "rate": 50.0},
                                                        "sensors": {"yaw_rate_sigma": 0.01}}))
        assert isinstance(ekf, EKF)
        for k in range(20):  # the same maths: the same estimates, bit for bit
            u, z = np.array([5.0, 5.0 + 0.01 * k]), Measurement(10.0 + 0.01 * k, 0.001 * k)
            np.testing.assert_array_equal(built.step(u, z).x, ekf.step(u, z).x)
        listing = "\n".join(settings_listing(estimators))
        assert "  second-ekf — [estimator] FilterSettings:" in listing
        assert "    divergence_dwell: float in (0, 1e+06] = 1.0 — " in listing
    finally:
        estimators.unregister("second-ekf")
        sys.modules.pop("second_ekf", None)


def test_each_builtin_estimator_is_one_registration_line() -> None:
    """The wiring registers each built-in in one call, naming its class's ``from_context`` and ``Settings``
    (``none`` has no class); the classes live in their own modules of :mod:`ftc_mj.estimation`."""
    tree = ast.parse(Path(wiring.__file__).read_text())
    calls = [n for n in ast.walk(tree) if isinstance(n, ast.Call) and ast.unparse(n.func) == "estimators.register"]
    names = [n.args[0].value for n in calls]
    assert sorted(names) == sorted(n for n in estimators.names() if estimators.get(n).origin == BUILTIN)
    assert len(names) == len(set(names))
    for name in names:
        entry = estimators.get(name)
        if name == "none":
            continue
        owner = getattr(entry.factory, "__self__", None) or entry.factory.func.__self__  # a partial for the IMMs
        assert owner.__module__.startswith("ftc_mj.estimation.") and issubclass(entry.meta["section"], owner.Settings)
