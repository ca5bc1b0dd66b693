"""The check primitives of ``ftc-mj paper``: a check, the rules that settle it, and the helpers
the claim families compare numbers with.

A :class:`Check` is one yes/no test of a paper sentence on the summary rows of one seed (label →
flattened metrics). It names the runs it reads (:attr:`Check.runs`), and :func:`settle` turns its
raw result into one of four outcomes by rules stated here, before any number is looked at:

- ``fail`` — any run it reads has failed (status other than ``ok``): a failed run fails its checks;
- ``not run`` — a run it reads is not part of this invocation (``--only``);
- ``n/a`` — its precondition does not hold: a fault onset of a run it reads lies after the end of
  the run, the check itself declared a precondition false (``na``, e.g. "feedback off makes the two
  runs identical by construction"), or a value it needs is missing;
- ``pass`` / ``fail`` — otherwise, the test's own result.

``n/a`` and ``not run`` are never counted as passes. A claim family returns one :class:`Evidence`
per claim and seed; the verdicts (one seed or over seeds) are in :mod:`ftc_mj.paper.verdicts`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from .texts import CLAIM_TEXTS

REPRODUCED = "reproduced"
PARTLY = "partly"
NOT_REPRODUCED = "not reproduced"
NOT_EVALUATED = "not evaluated"

PASS, FAIL, NA, NOT_RUN = "pass", "fail", "n/a", "not run"
OUTCOMES = (PASS, FAIL, NA, NOT_RUN)

Rows = Mapping[str, Mapping[str, Any]]


@dataclass
class Check:
    """One yes/no test of a claim on the rows of one seed."""

    text: str
    """What is tested (independent of the numbers, so that seeds can be matched check by check)."""
    passed: bool | None
    """The test's result; ``None`` = not applicable or not run (see :attr:`na`)."""
    detail: str = ""
    """The numbers behind the result."""
    runs: tuple[str, ...] = ()
    """Labels of the runs the check reads."""
    na: str = ""
    """Why the check is not applicable (or :data:`NOT_RUN`), when ``passed`` is ``None``."""

    @property
    def outcome(self) -> str:
        """``pass``, ``fail``, ``n/a`` or ``not run``."""
        if self.passed is not None:
            return PASS if self.passed else FAIL
        return NOT_RUN if self.na == NOT_RUN else NA


@dataclass
class Evidence:
    """One claim evaluated on the rows of one seed: its checks, the evidence table and the
    interpretation. :func:`ftc_mj.paper.verdicts.combine` judges these over the seeds into a
    :class:`~ftc_mj.paper.verdicts.Claim`."""

    id: str
    title: str
    paper: str
    """What the paper says (quoted or closely paraphrased, with its section)."""
    checks: list[Check] = field(default_factory=list)
    table: list[dict[str, Any]] = field(default_factory=list)
    """Evidence rows (label + the numbers the checks use)."""
    notes: list[str] = field(default_factory=list)
    """Interpretation: why the verdict comes out as it does."""


def chk(text: str, passed: bool | None, detail: str, *runs: str, na: str = "") -> Check:
    """A :class:`Check` reading ``runs``; a non-empty ``na`` makes it not applicable."""
    return Check(text, passed, detail, tuple(runs), na)


ClaimFn = Callable[[Rows], Evidence]
"""A claim family's claim: the rows of one seed → its :class:`Evidence` (checks not yet settled)."""


def claim(id: str) -> Callable[[Callable[[Evidence, Rows], None]], ClaimFn]:
    """Decorate ``fill(evidence, rows)``, which appends claim ``id``'s checks, table rows and notes,
    into the :data:`ClaimFn` that starts the claim's :class:`Evidence` from its statement in
    :data:`~.texts.CLAIM_TEXTS` and returns it filled."""
    title, paper = CLAIM_TEXTS[id]

    def wrap(fill: Callable[[Evidence, Rows], None]) -> ClaimFn:
        @functools.wraps(fill)
        def run(rows: Rows) -> Evidence:
            c = Evidence(id, title, paper)
            fill(c, rows)
            return c

        return run

    return wrap


# ------------------------------------------------------------------------------------- settling
def _run_state(rows: Rows, label: str) -> str:
    r = rows.get(label)
    if r is None or r.get("status") == "missing":
        return NOT_RUN
    return "ok" if r.get("status") == "ok" else FAIL


def onset_after_end(row: Mapping[str, Any] | None) -> bool:
    """A fault onset of the run's schedule lies after the run's last step (``onsets_after_end`` of
    :func:`~ftc_mj.paper.derived.derived_metrics`; the ``after end`` onsets of ``metrics.json``)."""
    v = num(row, "onsets_after_end")
    return v is not None and v > 0


def settle(ch: Check, rows: Rows) -> Check:
    """Apply the outcome rules of the module docstring to ``ch`` (in place) and return it."""
    states = {lb: _run_state(rows, lb) for lb in ch.runs}
    failed = [lb for lb, s in states.items() if s == FAIL]
    if failed:
        errs = "; ".join(f"{lb}: {rows[lb].get('status')} ({rows[lb].get('error') or 'no reason'})" for lb in failed)
        ch.passed, ch.na, ch.detail = False, "", f"run failed — {errs}"
    elif any(s == NOT_RUN for s in states.values()):
        ch.passed, ch.na = None, NOT_RUN
    elif any(onset_after_end(rows.get(lb)) for lb in ch.runs):
        ch.passed, ch.na = None, "a fault onset lies after the end of the run"
    elif ch.na:
        ch.passed = None
    elif ch.passed is None:
        ch.na = "a value it needs is missing"
    return ch


def evaluate(fns: Iterable[ClaimFn], rows: Rows) -> list[Evidence]:
    """Evaluate the claim functions on ``rows`` (one seed: label → flattened metrics) and settle
    every check."""
    out = []
    for fn in fns:
        c = fn(rows)
        for ch in c.checks:
            settle(ch, rows)
        out.append(c)
    return out


# ------------------------------------------------------------------------------------- helpers
def num(row: Mapping[str, Any] | None, key: str) -> float | None:
    """A finite float from a row, else None (missing run, missing key, null, NaN, non-numeric)."""
    if row is None:
        return None
    v = row.get(key)
    if v is None or v == "":
        return None
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


def truthy(row: Mapping[str, Any] | None, key: str) -> bool | None:
    if row is None:
        return None
    v = row.get(key)
    if v is None or v == "" or (isinstance(v, float) and math.isnan(v)):
        return None
    if isinstance(v, str):
        return v.strip().lower() in ("true", "1", "yes")
    return bool(v)


def fmt(v: Any, unit: str = "", digits: int = 3) -> str:
    if v is None:
        return "—"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, (int, float)):
        if isinstance(v, float) and not math.isfinite(v):
            return "—"
        return f"{v:.{digits}g}{unit}"
    return str(v)


def cmp(a: float | None, op: Callable[[float, float], bool], b: float | None) -> bool | None:
    if a is None or b is None:
        return None
    return bool(op(a, b))


def lt(a: float | None, b: float | None) -> bool | None:
    return cmp(a, lambda x, y: x < y, b)


def le(a: float | None, b: float | None) -> bool | None:
    return cmp(a, lambda x, y: x <= y, b)


def gt(a: float | None, b: float | None) -> bool | None:
    return cmp(a, lambda x, y: x > y, b)


def ge(a: float | None, b: float | None) -> bool | None:
    return cmp(a, lambda x, y: x >= y, b)


def _kleene(vals: tuple[bool | None, ...], decisive: bool) -> bool | None:
    """Three-valued and/or: ``decisive`` if any value is it, else None (unknown) if any value is
    None, else ``not decisive``."""
    if any(v is decisive for v in vals):
        return decisive
    if any(v is None for v in vals):
        return None
    return not decisive


def all_of(*vals: bool | None) -> bool | None:
    """False if any is False, else None if any is None, else True."""
    return _kleene(vals, False)


def any_of(*vals: bool | None) -> bool | None:
    """True if any is True, else None if any is None, else False."""
    return _kleene(vals, True)


def absmax(*vals: float | None) -> float | None:
    v = [abs(x) for x in vals if x is not None]
    return max(v) if v else None
