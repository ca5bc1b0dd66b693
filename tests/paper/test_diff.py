"""The baseline diff: claims.json of either mode, a rendered claims.md, an old paper_run.json."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from ftc_mj.errors import BadInput
from ftc_mj.paper.claims import checks as ck
from ftc_mj.paper.claims.paper import evaluate_claims
from ftc_mj.paper.diff import claims_document, compare, load_baseline
from ftc_mj.paper.render import render_claims
from ftc_mj.paper.verdicts import combine
from tests.paper.rows import paper_like_rows
from tests.paper.test_verdicts import per_seed


def test_compare_with_a_single_seed_baseline() -> None:
    single = combine({0: evaluate_claims(paper_like_rows())}, single_seed=True)
    base = json.loads(json.dumps(claims_document(single, [0], "single-seed")))
    seeded = combine(per_seed(10, {1, 3, 5}))
    cur = json.loads(json.dumps(claims_document(seeded, range(10), "seeded")))
    lines = compare(cur, base)
    assert any("verdict reproduced → partly" in ln for ln in lines)
    changed = [ln for ln in lines if "EKF fb on declares" in ln]
    assert len(changed) == 1 and "pass → undecided (7/10" in changed[0]
    # a pass that holds over seeds is no change
    assert not any("UKF fb on declares" in ln for ln in lines)
    assert compare(base, base) == []


def test_baseline_from_a_rendered_claims_md(tmp_path: Path) -> None:
    rows = paper_like_rows()
    rows["s2-ekf-fb-nmpc"]["detection_delay"] = None  # claim 1 partly, the others reproduced
    claims = combine({0: evaluate_claims(rows)}, single_seed=True)
    md = tmp_path / "claims.md"
    md.write_text(render_claims(claims, {0: rows}, {}, single_seed=True))
    base = load_baseline(md)
    assert {c["id"]: c["verdict"] for c in base["claims"]} == {c.id: c.verdict for c in claims}
    assert base["claims"][0]["verdict"] == ck.PARTLY


def test_baseline_from_an_old_paper_run_json(tmp_path: Path) -> None:
    (tmp_path / "paper_run.json").write_text(json.dumps({"verdicts": {"1": "reproduced", "2": "partly"}}))
    base = load_baseline(tmp_path)
    seeded = combine(per_seed(3, set()))
    lines = compare(json.loads(json.dumps(claims_document(seeded, range(3), "seeded"))), base)
    assert any(ln.startswith("- claim 1") and "reproduced → undecided" in ln for ln in lines)
    with pytest.raises(BadInput, match="--baseline"):
        load_baseline(tmp_path / "nothing")
