"""The claims ``ftc-mj paper`` judges: the check primitives (:mod:`.checks`), one module per claim
family — the paper's §4 claims 1–12 (:mod:`.paper`), the reconfiguration policies R1–R3
(:mod:`.policy`), path following P1 (:mod:`.pathfollow`) — the one table of the claims' statements
(:mod:`.texts`) and the one table of thresholds (:mod:`.thresholds`)."""

from __future__ import annotations

from .checks import Evidence, Rows, evaluate
from .paper import CLAIMS
from .pathfollow import PATHFOLLOW_CLAIMS
from .policy import POLICY_CLAIMS

ALL_CLAIMS = (*CLAIMS, *POLICY_CLAIMS, *PATHFOLLOW_CLAIMS)
"""Every claim function, in report order."""


def evaluate_all(rows: Rows) -> list[Evidence]:
    """Every claim of every family evaluated on the rows of one seed (label → flattened metrics)."""
    return evaluate(ALL_CLAIMS, rows)
