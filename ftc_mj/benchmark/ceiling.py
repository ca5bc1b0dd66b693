"""The report's tables of the ``progress`` rule (benchmark ``ftc-v2``): success on trackable and on stop-only draws,
every method's success as a fraction of the oracle's, the trackable draws the oracle fails, the difficulty tiers,
and the per-class table in which a draw counts in every class of its faults.

*Fraction of the oracle*, on the trackable draws both rows ran: ``p_m / p_o`` (success rates of the method and of
the ``oracle`` row). Its interval joins two exact Clopper–Pearson intervals at 97.5 % each,
``[lo_m / hi_o, hi_m / lo_o]``: each covers its rate with probability ≥ 97.5 % whatever the true rate (exact
binomial tails, never the normal approximation), so both hold together with probability ≥ 95 % by Bonferroni's
inequality — whatever the dependence between the paired rows. It is therefore not anti-conservative (its coverage
is at least 95 %); it is wide, the price of assuming nothing about the pairing.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ..markdown import table
from .attainability import STOP_ONLY, TRACKABLE
from .stats import ALPHA, aggregate, clopper_pearson

ORACLE = "oracle"
"""The reference row the fractions are taken of."""


def classes_of_draws(draws: Sequence[Any]) -> dict[int, tuple[str, ...]]:
    """Every fault class of each draw (by index): all its faults, ``("none",)`` without one."""
    return {d.index: tuple(f.fault_class for f in d.faults) or ("none",) for d in draws}


def every_class_table(rows: list[dict[str, Any]], methods: list[str], order: Sequence[str],
                      classes: dict[int, tuple[str, ...]]) -> list[str]:
    """Success rate per fault class (rows, ``none`` first, then in ``order``) and method, a draw counted in each
    class of its faults (``classes``; a draw with two faults is in two rows; a draw not in ``classes``: its row's
    ``fault_class``), Wilson 95 % intervals."""
    of = {r["draw"]: classes.get(r["draw"], (r.get("fault_class", "none"),)) for r in rows}
    present = {c for cs in of.values() for c in cs}
    body = [[c, *(_rate([r for r in rows if r["method"] == m and c in of[r["draw"]]]) for m in methods)]
            for c in ("none", *(c for c in order if c != "none")) if c in present]
    return table(["fault class (every fault of a draw)", *methods], body)


def _rate(rows: list[dict[str, Any]]) -> str:
    e = aggregate(rows)["success"]
    return e.fmt(pct=True) + f" (n={e.n})" if e.n else "—"


def tiers(draws: Sequence[Any], rows: list[dict[str, Any]]) -> dict[str, set[int]]:
    """The difficulty tiers: draw indices with and without a gyro, with one and two faults, trackable and
    stop-only (the label of the rows)."""
    label = {r["draw"]: r.get("label") for r in rows}
    return {"with a gyro": {d.index for d in draws if d.gyro_sigma is not None},
            "without a gyro": {d.index for d in draws if d.gyro_sigma is None},
            "no fault": {d.index for d in draws if not d.faults},
            "one fault": {d.index for d in draws if len(d.faults) == 1},
            "two faults": {d.index for d in draws if len(d.faults) == 2},
            TRACKABLE: {k for k, v in label.items() if v == TRACKABLE},
            STOP_ONLY: {k for k, v in label.items() if v == STOP_ONLY}}


def tier_table(draws: Sequence[Any], rows: list[dict[str, Any]], methods: list[str]) -> list[str]:
    """Success per difficulty tier (rows) and method (columns), Wilson 95 % intervals."""
    body = [[f"{name} ({len(idx)} draws)", *(_rate([r for r in rows if r["method"] == m and r["draw"] in idx])
                                           for m in methods)]
            for name, idx in tiers(draws, rows).items() if idx]
    return table(["tier", *methods], body)


def oracle_fraction(rows: list[dict[str, Any]], method: str) -> tuple[float, float, float, int]:
    """``(p_m / p_o, lo, hi, n)`` on the trackable draws both ``method`` and the oracle ran (module docstring);
    NaNs when the oracle succeeded nowhere there."""
    ok = {(r["method"], r["draw"]): bool(r.get("success")) for r in rows if r.get("label") == TRACKABLE}
    common = sorted(k for (m, k) in ok if m == ORACLE and (method, k) in ok)
    n = len(common)
    km, ko = sum(ok[(method, k)] for k in common), sum(ok[(ORACLE, k)] for k in common)
    nan = float("nan")
    if n == 0 or ko == 0:
        return nan, nan, nan, n
    level = 1.0 - ALPHA / 2.0
    lo_m, hi_m = clopper_pearson(km, n, level)
    lo_o, hi_o = clopper_pearson(ko, n, level)
    return km / ko, lo_m / hi_o, (hi_m / lo_o if lo_o > 0 else float("inf")), n


def label_table(rows: list[dict[str, Any]], methods: list[str]) -> list[str]:
    """Per method: success on trackable draws, on stop-only draws (Wilson 95 %), and as a fraction of the oracle's on
    the trackable draws (module docstring's interval) when the oracle ran."""
    with_oracle = ORACLE in methods
    body = []
    for m in methods:
        mine = [r for r in rows if r["method"] == m]
        cells = [m, _rate([r for r in mine if r.get("label") == TRACKABLE]),
                 _rate([r for r in mine if r.get("label") == STOP_ONLY])]
        if with_oracle:
            f, lo, hi, n = oracle_fraction(rows, m)
            cells.append("—" if f != f else f"{100 * f:.0f} % [{100 * lo:.0f}, {100 * hi:.0f}] (n={n})")
        body.append(cells)
    head = ["method", "success, trackable draws", "success, stop-only draws"]
    return table([*head, "fraction of the oracle's success (trackable) [95 %]"] if with_oracle else head, body)


def oracle_failures(rows: list[dict[str, Any]]) -> list[int]:
    """The trackable draws the oracle row fails: either the physics rule or the oracle is wrong there."""
    return sorted(r["draw"] for r in rows if r["method"] == ORACLE and r.get("label") == TRACKABLE
                  and not r.get("success"))


def rule_lines(rule: Any, rows: list[dict[str, Any]]) -> list[str]:
    """The rule's text: what success means on each label, the denominators and what was not applicable."""
    draws = {r["draw"]: r.get("label") for r in rows}
    n_t = sum(v == TRACKABLE for v in draws.values())
    n_s = sum(v == STOP_ONLY for v in draws.values())
    return [f"Rule `{rule.rule}` (the version's `[judge]`). Every draw is labelled from its truth by physics "
            "(`ftc_mj.benchmark.attainability`: the damaged robot's servo torque, traction and lift-off read from the "
            "drawn MJCF against the path's turning couple at a reduced speed; a lock against the locked tyre's "
            f"sliding friction): {n_t} trackable, {n_s} stop-only. **Trackable**: from 5 s after the last onset "
            "to the end, completed, never tipped, within 0.5 m of the path, and progress along the path (arc length "
            "of the truth's projection, unwrapped) at least "
            f"{100 * rule.progress_fraction:g} % of what the attainable speed covers (the desired speed capped by "
            "what the damaged robot can make). **Stop-only**: within 0.5 m and progressing before the disabling "
            f"onset, then at rest (< {rule.stop_speed:g} m/s) from {rule.stop_within:g} s after it, inside "
            f"{rule.corridor:g} m of the path, never tipped. Denominators: all draws of each label each method ran; "
            "not applicable: the fraction of the oracle on stop-only draws (the oracle is a tracking ceiling), and "
            "any fraction where the oracle succeeded on no trackable draw.", ""]


def ceiling_lines(bp: Any, rows: list[dict[str, Any]], methods: list[str]) -> list[str]:
    """The report's section of the ``progress`` rule (module docstring), empty under another rule."""
    rule = getattr(bp, "rule", None)
    if rule is None or rule.rule != "progress":
        return []
    out = ["## Trackable and stop-only draws", "", *rule_lines(rule, rows), *label_table(rows, methods), ""]
    if ORACLE in methods:
        bad = oracle_failures(rows)
        out += [f"Trackable draws the oracle fails ({len(bad)}; either the physics rule or the oracle is wrong "
                "there): " + (", ".join(str(k) for k in bad) if bad else "none") + ".", ""]
    return [*out, "## Difficulty tiers", "", *tier_table(bp.draws, rows, methods), ""]
