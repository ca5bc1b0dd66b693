"""Operating characteristics of the fault-decision rules from a Monte-Carlo study (``ftc-mj fdi-curves``).

Every run of a study carries, per rule, the records of its decision statistic's running maximum
(:mod:`ftc_mj.metrics.fdi`), from which its first alarm at *any* threshold ``h`` follows. Sweeping
``h`` over a grid gives, for each cell of the study (every axis but the fault axis, e.g. plant ×
sensors × filter) and each rule:

* **false alarms** (no-fault runs): the first-alarm rate ``λ = a / E`` — ``a`` runs that alarmed, ``E``
  the seconds observed up to each run's first alarm (or its end): the maximum-likelihood rate of an
  exponential time to the first alarm — and the mean time between false alarms ``ARL0 = 1/λ`` with
  the exact Poisson (Garwood) 95 % interval on ``a``;
* **detection delay** (fault runs of each severity): ``T - ν`` from the onset ``ν`` over the runs whose
  first alarm is at or after it (Pollak's conditional delay; a run that alarmed before the onset is an
  early alarm and is counted as such), mean and percentile-bootstrap 95 % interval over seeds; runs
  that never alarm are missed;
* **detection within a horizon** ``H`` against false alarm in a window of the same length (ROC): among
  the runs without an alarm before ``ν`` (no-fault runs: before the cells' onset time), the fraction
  alarming in ``[ν, ν + H]``, Wilson 95 % intervals;
* **isolation**: among detected runs, the fraction whose wheel at the first alarm is the true one,
  and the fraction ``'unknown'``.

Lorden's bound: for a change in the distribution of independent observations no detector with mean
time ``ARL0`` between false alarms has a (worst-case) delay below ``log(ARL0)/KL`` samples
asymptotically, ``KL`` the Kullback–Leibler information per sample; with an information that varies
from sample to sample the delay is at least the number of samples whose cumulative information reaches
``log(ARL0)`` (Lai 1998). Each fault run records the cumulative information the puncture actually put
into the measurements (:func:`ftc_mj.metrics.fdi.cumulative_kl`: the true speed and yaw rate
against the nominal model, over the sensor noise); the bound drawn is ``dt · n``, ``n`` the first
row after the onset at which the mean over the cell's seeds reaches ``log(ARL0/dt)``, and ``inf``
(not drawn) if it does not within the recorded profile. It holds for the raw measurements, hence for
every rule (all are functions of them).

Design points: each rule's threshold as configured (``k_sigma``, ``mode_threshold``) or calibrated for
``decision.arl0`` (``cusum``, ``glr``). Matched points: the threshold whose ARL0 measured on the
*development* seeds (below 1000) first reaches the target with 95 % confidence, judged on the
*held-out* seeds (1000 and up) — a study needs both, and at least 369 s of alarm-free development
exposure per cell for a 100 s target (``3.69 × target``: the Garwood lower bound of zero alarms).

Delays are non-negative: their interval is the percentile bootstrap of the mean, which stays inside
the range of the delays (never below zero).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...config import RunConfig
from ...estimation.rule_statistics import sigma_isolation
from ...metrics.fdi import lorden_delays
from ...wiring.decision import calibrated_threshold
from ..spec import HELD_OUT_START
from ..stats import Estimate, bootstrap_mean_ci, rate_ci
from .cells import RULES, Cell, Run

WHEELS: dict[int, str | None] = {0: None, 1: "right", 2: "left", 3: "both", 4: "unknown"}
N_THRESHOLDS = 60


# ---------------------------------------------------------------------------- first alarms
def first_alarms(records: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First-alarm time (s; ``inf`` if none) and record row (-1 if none) at each threshold of ``h``."""
    if records.shape[0] == 0:
        return np.full(h.shape, np.inf), np.full(h.shape, -1)
    j = np.searchsorted(records[:, 1], h, side="left")
    hit = j < records.shape[0]
    jj = np.where(hit, j, 0)
    return np.where(hit, records[jj, 0], np.inf), np.where(hit, jj, -1)


def isolated_wheel(rule: str, row: np.ndarray, h: float) -> str | None:
    """The wheel a rule isolates at a first alarm (record ``row``) with threshold ``h``."""
    if rule == "sigma":
        return sigma_isolation(float(row[2]), float(row[3]), bool(row[4] > 0.5), h)
    return WHEELS[int(row[2])]


def thresholds(cell: Cell, rule: str, design: float) -> np.ndarray:
    """Threshold grid of a rule in a cell: quantiles of every recorded value, plus the design point."""
    vals = [r.records[rule][:, 1] for r in [*cell.nofault, *(x for v in cell.faults.values() for x in v)]
            if r.records[rule].shape[0]]
    if not vals:
        return np.zeros(0)
    allv = np.concatenate(vals)
    grid = np.quantile(allv, np.linspace(0.0, 1.0, N_THRESHOLDS))
    extra = [design] if math.isfinite(design) else []
    return np.unique(np.concatenate([grid, extra]))


# ---------------------------------------------------------------------------- statistics
def poisson_rate(alarms: int, exposure: float) -> Estimate:
    """First-alarm rate (1/s) with the exact (Garwood) 95 % interval."""
    from scipy.stats import chi2

    if exposure <= 0:
        return Estimate(math.nan, math.nan, math.nan, 0)
    lo = 0.0 if alarms == 0 else float(chi2.ppf(0.025, 2 * alarms)) / 2.0
    hi = float(chi2.ppf(0.975, 2 * (alarms + 1))) / 2.0
    return Estimate(alarms / exposure, lo / exposure, hi / exposure, alarms)


def _inv(x: float) -> float:
    return math.inf if x <= 0 else 1.0 / x


def arl0_of(rate: Estimate) -> Estimate:
    """Mean time between false alarms (s) = 1/rate, interval inverted (``inf`` for no alarm)."""
    return Estimate(_inv(rate.mean), _inv(rate.hi), _inv(rate.lo), rate.n)


@dataclass
class Point:
    """A rule's operating point at one threshold in one cell."""

    h: float
    exposure: float
    """Fault-free seconds observed (each no-fault run up to its first alarm)."""
    rate: Estimate
    """First-alarm rate (1/s); its ``n`` is the number of alarms."""
    arl0: Estimate
    pfa: Estimate
    """False alarm in ``[ν, ν + H]`` without an earlier alarm (no-fault runs)."""
    delay: dict[Any, Estimate]
    pd: dict[Any, Estimate]
    early: dict[Any, Estimate]
    iso: dict[Any, Estimate]
    unknown: dict[Any, Estimate]


def first_alarm_at(run: Run, rule: str, h: float) -> tuple[float, np.ndarray | None]:
    """First-alarm time (s, ``inf`` if none) of a run at threshold ``h`` and its record row."""
    t, j = first_alarms(run.records[rule], np.array([h]))
    return float(t[0]), (run.records[rule][j[0]] if j[0] >= 0 else None)


def _false_alarms(runs: list[Run], rule: str, h: float, onset: float,
                  horizon: float) -> tuple[float, Estimate, Estimate]:
    """Exposure (s), first-alarm rate and the windowed false-alarm probability of no-fault runs."""
    T = np.array([first_alarm_at(r, rule, h)[0] for r in runs])
    dur = np.array([r.duration for r in runs])
    exposure = float(np.sum(np.minimum(T, dur)))
    clear = T >= onset
    return exposure, poisson_rate(int(np.sum(T < dur)), exposure), rate_ci(list(T[clear] <= onset + horizon))


def _detections(runs: list[Run], rule: str, h: float, horizon: float) -> tuple[Estimate, ...]:
    """Delay, detection within the horizon, early alarm, correct isolation and 'unknown' of fault runs."""
    alarms = [first_alarm_at(r, rule, h) for r in runs]
    T = np.array([a[0] for a in alarms])
    on = np.array([float(r.onset) for r in runs])  # type: ignore[arg-type]
    after = T >= on
    det = np.flatnonzero(after & np.isfinite(T))
    wheels = [isolated_wheel(rule, alarms[i][1], h) for i in det]  # type: ignore[arg-type]
    return (bootstrap_mean_ci(list(T[det] - on[det])), rate_ci(list(T[after] <= on[after] + horizon)),
            rate_ci(list(~after)), rate_ci([w == runs[i].wheel for w, i in zip(wheels, det, strict=True)]),
            rate_ci([w == "unknown" for w in wheels]))


def operating_point(cell: Cell, rule: str, h: float, horizon: float, seeds: set[int] | None = None) -> Point:
    """Every statistic of the module docstring at threshold ``h`` (runs restricted to ``seeds`` if given)."""
    def keep(runs: list[Run]) -> list[Run]:
        return [r for r in runs if seeds is None or r.seed in seeds]

    onset0 = float(np.median([r.onset for v in cell.faults.values() for r in v])) if cell.faults else 0.0
    exposure, rate, pfa = _false_alarms(keep(cell.nofault), rule, h, onset0, horizon)
    stats = {sev: _detections(keep(runs), rule, h, horizon) for sev, runs in cell.faults.items()}
    return Point(h, exposure, rate, arl0_of(rate), pfa, *({sev: st[i] for sev, st in stats.items()} for i in range(5)))


def design_threshold(cfg: RunConfig, rule: str) -> float:
    """The rule's threshold as the run configuration sets it."""
    d = cfg.estimator.decision
    if rule == "sigma":
        return float(d.k_sigma)
    if rule == "mode":
        return float(d.mode_threshold)
    return calibrated_threshold(cfg, rule)


def matched_threshold(cell: Cell, rule: str, grid: np.ndarray, target: float, dev: set[int]) -> float:
    """Smallest grid threshold whose ARL0 on the development seeds reaches ``target`` (s) with 95 %
    confidence (lower bound of its interval); ``nan`` if none does (too little fault-free exposure)."""
    for h in grid:
        p = operating_point(cell, rule, float(h), 1.0, dev)
        if p.arl0.lo >= target:
            return float(h)
    return math.nan


def lorden_bound(cell: Cell, severity: Any, arl0: np.ndarray, dt: float) -> np.ndarray:
    """Lorden's lower bound on the delay (s) at each ``arl0`` (s) from the cell's recorded cumulative fault
    information (module docstring); ``inf`` beyond the profile, ``nan`` without one."""
    prof = [r.kl for r in cell.faults.get(severity, []) if r.kl is not None and r.kl.size]
    if not prof:
        return np.full(arl0.shape, np.nan)
    n = min(p.size for p in prof)
    return lorden_delays(np.mean([p[:n] for p in prof], axis=0), arl0, dt)


# ---------------------------------------------------------------------------- sweep
LORDEN_ARL0 = np.geomspace(0.1, 1e4, 60)
"""ARL0 values (s) at which Lorden's bound is drawn."""


@dataclass
class RuleCurves:
    """One rule's sweep in one cell, and its design and matched points."""

    cell: Cell
    rule: str
    points: list[Point]
    design: Point
    matched: Point | None
    """At the threshold matched on development seeds, judged on held-out seeds."""


def sweep(cells: list[Cell], horizon: float, target: float) -> list[RuleCurves]:
    """Every rule's curves in every cell that has its statistic."""
    out = []
    for cell in cells:
        assert cell.config is not None
        seeds = sorted({r.seed for r in cell.nofault})
        dev = {s for s in seeds if s < HELD_OUT_START}
        held = {s for s in seeds if s >= HELD_OUT_START}
        for rule in RULES:
            h_design = design_threshold(cell.config, rule)
            grid = thresholds(cell, rule, h_design)
            if grid.size == 0:
                continue
            pts = [operating_point(cell, rule, float(h), horizon) for h in grid]
            design = operating_point(cell, rule, h_design, horizon)
            h_m = matched_threshold(cell, rule, grid, target, dev) if dev and held else math.nan
            matched = operating_point(cell, rule, h_m, horizon, held) if math.isfinite(h_m) else None
            out.append(RuleCurves(cell, rule, pts, design, matched))
    return out


def lorden_curve(cell: Cell, severity: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(ARL0 s, bound s)`` of :func:`lorden_bound` on the drawing grid."""
    assert cell.config is not None
    return LORDEN_ARL0, lorden_bound(cell, severity, LORDEN_ARL0, 1.0 / cell.config.estimator.rate)
