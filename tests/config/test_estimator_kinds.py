"""The ``[estimator]`` section is a union discriminated by ``kind`` (issue 39): each kind reads its own
model, an older flat resolved table (every kind's settings, the others' at their defaults) still reads as
the same run, another kind's setting away from its default is a one-line error naming the kinds that have it,
and only the sigma-point filters carry ``kappa``."""

from __future__ import annotations

import pytest

from ftc_mj.config import RunConfig, from_sections, validate_config
from ftc_mj.config.sections import ESTIMATOR_KINDS
from ftc_mj.errors import BadInput
from ftc_mj.estimation.decision_settings import DecisionSettings
from ftc_mj.estimation.imm import IMMEKFSettings, IMMSettings
from ftc_mj.estimation.settings import PluginEstimatorSettings
from ftc_mj.estimation.ukf import UKFSettings
from ftc_mj.fields import StrictModel
from ftc_mj.registry import estimators
from ftc_mj.wiring.estimation import setup_from_config


class QScale(StrictModel):
    """A plug-in estimator's options."""

    q_scale: float = 1.0

FLAT = {**IMMSettings().model_dump(), "kappa": 0.001, "decision": DecisionSettings().model_dump(), "options": {}}
"""An ``[estimator]`` table as resolved configs wrote it when the section was one flat model."""


@pytest.mark.parametrize("kind", sorted(ESTIMATOR_KINDS))
def test_an_older_flat_table_reads_as_the_same_run(kind: str) -> None:
    model = ESTIMATOR_KINDS[kind]
    cfg = validate_config({"estimator": {**FLAT, "kind": kind, "rate": 50.0}})
    assert type(cfg.estimator) is model and cfg.estimator == model(rate=50.0)


def test_another_kinds_setting_away_from_its_default_is_named() -> None:
    with pytest.raises(BadInput, match=r"^estimator.imm_models: not a setting of estimator 'ekf' \(a setting of "
                                       r"imm-ekf, imm-ukf\)$"):
        validate_config({"estimator": {**FLAT, "kind": "ekf", "imm_models": 5}})
    with pytest.raises(BadInput, match=r"^estimator.kappa: not a setting of estimator 'imm-ekf' \(a setting of "
                                       r"ukf, imm-ukf\)$"):
        validate_config({"estimator": {"kind": "imm-ekf", "kappa": 2.0}})
    with pytest.raises(BadInput, match=r"^estimator.options: estimator 'none' takes no options \(got a\)$"):
        validate_config({"estimator": {"kind": "none", "options": {"a": 1}}})


def test_kappa_is_the_sigma_point_filters_only() -> None:
    """The EKF never reads κ, so its setup has none; the UKF's is its setting."""
    for kind, kappa in (("ekf", None), ("imm-ekf", None), ("ukf", 0.5), ("imm-ukf", 0.5)):
        extra = {"kappa": 0.5} if kappa is not None else {}
        cfg = RunConfig.model_validate({"estimator": {"kind": kind, **extra}})
        assert setup_from_config(cfg).kappa == kappa


def test_sections_and_defaults() -> None:
    assert type(RunConfig().estimator) is UKFSettings
    cfg = from_sections(estimator={"kind": "imm-ekf", "imm_models": 5})
    assert type(cfg.estimator) is IMMEKFSettings and cfg.estimator.bank_size == 5
    with pytest.raises(BadInput, match=r"^estimator.imm_models: not a setting of estimator 'ukf'"):
        from_sections(estimator={"imm_models": 5})


def test_a_plugin_kind_reads_the_plugin_member() -> None:
    """A plug-in's table keeps what the loop and the record read (the filter model's settings, the decision)
    beside its checked ``options``; no UKF or IMM setting."""
    estimators.register("test-kinds-est", lambda settings, context: None, settings=QScale)
    try:
        cfg = RunConfig.model_validate({"estimator": {"kind": "test-kinds-est", "rate": 20.0,
                                                      "options": {"q_scale": 2.0}}})
        assert type(cfg.estimator) is PluginEstimatorSettings and cfg.estimator.rate == 20.0
        assert cfg.estimator.options == {"q_scale": 2.0}
        with pytest.raises(BadInput, match=r"^estimator.kappa: not a setting of estimator 'test-kinds-est' \(a "
                                           r"setting of ukf, imm-ukf\)$"):
            validate_config({"estimator": {"kind": "test-kinds-est", "kappa": 2.0}})
    finally:
        estimators.unregister("test-kinds-est")
