"""``claims.md``: the verdict rule, the seeds, the verdicts, the thresholds, and per claim its checks
(over seeds: ``passed / applicable`` with the Wilson 95 % interval and the failing seeds; in the
single-seed quick look: pass/fail with the run's numbers), the n/a reasons, the evidence and the
interpretation; then the data-tuned parameters, the IMM variants and the plant-domain table, and,
given a baseline, what changed against it (:mod:`.diff`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from ..markdown import dict_table
from .claims.checks import FAIL, NA, NOT_EVALUATED, NOT_REPRODUCED, NOT_RUN, PARTLY, PASS, REPRODUCED, fmt, num
from .claims.paper import lbl
from .claims.thresholds import THRESHOLDS
from .seeds import DEV_SEEDS, HELD_OUT_START, describe
from .tuning import TUNED, TuningOutcome
from .verdicts import (
    FAILS,
    HOLDS,
    LEVEL,
    RULE,
    SINGLE_SEED_RULE,
    UNDECIDED,
    CheckStats,
    Claim,
    aggregate_table,
    pass_interval,
)

ICON = {REPRODUCED: "✅ reproduced", PARTLY: "🟡 partly", NOT_REPRODUCED: "❌ not reproduced",
        NOT_EVALUATED: "⚪ not evaluated", "undecided": "❔ undecided"}
RESULT_ICON = {HOLDS: "✔ holds", FAILS: "✘ fails", UNDECIDED: "❔ undecided", PASS: "✔ pass", FAIL: "✘ fail",
               NA: "n/a", NOT_RUN: "not run"}
SHOW_FAILING = 5
"""Failing seeds listed per check (the rest as …)."""
PLANT_NOTE = ("The paper's robot is a kinematic model in MATLAB; ours is a MuJoCo multibody plant with tyre contact, "
              "so where the paper's closed loop does not reproduce that is a finding, not a tuning target.")
LABELS_NOTE = ("Run labels: `s<scenario>-<filter>[5]-<fb|nofb>-<controller>` (feedback off/on = reconfiguration "
               "policy none/direct); the IMM banks have 4 models unless the label says `5`. The reconfiguration-policy "
               "axis (claims R1–R3): `s<scenario>-ukf-<policy>-<speed|yaw>-nmpc-rp` (`-rp`: NMPC with the "
               "actuation-rate term); the path-following axis (claim P1) the same with `pf-nmpc`. Scenario 4's ramp "
               "starts at t = 10 s and reaches 0.1 m at 29 s.\n")


def md_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """A Markdown table of dict rows (the union of keys, in first-seen order; values by :func:`fmt`)."""
    return dict_table(rows, fmt)


def thresholds_table() -> str:
    return md_table([{"name": k, "value": v, "meaning": d} for k, (v, d) in THRESHOLDS.items()])


# ------------------------------------------------------------------------------------- verdicts and checks
def _counts(c: Claim) -> str:
    """How the claim's checks came out, e.g. ``3 hold, 1 fail, 0 undecided, 2 n/a``."""
    decided = ((PASS, "pass"), (FAIL, "fail")) if c.single_seed else \
        ((HOLDS, "hold"), (FAILS, "fail"), (UNDECIDED, "undecided"))
    return (", ".join(f"{c.count(r)} {name}" for r, name in decided)
            + (f", {c.count(NA)} n/a" if c.count(NA) else "")
            + (f", {c.count(NOT_RUN)} not run" if c.count(NOT_RUN) else ""))


def _check_summary(ch: CheckStats, seed: int) -> str:
    """``text: k/n`` over seeds; ``✘ text — numbers`` on a single seed."""
    if ch.single_seed:
        return f"{RESULT_ICON[ch.result][0]} {ch.text} — {ch.details.get(seed, '')}"
    return f"{ch.text}: {ch.passed}/{ch.applicable}"


def verdict_table(claims: Sequence[Claim]) -> str:
    """One row per claim: verdict, check counts and its two weakest checks."""
    rows = []
    for c in claims:
        weakest = sorted((ch for ch in c.checks if ch.applicable), key=lambda ch: ch.interval.mean)[:2]
        rows.append({"#": c.id, "claim": c.title, "verdict": ICON[c.verdict], "checks": _counts(c),
                     "weakest checks": "; ".join(_check_summary(ch, c.seeds[0]) for ch in weakest)})
    return md_table(rows)


def checks_table(c: Claim) -> str:
    """Every check that was run on some seed (the not-run ones are only counted in the heading)."""
    rows = []
    for ch in c.checks:
        if ch.result == NOT_RUN:
            continue
        if c.single_seed:
            rows.append({"check": ch.text, "result": RESULT_ICON[ch.result], "numbers": ch.details[c.seeds[0]]})
            continue
        iv = ch.interval
        fail = ch.failing_seeds()
        rows.append({"check": ch.text, "passed / applicable": f"{ch.passed}/{ch.applicable}",
                     "pass fraction [Wilson 95 %]": iv.fmt(pct=True) if ch.applicable else "—",
                     "n/a": ch.count(NA), "result": RESULT_ICON[ch.result],
                     "failing seeds": ", ".join(str(s) for s in fail[:SHOW_FAILING]) + (" …" if len(fail) > SHOW_FAILING
                                                                                         else "")})
    return md_table(rows)


def na_list(c: Claim) -> list[str]:
    """One line per check that was n/a on some seed, with the reasons and their counts."""
    return [f"- {ch.text}: n/a on {ch.count(NA)} of {len(ch.outcomes)} seeds — {ch.reason()}"
            for ch in c.checks if ch.count(NA)]


def _has_data(row: Mapping[str, Any]) -> bool:
    """An evidence row with some number (rows of runs outside this invocation have none)."""
    return any(v is not None and v != "missing" for v in list(row.values())[2:])


def _claim_section(c: Claim, note_seed: int) -> list[str]:
    out = [f"\n## {c.id}. {c.title} — {ICON[c.verdict]} ({_counts(c)})\n", f"**Paper.** {c.paper}\n"]
    if c.count(NOT_RUN) == len(c.checks):
        return out + ["_None of its runs is part of this invocation._\n"]
    out += ["**Checks** (each evaluated on every seed):\n" if not c.single_seed else "**Checks**:\n", checks_table(c)]
    nas = na_list(c)
    if nas:
        out += ["\n**Not applicable** (precondition not met, by the rules stated in advance):\n", "\n".join(nas) + "\n"]
    out += [f"\n**Evidence** (seed {note_seed}):\n" if c.single_seed else
            f"\n**Evidence** (median [min, max] over the {len(c.seeds)} seeds; booleans as count/seeds):\n",
            md_table([r for r in c.table if _has_data(r)])]
    if c.notes.get(note_seed):
        why = "**Why.** " if c.single_seed else f"**Why** (numbers of seed {note_seed} only). "
        out.append("\n" + why + " ".join(c.notes[note_seed]) + "\n")
    return out


# ------------------------------------------------------------------------------------- the other sections
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


VARIANT_COLUMNS = (("mode-3 delay [s]", "mode_delay_1"), ("correct-mode fraction", "mode_correct_fraction"),
                   ("final spread of mode probs", "mode_prob_spread_final"),
                   ("R_L RMSE after fault [m]", "radius_rmse_L_after_fault"),
                   ("R_L final error [m]", "radius_final_error_L"), ("in ±2σ", "innovation_in_2sigma"),
                   ("max |cte| after fault [m]", "cross_track_max_after_fault"))
"""(column header, metric) of the IMM-variant table."""


def variant_table(rows: Mapping[str, Mapping[str, Any]]) -> list[dict[str, Any]]:
    """The scenario 2 IMM-UKF runs of both variants, feedback off and on."""
    table = []
    for fb in (False, True):
        for variant in ("hypothesis", "paper"):
            lb = lbl(2, "imm-ukf", fb, variant=variant)
            r = rows.get(lb)
            if r is None:
                continue
            table.append({"run": lb} | {head: num(r, metric) for head, metric in VARIANT_COLUMNS})
    return table


def variant_section(table: list[dict[str, Any]]) -> str:
    out = ["## IMM variants: `hypothesis` (default) vs `paper` (as printed)\n",
           "The IMM exactly as printed in the paper (variant `paper`) gives every model the same dynamics and "
           "noise; the models differ only in their initial radii, so the mixing step merges them within a few "
           "hundred steps and the mode probabilities stay near 1/M. The default variant `hypothesis` "
           "pins each model's radii to its hypothesis (or to the ramp law for model 5), so the likelihoods differ "
           "and the mode probabilities mean something. All claims above use `hypothesis`; the extra runs below "
           "(beyond the paper's 38) show the literal variant in scenario 2.\n"]
    if not table:
        out.append("_The extra `paper`-variant runs were not part of this invocation._\n")
    else:
        out.append(md_table(table))
        out.append("\nSee `figures/imm_variants_s2.png`.\n")
    return "\n".join(out)


def domain_table(rows: Mapping[str, Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Plant domain, solver and filter health, one row per run."""
    return [{"run": lb, "status": r.get("status"), "out-of-domain fraction": num(r, "plant_out_of_domain_fraction"),
             "max |slip|": num(r, "max_abs_slip"), "max |roll| [deg]": num(r, "max_abs_roll_deg"),
             "solver failures": num(r, "solver_failures"), "filter resets": num(r, "filter_resets"),
             "wall [s]": num(r, "wall_time_s")} for lb, r in rows.items()]


def domain_section(table: list[dict[str, Any]]) -> str:
    return ("## Plant domain, solver and filter health per run\n\nThe MuJoCo plant reports when it leaves the "
            "kinematic model's domain (slip, lift-off, roll, scraping); such runs test the physical robot, not "
            "the paper's kinematic one.\n\n" + md_table(table))


# ------------------------------------------------------------------------------------- the document
def _header(rows_by_seed: Mapping[int, Mapping[str, Mapping[str, Any]]], meta: Mapping[str, Any],
            single: bool) -> list[str]:
    """Title, provenance line, verdict rule and seeds."""
    seeds = tuple(sorted(rows_by_seed))
    n_runs = sum(len(r) for r in rows_by_seed.values())
    failed = [f"{lb} (seed {s})" for s, rows in rows_by_seed.items() for lb, r in rows.items()
              if r.get("status") != "ok"]
    n_conf = len({lb for rows in rows_by_seed.values() for lb in rows})
    title = "single-seed quick look" if single else "verdicts over seeds"
    parts = [f"# Paper §4 claims checked on the MuJoCo plant — {title}\n"]
    if single:
        parts.append(f"**Single seed ({seeds[0]}, a development seed): a quick look, not a verdict over seeds.** "
                     f"Every number below is one run's; `ftc-mj paper` without `--quick` judges each check over "
                     f"held-out seeds with an interval.\n")
    parts += [f"Generated by `ftc-mj paper{' --quick' if single else ''}` from {n_runs} runs = {n_conf} configurations "
              f"× {len(seeds)} seeds ({describe(seeds)}); {n_runs - len(failed)} ok"
              + (f", failed: {', '.join(failed)}" if failed else "")
              + (f"; duration {meta['duration']:g} s (shortened!)" if meta.get("duration") else "")
              + (f"; {meta['computed']} runs computed in {meta['wall_time_s']:.1f} s with {meta.get('jobs')} workers"
                 if meta.get("wall_time_s") is not None else "") + ".\n",
              PLANT_NOTE + " Every check below is evaluated on each seed's runs separately (`summary.csv` has "
              "one row per run and seed) with the thresholds below.\n",
              "## Verdict rule\n", (SINGLE_SEED_RULE if single else RULE + " " + _min_pass(len(seeds))) + "\n",
              "## Seeds\n", f"Development seeds: {', '.join(str(s) for s in DEV_SEEDS)} — the single-seed looks at "
              f"the matrix and the studies that shaped the loop used them, and the data-tuned parameters are chosen "
              f"on them. Held-out seeds: {HELD_OUT_START} and up, used by no tuning study (a study flagged "
              "tuning = true refuses them). This report judges on "
              f"{describe(seeds)}.\n"]
    return parts


def render_claims(claims: Sequence[Claim], rows_by_seed: Mapping[int, Mapping[str, Mapping[str, Any]]],
                  meta: Mapping[str, Any], tuning: Sequence[TuningOutcome] | None = None,
                  changes: Sequence[tuple[str, Sequence[str]]] | None = None, single_seed: bool = False) -> str:
    """The whole ``claims.md``: over seeds, or the single-seed quick look (``single_seed``)."""
    seeds = tuple(sorted(rows_by_seed))
    parts = _header(rows_by_seed, meta, single_seed)
    for src, lines in changes or []:
        parts += [f"## What changed against `{src}`\n",
                  "Compared mechanically (claims matched by id, checks by text; a single-seed pass that holds over "
                  "seeds is no change):\n", ("\n".join(lines) if lines else "- nothing") + "\n"]
    parts += ["## Verdicts\n", verdict_table(claims), "\n## Thresholds\n", thresholds_table(), "\n" + LABELS_NOTE]
    for c in claims:
        parts += _claim_section(c, seeds[0])
    parts.append("\n" + tuning_section(tuning))
    variants = [variant_table(rows_by_seed[s]) for s in seeds]
    domains = [domain_table(rows_by_seed[s]) for s in seeds]
    parts.append("\n" + variant_section(variants[0] if single_seed and variants else aggregate_table(variants)))
    parts.append("\n" + domain_section(domains[0] if single_seed and domains else aggregate_table(domains)))
    return "\n".join(parts) + "\n"


def _min_pass(n: int) -> str:
    """A sentence: from how many passes of ``n`` applicable seeds a check holds."""
    for k in range(n + 1):
        if pass_interval(k, n).lo >= LEVEL:
            return f"With {n} applicable seeds a check holds from {k}/{n} passes and fails from {n - k}/{n} fails."
    return (f"With {n} seeds no check can hold or fail ({n}/{n} passes give a lower bound of "
            f"{pass_interval(n, n).lo:.2f}): this is a validation run, not a verdict.")
