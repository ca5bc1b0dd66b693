"""``ftc-mj components`` lists each built-in's settings from its settings model (the one declaration):
field, type and range, default, the first line of its docstring."""

from __future__ import annotations

from typer.testing import CliRunner

from ftc_mj.cli import app
from ftc_mj.estimation import DecisionSettings, IMMSettings
from ftc_mj.estimation.ekf import EKFSettings
from ftc_mj.estimation.imm import IMMUKFSettings
from ftc_mj.fields import describe_settings
from ftc_mj.reconfiguration import ReconfigurationSettings


def test_components_lists_the_builtins_settings() -> None:
    res = CliRunner().invoke(app, ["components"])
    assert res.exit_code == 0, res.output
    out = res.output
    assert "  ekf — [estimator] EKFSettings:" in out  # each kind its own model: the EKF has no sigma points
    assert "  imm-ukf — [estimator] IMMUKFSettings:" in out
    assert "  auto, cusum, glr, mode, sigma — [estimator.decision] DecisionSettings:" in out
    assert "  safe — [reconfiguration] ReconfigurationSettings:" in out
    for model in (EKFSettings, IMMUKFSettings, DecisionSettings, ReconfigurationSettings):
        for row in describe_settings(model):
            assert f"    {row}\n" in out


def test_a_row_is_generated_from_the_model() -> None:
    """Type and range, default and docstring come from the declaration itself."""
    rows = {r.split(":", 1)[0]: r for r in describe_settings(IMMSettings)}
    assert rows["rate"] == "rate: float in (0, 10000] Hz = 100.0 — Filter rate (Hz); dt = 1/rate."
    assert rows["imm_models"].startswith("imm_models: 4 | 5 = 4 — The paper's IMM bank: 4 models")
    assert rows["p_stay"].startswith("p_stay: float in (0, 1) | none = None — Diagonal of a custom bank's")
    assert rows["q_diffusion"].startswith("q_diffusion: tuple[5 × float in [0, 1e+06]] = (0.25, 0.25, 0.0001")
    assert set(rows) == set(IMMSettings.model_fields)
