"""Claim verdicts: every check evaluated per seed, counted, and judged by a rule stated in advance —
over seeds with a Wilson interval, or on the one run of the single-seed quick look.

Each claim is evaluated on the rows of each seed separately (:mod:`.claims`; a failed run fails its
checks, an unmet precondition makes a check n/a). Per check, over the seeds: ``passed`` /
``applicable`` (applicable = passed + failed), the Wilson 95 % interval of the pass fraction
(:func:`pass_interval`), and the n/a and not-run counts with their reasons.

The verdict rule over seeds (:data:`RULE`):

- a check **holds** when the Wilson lower bound of its pass fraction is at least :data:`LEVEL` (½),
  **fails** when the upper bound is at most ½, and is **undecided** otherwise; it is **n/a** when no
  seed is applicable;
- a claim is **reproduced** when every check that is applicable on some seed holds, **not
  reproduced** when every such check fails, **undecided** when none of them holds or fails, and
  **partly** otherwise; **not evaluated** when no check is applicable on any seed.

Why ½: the paper's sentences say what the system does, not what it does in one lucky or unlucky
run. Under seeded sensor noise a sentence's check is taken as reproduced when the seeds show it
happens in most runs at 95 % confidence, and as contradicted when they show it happens in few.
With 10 seeds a check holds at ≥ 9/10 passes (9/10: [0.60, 0.98]) and fails at ≤ 1/10; 8/10
(interval [0.49, 0.94]) is undecided.

The single-seed quick look (:data:`SINGLE_SEED_RULE`) judges a check by its one outcome (pass or
fail) and a claim by the same claim rule, which there has no undecided case.
"""

from __future__ import annotations

import statistics
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ..study.stats import Estimate
from .claims.checks import FAIL, NA, NOT_EVALUATED, NOT_REPRODUCED, NOT_RUN, PARTLY, PASS, REPRODUCED, Evidence, fmt

LEVEL = 0.5
HOLDS, FAILS, UNDECIDED = "holds", "fails", "undecided"
UNDECIDED_CLAIM = "undecided"
RULE = (f"A check holds when the Wilson 95 % lower bound of its pass fraction over the applicable seeds is ≥ "
        f"{LEVEL:g}, fails when the upper bound is ≤ {LEVEL:g}, and is undecided otherwise (n/a when no seed is "
        f"applicable). A claim is reproduced when every applicable check holds, not reproduced when every one "
        f"fails, undecided when none holds or fails, partly otherwise. A failed run fails its checks; a check "
        f"whose precondition does not hold is n/a and never counts as a pass.")
SINGLE_SEED_RULE = ("Every claim is a set of checks, each pass or fail on this seed's run: all pass → reproduced, "
                    "none → not reproduced, otherwise partly. A failed run fails its checks; a check whose "
                    "precondition does not hold (listed with its reason) is n/a and not counted; runs missing from "
                    "the invocation leave their checks not run.")
YES, NO = (PASS, HOLDS), (FAIL, FAILS)
"""Check results that count for / against a claim (single seed, over seeds)."""


def pass_interval(k: int, n: int) -> Estimate:
    """Pass fraction ``k / n`` with its Wilson 95 % interval (``scipy.stats.binomtest``); NaN when
    ``n`` is 0."""
    if n == 0:
        return Estimate(float("nan"), float("nan"), float("nan"), 0)
    from scipy.stats import binomtest  # here, not at the module's import: `ftc-mj studies` lists without it

    ci = binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
    return Estimate(k / n, float(ci.low), float(ci.high), n)


@dataclass
class CheckStats:
    """One check over the seeds it was evaluated on."""

    text: str
    outcomes: dict[int, str] = field(default_factory=dict)
    """Seed → ``pass`` / ``fail`` / ``n/a`` / ``not run``."""
    details: dict[int, str] = field(default_factory=dict)
    """Seed → the numbers behind the outcome."""
    reasons: Counter[str] = field(default_factory=Counter)
    """Why the check was n/a (reason → number of seeds)."""
    single_seed: bool = False
    """Judged by its one outcome (the quick look) instead of the rule over seeds."""

    def count(self, outcome: str) -> int:
        return sum(1 for o in self.outcomes.values() if o == outcome)

    @property
    def passed(self) -> int:
        return self.count(PASS)

    @property
    def applicable(self) -> int:
        return self.count(PASS) + self.count(FAIL)

    @property
    def interval(self) -> Estimate:
        """Pass fraction over the applicable seeds with its Wilson 95 % interval."""
        return pass_interval(self.passed, self.applicable)

    @property
    def result(self) -> str:
        """Over seeds ``holds`` / ``fails`` / ``undecided`` (the rule of :data:`RULE`), on a single seed
        ``pass`` / ``fail``; ``n/a`` / ``not run`` when no seed is applicable."""
        if self.applicable == 0:
            return NOT_RUN if self.outcomes and self.count(NOT_RUN) == len(self.outcomes) else NA
        if self.single_seed:
            return PASS if self.passed else FAIL
        iv = self.interval
        if iv.lo >= LEVEL:
            return HOLDS
        if iv.hi <= LEVEL:
            return FAILS
        return UNDECIDED

    @property
    def detail(self) -> str:
        """The numbers behind the outcome on the first seed evaluated ("" before any)."""
        return self.details[min(self.details)] if self.details else ""

    def failing_seeds(self) -> list[int]:
        return [s for s, o in self.outcomes.items() if o == FAIL]

    def reason(self) -> str:
        """The n/a reasons with their seed counts, most frequent first."""
        return "; ".join(f"{r} ({k})" for r, k in self.reasons.most_common())


@dataclass
class Claim:
    """One claim judged over the seeds it was evaluated on (one seed in the quick look)."""

    id: str
    title: str
    paper: str
    checks: list[CheckStats]
    tables: dict[int, list[dict[str, Any]]]
    """Seed → evidence table."""
    notes: dict[int, list[str]]
    """Seed → interpretation."""
    seeds: tuple[int, ...]
    single_seed: bool = False

    def count(self, result: str) -> int:
        return sum(1 for c in self.checks if c.result == result)

    @property
    def verdict(self) -> str:
        return claim_verdict([c.result for c in self.checks])

    @property
    def table(self) -> list[dict[str, Any]]:
        """The evidence table: the seed's own in the quick look, else :func:`aggregate_table` over the seeds."""
        tables = [self.tables[s] for s in self.seeds if s in self.tables]
        return list(tables[0]) if self.single_seed and tables else aggregate_table(tables)


def claim_verdict(results: Sequence[str]) -> str:
    """The claim rule of :data:`RULE` (and :data:`SINGLE_SEED_RULE`) from its checks' results."""
    decided = [r for r in results if r in (*YES, *NO, UNDECIDED)]
    if not decided:
        return NOT_EVALUATED
    if all(r in YES for r in decided):
        return REPRODUCED
    if all(r in NO for r in decided):
        return NOT_REPRODUCED
    if all(r == UNDECIDED for r in decided):
        return UNDECIDED_CLAIM
    return PARTLY


def combine(per_seed: Mapping[int, Sequence[Evidence]], single_seed: bool = False) -> list[Claim]:
    """Judge the claims evaluated on each seed (same claims, same checks in the same order: check
    texts do not depend on the numbers, which is asserted); ``single_seed`` for the quick look."""
    seeds = tuple(sorted(per_seed))
    if not seeds:
        return []
    out = []
    for i, c0 in enumerate(per_seed[seeds[0]]):
        stats = [CheckStats(ch.text, single_seed=single_seed) for ch in c0.checks]
        tables, notes = {}, {}
        for s in seeds:
            c = per_seed[s][i]
            if c.id != c0.id or [ch.text for ch in c.checks] != [st.text for st in stats]:
                raise ValueError(f"claim {c0.id}: seed {s} has other checks than seed {seeds[0]}")
            for st, ch in zip(stats, c.checks, strict=True):
                st.outcomes[s] = ch.outcome
                st.details[s] = ch.detail
                if ch.outcome == NA:
                    st.reasons[ch.na] += 1
            tables[s], notes[s] = c.table, c.notes
        out.append(Claim(c0.id, c0.title, c0.paper, stats, tables, notes, seeds, single_seed))
    return out


# ------------------------------------------------------------------------------------- evidence
def _numeric(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def summarise(values: Sequence[Any]) -> Any:
    """One cell over the seeds: numbers → ``median [min, max]`` (n if some are missing); booleans →
    ``k/n``; anything else → the common value, or ``mixed``."""
    present = [v for v in values if v is not None and not (isinstance(v, float) and v != v)]
    if not present:
        return None
    if all(isinstance(v, bool) for v in present):
        return f"{sum(present)}/{len(present)}"
    if all(_numeric(v) for v in present):
        med = statistics.median(present)
        if len(present) == 1 or min(present) == max(present):
            txt = fmt(float(med))
        else:
            txt = f"{fmt(float(med))} [{fmt(float(min(present)))}, {fmt(float(max(present)))}]"
        return txt + (f" (n={len(present)})" if len(present) < len(values) else "")
    return present[0] if all(v == present[0] for v in present) else "mixed"


def aggregate_table(tables: Sequence[Sequence[Mapping[str, Any]]]) -> list[dict[str, Any]]:
    """Row-by-row, column-by-column :func:`summarise` of the same evidence table over seeds."""
    if not tables:
        return []
    n = max(len(t) for t in tables)
    out = []
    for i in range(n):
        rows = [t[i] for t in tables if i < len(t)]
        keys: list[str] = []
        for r in rows:
            keys += [k for k in r if k not in keys]
        out.append({k: summarise([r.get(k) for r in rows]) for k in keys})
    return out
