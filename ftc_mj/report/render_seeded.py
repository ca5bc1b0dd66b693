"""``claims.md`` over seeds: every check with ``passed / applicable``, its Wilson 95 % interval, its
n/a count and reasons; the verdict rule; which seeds are development and which held-out; the
data-tuned parameters; and, given a baseline, what changed against it (:mod:`.compare`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from .checks import NA, NOT_RUN
from .render import (
    ICON,
    LABELS_NOTE,
    PLANT_NOTE,
    domain_section,
    domain_table,
    md_table,
    thresholds_table,
    variant_section,
    variant_table,
)
from .seeded import FAILS, HOLDS, LEVEL, RULE, UNDECIDED, SeededClaim, aggregate_table
from .seeds import DEV_SEEDS, HELD_OUT_START, describe
from .tuning import TUNED, TuningOutcome

RESULT_ICON = {HOLDS: "✔ holds", FAILS: "✘ fails", UNDECIDED: "❔ undecided", NA: "n/a", NOT_RUN: "not run"}
SHOW_FAILING = 5


def _counts(c: SeededClaim) -> str:
    return (f"{c.count(HOLDS)} hold, {c.count(FAILS)} fail, {c.count(UNDECIDED)} undecided"
            + (f", {c.count(NA)} n/a" if c.count(NA) else "") + (f", {c.count(NOT_RUN)} not run"
                                                                 if c.count(NOT_RUN) else ""))


def verdict_table(claims: Sequence[SeededClaim]) -> str:
    rows = []
    for c in claims:
        weakest = sorted((ch for ch in c.checks if ch.applicable), key=lambda ch: ch.interval.mean)[:2]
        rows.append({"#": c.id, "claim": c.title, "verdict": ICON[c.verdict], "checks": _counts(c),
                     "weakest checks": "; ".join(f"{ch.text}: {ch.passed}/{ch.applicable}" for ch in weakest)})
    return md_table(rows)


def checks_table(c: SeededClaim) -> str:
    """Every check that was run on some seed (the not-run ones are only counted in the heading)."""
    rows = []
    for ch in c.checks:
        if ch.result == NOT_RUN:
            continue
        iv = ch.interval
        fail = ch.failing_seeds()
        rows.append({"check": ch.text, "passed / applicable": f"{ch.passed}/{ch.applicable}",
                     "pass fraction [Wilson 95 %]": iv.fmt(pct=True) if ch.applicable else "—",
                     "n/a": ch.count(NA), "result": RESULT_ICON[ch.result],
                     "failing seeds": ", ".join(str(s) for s in fail[:SHOW_FAILING]) + (" …" if len(fail) > SHOW_FAILING
                                                                                         else "")})
    return md_table(rows)


def na_list(c: SeededClaim) -> list[str]:
    """One line per check that was n/a on some seed, with the reasons and their counts."""
    out = []
    for ch in c.checks:
        if ch.count(NA):
            why = "; ".join(f"{r} ({k})" for r, k in ch.reasons.most_common())
            out.append(f"- {ch.text}: n/a on {ch.count(NA)} of {len(ch.outcomes)} seeds — {why}")
    return out


def _has_data(row: Mapping[str, Any]) -> bool:
    """An evidence row with some number (rows of runs outside this invocation have none)."""
    return any(v is not None and v != "missing" for v in list(row.values())[2:])


def tuning_section(outcomes: Sequence[TuningOutcome] | None) -> str:
    parts = ["## Data-tuned parameters\n",
             f"Chosen on {describe(DEV_SEEDS)} by rules stated before the runs "
             f"(the built-in studies `tune_*`, `ftc-mj paper --tune`); the claims above are judged with the configured "
             f"defaults.\n"]
    if not outcomes:
        parts.append(md_table([{"parameter": t.key, "default": t.default(), "study": f"built-in {t.study}",
                                "rule": t.rule} for t in TUNED]))
        parts.append("\n_The tuning studies were not part of this invocation (`ftc-mj paper --tune`)._\n")
        return "\n".join(parts)
    for o in outcomes:
        t, sel = o.tuned, o.selection
        agree = "equals" if sel.value is not None and abs(sel.value - t.default()) < 1e-12 else "differs from"
        parts.append(f"### `{t.key}`\n\nRule: {t.rule}.\n\nOn {describe(tuple(o.seeds))} ({o.runs} runs, "
                     f"{o.failed} failed): chosen **{sel.value:g}** ({sel.why}); it {agree} the default "
                     f"{t.default():g}.\n" if sel.value is not None else
                     f"### `{t.key}`\n\nRule: {t.rule}.\n\nNo result ({sel.why}).\n")
        parts.append(md_table(sel.table))
    return "\n".join(parts)


def _claim_section(c: SeededClaim, note_seed: int) -> list[str]:
    out = [f"\n## {c.id}. {c.title} — {ICON[c.verdict]} ({_counts(c)})\n", f"**Paper.** {c.paper}\n"]
    if c.count(NOT_RUN) == len(c.checks):
        return out + ["_None of its runs is part of this invocation._\n"]
    out += ["**Checks** (each evaluated on every seed):\n", checks_table(c)]
    nas = na_list(c)
    if nas:
        out += ["\n**Not applicable** (precondition not met, by the rules stated in advance):\n", "\n".join(nas) + "\n"]
    out += [f"\n**Evidence** (median [min, max] over the {len(c.seeds)} seeds; booleans as count/seeds):\n",
            md_table([r for r in c.table() if _has_data(r)])]
    if c.notes.get(note_seed):
        out.append(f"\n**Why** (numbers of seed {note_seed} only). " + " ".join(c.notes[note_seed]) + "\n")
    return out


def render_seeded(claims: Sequence[SeededClaim], rows_by_seed: Mapping[int, Mapping[str, Mapping[str, Any]]],
                  meta: Mapping[str, Any], tuning: Sequence[TuningOutcome] | None = None,
                  changes: Sequence[tuple[str, Sequence[str]]] | None = None) -> str:
    """The whole ``claims.md`` over seeds."""
    seeds = tuple(sorted(rows_by_seed))
    n_runs = sum(len(r) for r in rows_by_seed.values())
    failed = [f"{lb} (seed {s})" for s, rows in rows_by_seed.items() for lb, r in rows.items()
              if r.get("status") != "ok"]
    n_conf = len({lb for rows in rows_by_seed.values() for lb in rows})
    parts = ["# Paper §4 claims checked on the MuJoCo plant — verdicts over seeds\n",
             f"Generated by `ftc-mj paper` from {n_runs} runs = {n_conf} configurations × {len(seeds)} seeds "
             f"({describe(seeds)}); {n_runs - len(failed)} ok"
             + (f", failed: {', '.join(failed)}" if failed else "")
             + (f"; duration {meta['duration']:g} s (shortened!)" if meta.get("duration") else "")
             + (f"; {meta['computed']} runs computed in {meta['wall_time_s']:.1f} s with {meta.get('jobs')} workers"
                if meta.get("wall_time_s") is not None else "") + ".\n",
             PLANT_NOTE + " Every check below is evaluated on each seed's runs separately (`summary.csv` has "
             "one row per run and seed) with the thresholds below.\n",
             "## Verdict rule\n", RULE + " " + _min_pass(len(seeds)) + "\n",
             "## Seeds\n", f"Development seeds: {', '.join(str(s) for s in DEV_SEEDS)} — the single-seed looks at "
             f"the matrix and the studies that shaped the loop used them, and the data-tuned parameters are chosen on "
             f"them. Held-out seeds: {HELD_OUT_START} and up, used by no study file. This report judges on "
             f"{describe(seeds)}.\n"]
    for src, lines in changes or []:
        parts += [f"## What changed against `{src}`\n",
                  "Compared mechanically (claims matched by id, checks by text; a single-seed pass that holds over "
                  "seeds is no change):\n", ("\n".join(lines) if lines else "- nothing") + "\n"]
    parts += ["## Verdicts\n", verdict_table(claims), "\n## Thresholds\n", thresholds_table(), "\n" + LABELS_NOTE]
    for c in claims:
        parts += _claim_section(c, seeds[0])
    parts.append("\n" + tuning_section(tuning))
    parts.append("\n" + variant_section(aggregate_table([variant_table(rows_by_seed[s]) for s in seeds])))
    parts.append("\n" + domain_section(aggregate_table([domain_table(rows_by_seed[s]) for s in seeds])))
    return "\n".join(parts) + "\n"


def _min_pass(n: int) -> str:
    """A sentence: from how many passes of ``n`` applicable seeds a check holds."""
    from ..study.analysis import rate_ci

    for k in range(n + 1):
        if rate_ci([True] * k + [False] * (n - k)).lo >= LEVEL:
            return f"With {n} applicable seeds a check holds from {k}/{n} passes and fails from {n - k}/{n} fails."
    return (f"With {n} seeds no check can hold or fail ({n}/{n} passes give a lower bound of "
            f"{rate_ci([True] * n).lo:.2f}): this is a validation run, not a verdict.")

