"""``summary.csv``: one row per run and seed (label, seed, scenario, estimator, imm_models, feedback,
controller and the flattened metrics), written atomically, and read back."""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..io import atomic_path

ID_COLUMNS = ("label", "seed", "scenario", "estimator", "imm_models", "imm_variant", "feedback", "policy", "sensing",
              "rate_penalty", "controller", "extra",
              "status", "error", "run_id", "run_dir")


def _cell(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return "" if not math.isfinite(v) else repr(v)
    return str(v)


def write_summary_csv(path: Path, rows: Sequence[Mapping[str, Any]]) -> None:
    """Write the rows (already flat) with the identity columns first, atomically."""
    keys: list[str] = [k for k in ID_COLUMNS]
    for r in rows:
        for k in r:
            if k not in keys:
                keys.append(k)
    with atomic_path(Path(path)) as tmp:
        with open(tmp, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(keys)
            for r in rows:
                w.writerow([_cell(r.get(k)) for k in keys])


def read_summary_csv(path: Path) -> list[dict[str, Any]]:
    """Read ``summary.csv`` back (numbers as floats, empty cells as None, True/False as bools)."""
    rows: list[dict[str, Any]] = []
    with open(path, newline="") as fh:
        for rec in csv.DictReader(fh):
            row: dict[str, Any] = {}
            for k, v in rec.items():
                if v == "":
                    row[k] = None
                elif v in ("True", "False"):
                    row[k] = v == "True"
                else:
                    try:
                        row[k] = float(v)
                    except ValueError:
                        row[k] = v
            rows.append(row)
    return rows
