"""Apply the selection rules of the data-tuned parameters to finished tuning studies and print them.

    .venv/bin/ftc-mj study tune_dwell --workers 2
    .venv/bin/ftc-mj study tune_growth --workers 2
    .venv/bin/python docs/tools/tuning_table.py [runs/out/studies]

The same rules ``ftc-mj paper --tune`` applies (:mod:`ftc_mj.paper.tuning`), on the study output
folders ``tune-dwell`` and ``tune-growth`` (development seeds 0–9), with the configured default next
to the chosen value.
"""

from __future__ import annotations

import sys
from pathlib import Path

import polars as pl

from ftc_mj.paper.render import md_table
from ftc_mj.paper.tuning import TUNED

FOLDERS = {"tune_dwell": "tune-dwell", "tune_growth": "tune-growth"}


def main(argv: list[str]) -> None:
    root = Path(argv[1] if len(argv) > 1 else "runs/out/studies")
    for t in TUNED:
        f = root / FOLDERS[t.study] / "results.parquet"
        if not f.is_file():
            print(f"\n`{t.key}`: no results at {f}")
            continue
        df = pl.read_parquet(f)
        sel = t.select(df)
        seeds = sorted(set(df["seed"].to_list()))
        print(f"\n`{t.key}` ({df.height} runs, {df.filter(pl.col('status') != 'ok').height} not ok, seeds {seeds}): "
              f"chosen {sel.value}, configured {t.default():g} ({sel.why}).\n\nRule: {t.rule}.\n")
        print(md_table(sel.table))


if __name__ == "__main__":
    main(sys.argv)
