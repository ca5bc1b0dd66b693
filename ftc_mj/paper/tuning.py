"""Parameters tuned on data, chosen on the development seeds by selection rules stated in advance.

Two parameters of the loop were set by looking at runs: the fault decision's dwell
(``estimator.decision.dwell``) and the safe policy's growth limit
(``reconfiguration.max_growth_rate``). Each has a study over the development seeds
(the built-in studies ``tune_dwell`` and ``tune_growth``, whose headers state the rule) and a
selection function here that applies the rule to the study's results. ``ftc-mj paper --tune`` runs
both and reports the chosen value next to the configured default; the claims are judged on the
held-out seeds (:mod:`.seeds`) with the defaults. A default that differs from the choice is
reported as such (the default should then change, and the claims be re-judged).

Each parameter is tuned with the other at its default.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import polars as pl

from ..config import RunConfig
from ..resources import resource_path
from ..study.stats import mean_ci, rate_ci
from .claims.thresholds import POLICY_TOL

STUDY_DIR = resource_path("studies")
"""Where the built-in studies are (package data)."""


@dataclass
class Selection:
    """The outcome of a selection rule: the chosen value and the per-candidate evidence."""

    value: float | None
    table: list[dict[str, Any]]
    why: str


@dataclass(frozen=True)
class Tuned:
    """A data-tuned parameter: its config key, its study, the candidate axis and the rule."""

    key: str
    study: str
    axis: str
    rule: str
    select: Callable[[pl.DataFrame], Selection]

    def default(self) -> float:
        node: Any = RunConfig()
        for part in self.key.split("."):
            node = getattr(node, part)
        return float(node)


def _ok(df: pl.DataFrame) -> pl.Expr:
    return pl.col("status") == "ok"


def _bool_list(df: pl.DataFrame, col: str) -> list[bool | None]:
    return [None if v is None else bool(v) for v in df[col].to_list()] if col in df.columns else [None] * df.height


def _counts(df: pl.DataFrame, col: str) -> list[int]:
    """A count column as ints (0 where missing: runs without a fault onset, or metrics without it)."""
    if col not in df.columns:
        return [0] * df.height
    return [int(v) if v is not None else 0 for v in df[col].to_list()]


def _floats(df: pl.DataFrame, col: str) -> list[float]:
    if col not in df.columns:
        return []
    return [float(v) for v in df[col].to_list() if v is not None and math.isfinite(float(v))]


# ------------------------------------------------------------------------------------- dwell
DWELL_RULE = ("the smallest dwell with no false alarm and no false isolation in any development run (a false "
              "alarm: a declaration before the first onset, any declaration in scenario 1; a false isolation: a "
              "declaration after an onset naming a wheel that is not punctured; a failed run counts as one); if "
              "every dwell has some, the one with the fewest such runs, the smaller on ties")


def select_dwell(df: pl.DataFrame) -> Selection:
    """:data:`DWELL_RULE` on the results of ``tune_dwell.toml``."""
    table, scored = [], []
    for d in sorted({float(v) for v in df["dwell"].to_list()}):
        part = df.filter(pl.col("dwell") == d)
        fa = [bool(f) or s != "ok" for f, s in zip(_bool_list(part, "false_alarm"), part["status"].to_list(),
                                                        strict=True)]
        fi = [bool(v) for v in _counts(part, "false_isolations")]
        bad = [a or b for a, b in zip(fa, fi, strict=True)]
        faulty = part.filter(_ok(part) & (pl.col("fault") != "s1"))
        missed = rate_ci([v for v in _bool_list(faulty, "missed_detection") if v is not None])
        safe_cte = mean_ci(_floats(faulty.filter(pl.col("setup") == "ukf-safe-yaw"), "cross_track_max_recovered"))
        table.append({"dwell [s]": d, "runs": part.height, "false alarms": f"{sum(fa)}/{len(fa)}",
                      "runs with false isolations": f"{sum(fi)}/{len(fi)}",
                      "false alarm or isolation [95 % CI]": rate_ci(bad).fmt(pct=True),
                      "detection delay [s]": mean_ci(_floats(faulty, "detection_delay")).fmt(),
                      "missed detections": missed.fmt(pct=True),
                      "safe: max |cte| from onset + 5 s [m]": safe_cte.fmt()})
        scored.append((sum(bad), d))
    if not scored:
        return Selection(None, table, "no runs")
    n_bad, best = min(scored)
    why = ("no false alarm or isolation" if n_bad == 0 else
           f"no dwell without false alarms or isolations; {n_bad} runs with this one")
    return Selection(best, table, why)


# ------------------------------------------------------------------------------------- growth limit
GROWTH_RULE = (f"a limit is admissible when in every development run safe is not worse than none of the same "
               f"scenario and seed by claim R2's criterion (max |cte| from 5 s after the fault, wheel-at-limit time, "
               f"lift-off time outside the puncture transients each ≤ none + {POLICY_TOL:g}; no tip-over where none "
               f"does not; a failed run violates); among the admissible, the smallest mean max |cte| from 5 s after "
               f"the fault, the larger limit on ties; if none is admissible, the fewest violating runs first")
R2_KEYS = ("cross_track_max_recovered", "omega_at_limit_s", "liftoff_time_post_transient_s")


def _violates(safe: dict[str, Any], none: dict[str, Any] | None) -> bool:
    """Claim R2's no-harm criterion for one pair of runs (True = safe is worse)."""
    if none is None or safe.get("status") != "ok" or none.get("status") != "ok":
        return True
    for k in R2_KEYS:
        a, b = none.get(k), safe.get(k)
        if a is None or b is None or b > a + POLICY_TOL:
            return True
    return bool(safe.get("tipped")) and not bool(none.get("tipped"))


def select_growth(df: pl.DataFrame) -> Selection:
    """:data:`GROWTH_RULE` on the results of ``tune_growth.toml``."""
    rows = df.to_dicts()
    none = {(r["fault"], r["seed"]): r for r in rows if r["setting"] == "none"}
    table, scored = [], []
    for g in sorted({str(r["setting"]) for r in rows} - {"none"}, key=float):
        runs = [r for r in rows if r["setting"] == g]
        bad = [r for r in runs if _violates(r, none.get((r["fault"], r["seed"])))]
        cte = mean_ci([r.get("cross_track_max_recovered") for r in runs if r.get("status") == "ok"])
        lift = mean_ci([r.get("liftoff_time_post_transient_s") for r in runs if r.get("status") == "ok"])
        table.append({"growth limit [m/s]": float(g), "runs": len(runs),
                      "runs worse than none (R2)": f"{len(bad)}/{len(runs)}",
                      "max |cte| from onset + 5 s [m]": cte.fmt(), "lift-off outside transients [s]": lift.fmt()})
        mean = cte.mean if math.isfinite(cte.mean) else math.inf
        scored.append((len(bad), mean, -float(g)))
    if not scored:
        return Selection(None, table, "no runs")
    n_bad, mean, neg_g = min(scored)
    why = "admissible (never worse than none)" if n_bad == 0 else f"none admissible; {n_bad} violating runs"
    return Selection(-neg_g, table, why)


TUNED: tuple[Tuned, ...] = (
    Tuned("estimator.decision.dwell", "tune_dwell", "dwell", DWELL_RULE, select_dwell),
    Tuned("reconfiguration.max_growth_rate", "tune_growth", "setting", GROWTH_RULE, select_growth),
)


# ------------------------------------------------------------------------------------- running
@dataclass
class TuningOutcome:
    tuned: Tuned
    selection: Selection
    seeds: list[int]
    runs: int
    failed: int
    folder: Path
    wall_time_s: float


def run_tuning(out: Path, *, n_seeds: int | None, duration: float | None, workers: int, progress: bool = False,
               report_only: bool = False, which: Sequence[Tuned] = TUNED) -> list[TuningOutcome]:
    """Run (or, with ``report_only``, read) each tuning study into ``out/tuning/<study>/<hash>`` and
    apply its selection rule. ``n_seeds`` keeps the first n development seeds (the study files list
    seeds 0 … 9, so the count form ``seeds = n`` of the study machinery gives exactly those)."""
    from ..study.plan import plan_study
    from ..study.runner import run_study
    from ..study.store import StudyStore

    extra = {"duration": float(duration)} if duration is not None else None
    plans = [(t, plan_study(STUDY_DIR / f"{t.study}.toml", extra_overrides=extra, seeds=n_seeds)) for t in which]
    outcomes = []
    for t, plan in plans:
        folder = Path(out) / "tuning" / t.study / plan.study_hash
        wall = 0.0
        if report_only:
            StudyStore(folder).check(plan)
            df = StudyStore(folder).collect(plan)
        else:
            rep = run_study(plan, folder, workers=workers, serial=workers == 1, analyse=False, progress=progress)
            df, wall = rep.results if rep.results is not None else pl.DataFrame(), rep.wall_time_s
        sel = t.select(df) if df.height else Selection(None, [], "no runs")
        failed = int(df.filter(pl.col("status") != "ok").height) if df.height else 0
        outcomes.append(TuningOutcome(t, sel, sorted({r.seed for r in plan.runs}), df.height, failed, folder, wall))
    return outcomes
