"""Every fault-decision rule's statistic, each filter step, so thresholds can be swept after a run.

For each rule the statistic ``g_k`` is defined so that the rule's **first** declaration at a
threshold ``h`` is the first step with ``g_k ≥ h``; one run therefore gives the first alarm for every
threshold (the trace columns ``<rule>_stat``):

``sigma`` (threshold ``k_sigma``)
    ``z_k = max(z_R, z_L, z_w)``, with ``z_i = d_i / σ_i`` for a radius *drop* ``d_i = R0 - R̂_i``
    larger than ``min_drop`` (0 otherwise; a radius above nominal is not a puncture), ``i`` = each wheel
    and the observed combination ``w · R`` (:mod:`.observability`); ``g_k`` = the minimum of ``z`` over
    the last ``dwell`` seconds (the condition must hold that long). At a first alarm with threshold
    ``h`` the isolated wheels are those with ``z_i ≥ h`` if the split is identified (σ along it at most
    ``max_split_sigma``), else ``'unknown'``; ``sigma_z_R``/``sigma_z_L`` are logged for that.
``mode`` (threshold ``mode_threshold``; IMMs only)
    ``z_k`` = the probability of the most probable fault class if its wheel(s) dropped by more than
    ``min_drop``, else 0; ``g_k`` its minimum over ``dwell``; the isolated wheel is that class.
``cusum``, ``glr`` (thresholds in log-likelihood-ratio units, :mod:`.change`)
    the detector's statistic; the isolated wheel is the leading hypothesis if it leads by
    ``isolation_llr``, else ``'unknown'``. The GLR also logs its estimates of the drop (``glr_drop``,
    m per affected wheel) and of the onset (``glr_onset``, s).

``<rule>_wheel`` holds the isolation code of the step (:data:`.change.WHEEL_CODES`; for ``sigma`` the
code at the threshold ``k_sigma``), ``white_innovation_1``/``_2`` the first two components of the
whitened innovation (speed; yaw rate when present) that the detectors use.
"""

from __future__ import annotations

import functools
import math
from collections import deque
from typing import Protocol

import numpy as np

from ..model.kinematics import numpy_step_jacobian
from .base import FilterOutput, Hypothesis
from .change import (
    HYPOTHESES,
    WHEEL_CODES,
    InnovationCUSUM,
    JumpGLR,
    isolate,
    linearise_step,
)
from .observability import RadiusDirections
from .setup import FilterSetup

STAT_COLUMNS: tuple[str, ...] = (
    "sigma_stat", "sigma_wheel", "sigma_z_R", "sigma_z_L", "mode_stat", "mode_wheel",
    "cusum_stat", "cusum_wheel", "glr_stat", "glr_wheel", "glr_drop", "glr_onset",
    "white_innovation_1", "white_innovation_2",
)
"""Trace columns written by :class:`RuleStatistics` (NaN where a rule does not apply)."""
_EYE5 = np.eye(5)


class DecisionSettings(Protocol):
    """What the decision layer reads of the ``[estimator.decision]`` section (SI units)."""

    rule: str
    dwell: float
    k_sigma: float
    min_drop: float
    max_split_sigma: float
    mode_threshold: float
    cusum_shift: float
    isolation_llr: float
    statistics: bool
CLASSES: tuple[str, ...] = ("right", "left", "both")
"""IMM fault classes (a class = the members hypothesising that wheel or wheels)."""


class SlidingMin:
    """Minimum of the last ``n`` values pushed (``-inf`` until ``n`` values have been seen)."""

    def __init__(self, n: int) -> None:
        self.n = max(1, n)
        self.buf: deque[float] = deque(maxlen=self.n)

    def push(self, v: float) -> float:
        self.buf.append(v)
        return min(self.buf) if len(self.buf) == self.n else -math.inf


def drop_scores(out: FilterOutput, dirs: RadiusDirections, R0: float, min_drop: float) -> tuple[float, float, float]:
    """``(z_R, z_L, z_w)``: each wheel's and the observed combination's radius drop in σ, 0 when the
    drop is not above ``min_drop`` (m)."""
    dR, dL = R0 - float(out.x[3]), R0 - float(out.x[4])
    pairs = ((dR, float(out.P[3, 3])), (dL, float(out.P[4, 4])), (dirs.w[0] * dR + dirs.w[1] * dL, dirs.sum_std ** 2))
    z = []
    for dep, var in pairs:
        sd = math.sqrt(max(var, 0.0))
        z.append(dep / sd if math.isfinite(dep) and dep > min_drop and sd > 0 else 0.0)
    return z[0], z[1], z[2]


def sigma_isolation(z_R: float, z_L: float, split_ok: bool, h: float) -> str:
    """The sigma rule's isolated wheel at a declaration with threshold ``h`` (see the module docstring)."""
    sus_R, sus_L = z_R >= h, z_L >= h
    if not split_ok or not (sus_R or sus_L):
        return "unknown"
    return "both" if sus_R and sus_L else "right" if sus_R else "left"


@functools.cache
def class_members(hypotheses: tuple[Hypothesis, ...]) -> tuple[tuple[str, tuple[int, ...]], ...]:
    """Each fault class (``right``, ``left``, ``both``) with the indices of the members whose hypothesis
    makes that wheel faulty (computed once per bank: the decision runs at every filter step)."""
    return tuple((c, tuple(i for i, h in enumerate(hypotheses) if h.wheel == c)) for c in CLASSES)


def mode_score(out: FilterOutput, R0: float, min_drop: float) -> tuple[str, float, bool] | None:
    """``(class, probability, dropped)``: the most probable IMM fault class (probabilities summed over
    the members whose declared hypothesis makes that wheel faulty), its probability, and whether the
    combined radius estimate of its wheel(s) is below nominal by more than ``min_drop`` (m); ``None``
    for an output without mode probabilities and hypotheses."""
    if out.mode_probs is None or out.hypotheses is None:
        return None
    m = np.asarray(out.mode_probs, float).tolist()
    probs = {c: float(sum(m[i] for i in idx)) for c, idx in class_members(tuple(out.hypotheses))}
    best = max(CLASSES, key=lambda c: probs[c])
    drop_R = R0 - float(out.x[3]) > min_drop
    drop_L = R0 - float(out.x[4]) > min_drop
    ok = {"right": drop_R, "left": drop_L, "both": drop_R and drop_L}[best]
    return best, probs[best], ok


class RuleStatistics:
    """Stateful per-step statistics of all rules for one run (see the module docstring)."""

    def __init__(self, setup: FilterSetup, settings: DecisionSettings, rate: float, glr_window: int) -> None:
        """``setup``: the filter whose outputs are fed; ``settings``: the ``[estimator.decision]`` section;
        ``rate``: the filter rate (Hz); ``glr_window``: the GLR window (steps)."""
        d = settings
        self.setup = setup
        self.dt = self.setup.dt
        self.R0 = self.setup.nominal_radius
        self.d = d
        n_dwell = int(round(d.dwell * rate)) + 1
        self._sigma_win = SlidingMin(n_dwell)
        self._mode_win = SlidingMin(n_dwell)
        self.cusum = InnovationCUSUM(d.cusum_shift)
        self.glr = JumpGLR(glr_window)
        self._x_prev: np.ndarray | None = None
        self._cusum_g = self._glr_g = 0.0
        self._cusum_h = np.zeros(len(HYPOTHESES))
        self._glr_h = np.zeros(len(HYPOTHESES))
        self._glr_best: tuple[float, float] = (math.nan, math.nan)

    def update(self, t: float, out: FilterOutput, u: np.ndarray, dirs: RadiusDirections) -> dict[str, float]:
        """Statistics after the filter step of time ``t`` (s) predicted with wheel rates ``u`` (rad/s)."""
        s: dict[str, float] = dict.fromkeys(STAT_COLUMNS, math.nan)
        zR, zL, zw = drop_scores(out, dirs, self.R0, self.d.min_drop)
        s["sigma_z_R"], s["sigma_z_L"] = zR, zL
        s["sigma_stat"] = self._sigma_win.push(max(zR, zL, zw))
        split_ok = dirs.split_std <= self.d.max_split_sigma
        code = WHEEL_CODES[sigma_isolation(zR, zL, split_ok, self.d.k_sigma)] if max(zR, zL, zw) > self.d.k_sigma else 0
        s["sigma_wheel"] = float(code)
        if out.mode_probs is not None:
            self._mode(out, s)
        self._change(t, out, u, s)
        return s

    def _mode(self, out: FilterOutput, s: dict[str, float]) -> None:
        score = mode_score(out, self.R0, self.d.min_drop)
        if score is None:
            return
        best, p, ok = score
        s["mode_stat"] = self._mode_win.push(p if ok else 0.0)
        s["mode_wheel"] = float(WHEEL_CODES[best] if ok else 0)

    def _change(self, t: float, out: FilterOutput, u: np.ndarray, s: dict[str, float]) -> None:
        """CUSUM and GLR: advanced on steps with a usable innovation, held otherwise."""
        x = np.asarray(out.x, float)
        lin = None if out.rejected or out.reset else linearise_step(
            self.setup, x, np.asarray(out.P, float), np.asarray(out.innovation, float), np.asarray(out.S, float), u)
        if lin is not None:
            e = lin.e[None, :]
            s["white_innovation_1"] = float(lin.e[0])
            if lin.e.size > 1 and self.setup.yaw_rate_sigma is not None:
                s["white_innovation_2"] = float(lin.e[1])
            self._cusum_h = self.cusum.step(e, lin.W)[0].copy()
            self._cusum_g = float(self._cusum_h.max())
            if self.setup.position_sigma is None:
                F = _EYE5  # no channel sees the pose: its rows of F do not reach any signature
            else:
                x_lin = self._x_prev if self._x_prev is not None else x
                F = numpy_step_jacobian(self.setup.model, x_lin, np.asarray(u, float), self.dt)
            self._glr_g = float(self.glr.step(e, lin.W, F, lin.A)[0])
            self._glr_h = self.glr.per_hypothesis[0].copy()
            if self._glr_g > 0.0:
                hyp, nu, lag = self.glr.estimate()
                per_wheel = nu * (math.sqrt(0.5) if hyp == "both" else 1.0)
                self._glr_best = (per_wheel, t - lag * self.dt)
            else:
                self._glr_best = (math.nan, math.nan)
        self._x_prev = x
        margin = self.d.isolation_llr
        s["cusum_stat"] = self._cusum_g
        s["cusum_wheel"] = float(WHEEL_CODES[isolate(self._cusum_h, margin)])
        s["glr_stat"] = self._glr_g
        s["glr_wheel"] = float(WHEEL_CODES[isolate(self._glr_h, margin)])
        s["glr_drop"], s["glr_onset"] = self._glr_best
