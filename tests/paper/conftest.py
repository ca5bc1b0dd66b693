"""Fixtures of the paper tests: fake run directories shared by the module that asks for them."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.paper.fake_runs import fake_run

FIGURE_LABELS = ["s2-ukf-fb-nmpc", "s2-ukf-nofb-nmpc", "s2-ukf-fb-lmpc", "s2-imm-ukf-fb-nmpc",
                 "s2-imm-ukf-fb-nmpc-paper", "s4-imm-ukf5-fb-nmpc", "s4-ukf-fb-nmpc", "s4-ekf-fb-nmpc"]
"""Runs that every figure kind but scenarios 1 and 3 can draw on."""


@pytest.fixture(scope="module")
def fake_run_dirs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Label → fake run directory of :data:`FIGURE_LABELS` (12 s each)."""
    runs = tmp_path_factory.mktemp("runs")
    return {lb: fake_run(runs, lb) for lb in FIGURE_LABELS}
