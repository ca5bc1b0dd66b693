"""The baseline diff: what changed between two ``ftc-mj paper`` results: claim verdicts and check results, matched by
claim id and check text.

Both sides are ``claims.json`` documents (:func:`claims_document`), single-seed or over seeds; an
older output folder that has only ``paper_run.json``, or a rendered ``claims.md`` (e.g. the published
``docs/paper-claims.md``), contributes its claim verdicts. A check's
result is reduced to a class before comparing — *yes* (pass, holds), *no* (fail, fails), *?*
(undecided), *n/a*, *not run* — so a single-seed pass that holds over seeds is no change, and a
single-seed pass that is undecided over seeds is one.
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..errors import BadInput
from .claims.checks import FAIL, NA, NOT_EVALUATED, NOT_REPRODUCED, NOT_RUN, PARTLY, PASS, REPRODUCED
from .verdicts import FAILS, HOLDS, UNDECIDED, CheckStats, Claim

CLASS = {PASS: "yes", HOLDS: "yes", FAIL: "no", FAILS: "no", UNDECIDED: "?", NA: "n/a", NOT_RUN: "not run"}


def claims_document(claims: Sequence[Claim], seeds: Sequence[int], mode: str) -> dict[str, Any]:
    """``claims.json``: every claim's verdict and every check's result, machine-readable (a single-seed
    check with its numbers and n/a reason, a check over seeds with its counts and interval)."""
    out = [{"id": c.id, "title": c.title, "verdict": c.verdict,
            "checks": [_check_document(ch, c.seeds[0]) if c.single_seed else _check_document(ch)
                       for ch in c.checks]} for c in claims]
    return {"mode": mode, "seeds": [int(s) for s in seeds], "claims": out}


def _check_document(ch: CheckStats, seed: int | None = None) -> dict[str, Any]:
    """One check of ``claims.json``: on ``seed`` alone when given, else over the seeds."""
    if seed is not None:
        reason = NOT_RUN if ch.outcomes.get(seed) == NOT_RUN else next(iter(ch.reasons), "")
        return {"text": ch.text, "result": ch.outcomes.get(seed), "detail": ch.details.get(seed, ""),
                "na_reason": reason}
    iv = ch.interval
    return {"text": ch.text, "result": ch.result, "passed": ch.passed, "applicable": ch.applicable,
            "na": ch.count(NA), "not_run": ch.count(NOT_RUN), "fraction": iv.mean, "lo": iv.lo, "hi": iv.hi,
            "na_reasons": dict(ch.reasons), "failing_seeds": ch.failing_seeds()}


def verdicts_of_markdown(text: str) -> dict[str, str]:
    """Claim id → verdict from the ``## Verdicts`` table of a rendered ``claims.md`` (or of
    ``docs/paper-claims.md``): the published verdicts, when no ``claims.json`` was kept."""
    known = sorted((REPRODUCED, PARTLY, NOT_REPRODUCED, NOT_EVALUATED, "undecided"), key=len, reverse=True)
    table = text.split("## Verdicts", 1)[-1].split("\n## ", 1)[0]
    out = {}
    for line in table.splitlines():
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line.strip())[1:-1]]
        if len(cells) < 3 or cells[0] in ("#", "") or set(cells[0]) <= {"-"}:
            continue
        verdict = next((v for v in known if v in cells[2]), None)
        if verdict is not None:
            out[cells[0]] = verdict
    return out


def load_baseline(path: Path) -> dict[str, Any]:
    """A baseline from a ``claims.json`` file, a rendered ``claims.md`` (its verdict table), or an
    output folder (its ``claims.json``, else the verdicts of its ``paper_run.json``). BadInput if
    there is none."""
    p = Path(path)
    if p.is_file() and p.suffix == ".md":
        verdicts = verdicts_of_markdown(p.read_text())
        if not verdicts:
            raise BadInput(f"--baseline: {p} has no verdict table")
        return {"mode": "single-seed", "seeds": [], "source": str(p),
                "claims": [{"id": k, "verdict": v, "checks": None} for k, v in verdicts.items()]}
    cand = [p] if p.is_file() else [p / "claims.json", p / "paper_run.json"]
    for f in cand:
        if not f.is_file():
            continue
        try:
            data = json.loads(f.read_text())
        except (OSError, ValueError) as err:
            raise BadInput(f"--baseline: {f} is unreadable ({err})") from None
        if "claims" in data:
            return data
        if "verdicts" in data:
            return {"mode": "single-seed", "seeds": [], "source": str(f),
                    "claims": [{"id": k, "verdict": v, "checks": None} for k, v in data["verdicts"].items()]}
        raise BadInput(f"--baseline: {f} holds neither claims nor verdicts")
    raise BadInput(f"--baseline: no claims.json or paper_run.json at {p}")


def _result_text(ch: Mapping[str, Any]) -> str:
    if "applicable" in ch:
        if not ch["applicable"]:
            return f"{ch['result']}"
        return f"{ch['result']} ({ch['passed']}/{ch['applicable']} [{ch['lo']:.2f}, {ch['hi']:.2f}])"
    return str(ch["result"])


def compare(current: Mapping[str, Any], baseline: Mapping[str, Any]) -> list[str]:
    """Markdown bullet lines: every verdict that changed and every check whose result class changed
    (or that exists on one side only)."""
    base = {c["id"]: c for c in baseline["claims"]}
    lines = []
    for c in current["claims"]:
        b = base.get(c["id"])
        if b is None:
            lines.append(f"- claim {c['id']} ({c['title']}): new — {c['verdict']}")
            continue
        head = f"claim {c['id']} ({c['title']}): verdict {b['verdict']} → {c['verdict']}"
        if b.get("checks") is None:
            if b["verdict"] != c["verdict"]:
                lines.append(f"- {head}")
            continue
        bchecks = {ch["text"]: ch for ch in b["checks"]}
        diffs = []
        for ch in c["checks"]:
            old = bchecks.pop(ch["text"], None)
            if old is None:
                diffs.append(f"  - new check: {ch['text']} — {_result_text(ch)}")
            elif CLASS.get(old["result"]) != CLASS.get(ch["result"]):
                diffs.append(f"  - {ch['text']}: {_result_text(old)} → {_result_text(ch)}")
        diffs += [f"  - dropped check: {t} (was {_result_text(ch)})" for t, ch in bchecks.items()]
        if diffs or b["verdict"] != c["verdict"]:
            lines.append(f"- {head}" if b["verdict"] != c["verdict"] else
                         f"- claim {c['id']} ({c['title']}): verdict {c['verdict']} (unchanged)")
            lines += diffs
    lines += [f"- claim {k}: dropped (was {b['verdict']})" for k, b in base.items()
              if k not in {c['id'] for c in current["claims"]}]
    return lines
