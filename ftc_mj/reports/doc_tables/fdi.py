"""Regenerate the two summary tables of docs/fdi.md, "FDI operating characteristics", from a finished
``fdi`` study (``ftc-mj study fdi``; the full tables are ``ftc-mj fdi-curves``'s ``fdi.md``):

    ftc-mj study fdi --report      # from runs/out/studies/fdi

1. Every rule at its design threshold: ARL0 with its Garwood 95 % interval and number of alarms, the
   conditional delay per severity (mean and its percentile-bootstrap 95 % interval, never below zero,
   (n) the runs that alarmed at or after the onset), and as counts per severity (20 · 50 · 80 %) the runs detected
   within 2 s, the detections isolating the true wheel and those isolating ``unknown``.
2. Per severity, each rule's shortest delay over the swept thresholds whose ARL0 reaches 100 s with
   95 % confidence on all seeds and that detect at least half of the runs within 2 s (the
   "Shortest delay" table of ``fdi.md``, with intervals), next to Lorden's bound at the ARL0 lower
   limit of no false alarm in the cell's fault-free seconds.

Definitions: :mod:`ftc_mj.study.fdi.curves`. Cells whose rows are identical (EKF and UKF, IMM-EKF
and IMM-UKF) are printed once.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ... import markdown as md
from ...study.fdi.cells import RULES, Cell, load_cells
from ...study.fdi.curves import (
    Point,
    arl0_of,
    design_threshold,
    lorden_bound,
    operating_point,
    poisson_rate,
    thresholds,
)
from ...study.stats import Estimate

HORIZON = 2.0
LEVEL = 100.0
NAMES = {"ekf": "EKF", "ukf": "UKF", "imm-ekf": "IMM-EKF", "imm-ukf": "IMM-UKF"}


def g(x: float, s: int = 3) -> str:
    """``s`` significant digits."""
    return f"{x:.{s}g}"


def arl(p: Point) -> str:
    """ARL0 (s) with its Garwood 95 % interval and the number of alarms."""
    a = p.arl0
    if a.n == 0:
        return f"> {a.lo:.0f} (0)"
    hi = "∞" if not math.isfinite(a.hi) else g(a.hi)
    return f"{g(a.mean)} [{g(a.lo)}, {hi}] ({a.n})"


def delay(e: Estimate) -> str:
    """Mean delay (s) and its percentile-bootstrap 95 % interval (runs)."""
    if e.n == 0:
        return "— (0)"
    if e.n == 1 or not math.isfinite(e.lo):
        return f"{g(e.mean)} (1)"
    return f"{g(e.mean)} [{g(e.lo, 2)}, {g(e.hi, 2)}] ({e.n})"


def count(e: Estimate) -> str:
    """A proportion as ``k/n``."""
    return "—" if e.n == 0 else f"{round(e.mean * e.n)}/{e.n}"


def cell_rows(cell: Cell) -> tuple[list[tuple[str, ...]], list[tuple[str, ...]]]:
    """Rows (cells) of table 1 and table 2 of a cell, without the filter column."""
    assert cell.config is not None
    plant, sensors = str(cell.key["plant"]), str(cell.key["sensors"])
    sevs = sorted(cell.faults, key=float)
    dt = 1.0 / cell.config.estimator.rate
    design, best = [], {}
    for rule in RULES:
        h_d = design_threshold(cell.config, rule)
        grid = thresholds(cell, rule, h_d)
        if grid.size == 0:
            continue
        p = operating_point(cell, rule, h_d, HORIZON)
        design.append([plant, sensors, rule, g(p.h), arl(p), *(delay(p.delay[s]) for s in sevs),
                       *(" · ".join(count(getattr(p, f)[s]) for s in sevs) for f in ("pd", "iso", "unknown"))])
        pts = [operating_point(cell, rule, float(h), HORIZON) for h in grid]
        for s in sevs:
            ok = [q for q in pts if q.arl0.lo >= LEVEL and q.pd[s].mean >= 0.5 and math.isfinite(q.delay[s].mean)]
            b = min(ok, key=lambda q, s=s: q.delay[s].mean) if ok else None
            best[(rule, s)] = f"{delay(b.delay[s])}, {count(b.pd[s])}" if b else "none"
    # the ARL0 lower limit with no false alarm in the cell's fault-free seconds
    floor = arl0_of(poisson_rate(0, sum(r.duration for r in cell.nofault))).lo
    table2 = []
    for s in sevs:
        bound = float(lorden_bound(cell, s, np.array([floor]), dt)[0])
        table2.append([plant, sensors, f"{100 * float(s):.0f} %", g(bound, 2),
                       *(best.get((r, s), "—") for r in RULES)])
    return [tuple(r) for r in design], [tuple(r) for r in table2]


Rows = list[tuple[str, list[tuple[str, ...]]]]


def merged(cells: list[Cell]) -> tuple[Rows, Rows]:
    """Per table, (filters, rows) with the filters whose rows are identical merged."""
    out: tuple[dict, dict] = ({}, {})
    for cell in cells:
        rows = cell_rows(cell)
        for i in range(2):
            key = (str(cell.key["plant"]), str(cell.key["sensors"]), tuple(rows[i]))
            out[i].setdefault(key, []).append(NAMES.get(str(cell.key["estimator"]), str(cell.key["estimator"])))
    return tuple([(", ".join(f), list(k[2])) for k, f in d.items()] for d in out)  # type: ignore[return-value]


def with_filters(row: tuple[str, ...], filters: str) -> str:
    """A row with the filters column inserted after plant and sensors."""
    return md.row([*row[:2], filters, *row[2:]])


def report(out: Path) -> str:
    """Both summary tables from the ``fdi`` study's output folder."""
    cells, _ = load_cells(Path(out), "severity")
    t1, t2 = merged(cells)
    lines = md.table(["plant", "sensors", "filters", "rule", "threshold", "ARL0 s [95 %] (alarms)", "delay s, 20 %",
                      "delay s, 50 %", "delay s, 80 %", "detected ≤ 2 s", "isolation correct", "unknown"])
    lines += [with_filters(r, filters) for filters, rows in t1 for r in rows]
    lines += ["", *md.table(["plant", "sensors", "filters", "severity", "Lorden bound (s)", *RULES])]
    lines += [with_filters(r, filters) for filters, rows in t2 for r in rows]
    return "\n".join(lines) + "\n"
