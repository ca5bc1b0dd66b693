"""What a study's ``run_fn`` returns, for tests that stand in an instantaneous fake for ``execute``
(:class:`ftc_mj.sim.run.RunOutcome`-like: ``.metrics``, ``.result.trace``, ``.run_dir``)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np


@dataclass
class FakeResult:
    """A simulation result: only its trace (columns of equal length, ``t`` in s)."""

    trace: dict[str, np.ndarray]


@dataclass
class FakeOutcome:
    """A run's outcome: its metrics, result and run folder (None without recording)."""

    metrics: dict[str, Any]
    result: FakeResult
    run_dir: Path | None = None
