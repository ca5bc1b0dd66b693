"""claims.md in both modes (thresholds, verdicts, the variant sections) and summary.csv."""

from __future__ import annotations

from typing import Any

from ftc_mj.paper.claims import evaluate_all
from ftc_mj.paper.claims.thresholds import THRESHOLDS
from ftc_mj.paper.render import render_claims
from ftc_mj.paper.summary import read_summary_csv, write_summary_csv
from ftc_mj.paper.verdicts import combine
from tests.paper.rows import paper_like_rows, policy_rows


def test_render_claims_states_thresholds_and_verdicts(tmp_path: Any) -> None:
    rows = paper_like_rows()
    rows.update({lb: {"label": lb, **r} for lb, r in policy_rows().items()})
    claims = combine({0: evaluate_all(rows)}, single_seed=True)
    md = render_claims(claims, {0: rows}, {"wall_time_s": 12.3, "jobs": 2, "computed": 3}, single_seed=True)
    assert "## Thresholds" in md and "single-seed quick look" in md and "| ✔ pass |" in md
    for name in THRESHOLDS:
        assert name in md
    assert "reproduced" in md and "partly" in md
    assert "`paper`" in md and "hypothesis" in md
    # summary.csv round trip
    path = tmp_path / "summary.csv"
    write_summary_csv(path, list(rows.values()))
    back = read_summary_csv(path)
    assert len(back) == len(rows)
    assert back[0]["label"] == next(iter(rows))
    assert isinstance(back[0]["radius_rmse_L"], float)
    assert back[0]["false_alarm"] is False
    # verdicts from the CSV equal those from the in-memory rows
    by_csv = {r["label"]: r for r in back}
    assert [c.verdict for c in combine({0: evaluate_all(by_csv)}, single_seed=True)] == [c.verdict for c in claims]
