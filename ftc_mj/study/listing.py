"""What a study is before it runs: ``ftc-mj studies`` (each built-in study's run count, simulated
time, full description and the analyses that apply to it) and ``ftc-mj study NAME --list`` (its
plan, one run a line). Reads the plan only; nothing is simulated or written."""

from __future__ import annotations

import textwrap
from collections.abc import Collection
from pathlib import Path
from typing import Any

from .plan import StudyPlan

FAULT_AXIS = "severity"
"""The axis ``ftc-mj fdi-curves`` reads the fault from by default (``--fault-axis``)."""


def _no_fault(config: dict[str, Any]) -> bool:
    """The run's fault schedules are all empty."""
    return not any((config.get("faults") or {}).values())


def fdi_curves_apply(plan: StudyPlan) -> bool:
    """Whether ``ftc-mj fdi-curves`` can read the study's results: a :data:`FAULT_AXIS` axis, every run
    logging the decision statistics (``estimator.decision.statistics``) and some runs without a fault
    (the false alarms are measured on them)."""
    if FAULT_AXIS not in plan.axis_columns or not plan.runs:
        return False
    logged = all(((r.config.get("estimator") or {}).get("decision") or {}).get("statistics") for r in plan.runs)
    return logged and any(_no_fault(r.config) for r in plan.runs)


def analyses(plan: StudyPlan, published: Collection[str] = ()) -> list[str]:
    """The analyses that apply to the study, as the commands or files that give them (``OUT``: its
    output folder); ``published``: the built-in studies with published docs tables (given by the caller,
    :func:`ftc_mj.reports.doc_tables.doc_table_studies`: the reports layer sits above the studies)."""
    out = ["OUT/summary.md and OUT/figures/ (written at the end of every study)"]
    if plan.spec.name in published:
        out.append(f"ftc-mj study {plan.path.stem} --report (its published docs tables)")
    if fdi_curves_apply(plan):
        out.append("ftc-mj fdi-curves OUT (FDI operating characteristics)")
    return out


def simulated_s(plan: StudyPlan) -> float:
    """Simulated time of all the study's runs (s)."""
    return float(sum(float(r.config.get("duration", 0.0)) for r in plan.runs))


def _hours(seconds: float) -> str:
    return f"{seconds / 3600:.1f} h" if seconds >= 3600 else f"{seconds / 60:.0f} min"


def measured_rate(out: Path) -> float | None:
    """Runs per minute this machine computed for the study whose output folder is ``out``: all the runs its
    finished invocations computed over their wall time (``log.jsonl``); ``None`` before any."""
    from .store import StudyStore

    ends = [e for e in StudyStore(out).read_log() if e.get("event") == "end" and e.get("computed")]
    runs = sum(int(e["computed"]) for e in ends)
    wall = sum(float(e.get("wall_time_s") or 0.0) for e in ends)
    return 60.0 * runs / wall if runs and wall > 0 else None


def study_entry(name: str, plan: StudyPlan, width: int = 100, out: Path | None = None,
                published: Collection[str] = ()) -> list[str]:
    """The lines ``ftc-mj studies`` prints for one built-in study: name, run count and simulated time (and,
    if its output folder ``out`` records finished invocations, the expected duration at the rate measured
    there), the whole description wrapped to ``width`` characters, the analyses that apply (``published``:
    as for :func:`analyses`)."""
    head = f"{name}: {len(plan.runs)} runs, {_hours(simulated_s(plan))} simulated"
    rate = measured_rate(out) if out is not None else None
    if rate:
        head += f"; about {_hours(60.0 * len(plan.runs) / rate)} at the {rate:.3g} runs/min measured in {out}"
    desc = " ".join(plan.spec.description.split()) or "(no description)"
    wrap = {"width": width, "break_on_hyphens": False, "break_long_words": False, "initial_indent": "    "}
    lines = [head, *textwrap.wrap(desc, subsequent_indent="    ", **wrap)]
    lines += textwrap.wrap("analyses: " + "; ".join(analyses(plan, published)), subsequent_indent="      ", **wrap)
    return lines


def plan_lines(plan: StudyPlan) -> list[str]:
    """The plan of ``ftc-mj study NAME --list``: a head line (runs, axes, seeds, simulated time), then one
    line per run: index, key, the axis labels and the seed, tab-separated."""
    seeds = list(dict.fromkeys(r.seed for r in plan.runs))
    axes = " x ".join(f"{c} ({len({str(r.labels.get(c)) for r in plan.runs})})" for c in plan.axis_columns)
    head = (f"# {plan.spec.name}: {len(plan.runs)} runs = {axes or 'no axis'} x {len(seeds)} seed(s); "
            f"{_hours(simulated_s(plan))} simulated; nothing was run")
    rows = [f"{r.index}\t{r.key}\t" + " ".join(f"{c}={r.labels.get(c)}" for c in plan.axis_columns)
            + f"\tseed={r.seed}" for r in plan.runs]
    return [head, *rows]
