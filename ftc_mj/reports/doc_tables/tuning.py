"""The data-tuned parameters of docs/studies.md from the built-in tuning studies ``tune_dwell`` and
``tune_growth``: the selection rule of :mod:`ftc_mj.paper.tuning` applied to the study's results, the chosen
value next to the configured default, and the evidence per candidate value.

    ftc-mj study tune_dwell --workers 2
    ftc-mj study tune_dwell --report        # from runs/out/studies/tune-dwell
    ftc-mj study tune_dwell --report --out runs/out/paper/tuning/tune_dwell/<hash>   # what `ftc-mj paper --tune` ran

The same rules ``ftc-mj paper --tune`` applies, on the development seeds the study ran (0–9).
"""

from __future__ import annotations

from pathlib import Path

import polars as pl

from ...paper.render import md_table
from ...paper.tuning import STUDY_DIR, TUNED, Tuned
from ...study.spec import read_study_spec
from .results import read_results


def tuned_by_study() -> dict[str, Tuned]:
    """Each data-tuned parameter by the ``name`` of its study file (what ``ftc-mj study`` reports under and
    what names its default output folder: ``tune-dwell``, ``tune-growth``)."""
    return {read_study_spec(STUDY_DIR / f"{t.study}.toml").name: t for t in TUNED}


def report(out: Path, tuned: Tuned) -> str:
    """The runs counted, the value the selection rule chooses against the configured default and why, the
    rule, and the per-candidate table, from the study output folder ``out``."""
    df = read_results(out)
    if df.height == 0:
        return f"\n`{tuned.key}`: no results at {out}\n"
    sel = tuned.select(df)
    seeds = sorted(set(df["seed"].to_list()))
    head = (f"\n`{tuned.key}` ({df.height} runs, {df.filter(pl.col('status') != 'ok').height} not ok, seeds {seeds}): "
            f"chosen {sel.value}, configured {tuned.default():g} ({sel.why}).\n\nRule: {tuned.rule}.\n")
    return f"{head}\n{md_table(sel.table)}\n"
