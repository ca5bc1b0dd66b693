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
    the detector's statistic on the innovations of the no-fault residual generator
    (:class:`.residual.ChangeDetectors`, the same for every estimator), never re-anchored here: its
    first crossing of ``h`` is the first alarm at ``h`` (the live rule re-anchors its own after each
    declaration, so after the first alarm its statistic differs from the logged one). The isolated
    wheel is the leading hypothesis if it leads by ``isolation_llr``, else ``'unknown'``. The GLR also
    logs its estimates of the drop (``glr_drop``, m per affected wheel) and of the onset (``glr_onset``, s).

``<rule>_wheel`` holds the isolation code of the step (:data:`.change.WHEEL_CODES`; for ``sigma`` the
code at the threshold ``k_sigma``), ``white_innovation_1``/``_2`` the first two components of the
residual generator's whitened innovation (speed; yaw rate when present) that the detectors use.
"""

from __future__ import annotations

import functools
import math
from collections import deque

import numpy as np

from .base import FilterOutput, Hypothesis, Measurement
from .change import WHEEL_CODES
from .decision_settings import DecisionSettings
from .observability import RadiusDirections
from .residual import ChangeDetectors
from .setup import FilterSetup

STAT_COLUMNS: tuple[str, ...] = (
    "sigma_stat", "sigma_wheel", "sigma_z_R", "sigma_z_L", "mode_stat", "mode_wheel",
    "cusum_stat", "cusum_wheel", "glr_stat", "glr_wheel", "glr_drop", "glr_onset",
    "white_innovation_1", "white_innovation_2",
)
"""Trace columns written by :class:`RuleStatistics` (NaN where a rule does not apply)."""


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

    def __init__(self, setup: FilterSetup, settings: DecisionSettings, rate: float, glr_window: int,
                 physical: bool = False) -> None:
        """``setup``: the filter whose outputs are fed; ``settings``: the ``[estimator.decision]`` section;
        ``rate``: the filter rate (Hz); ``glr_window``: the GLR window (steps); ``physical``: the change
        detectors whiten under the physical robot's null model (:class:`.residual.ChangeDetectors`)."""
        d = settings
        self.setup = setup
        self.dt = self.setup.dt
        self.R0 = self.setup.nominal_radius
        self.d = d
        n_dwell = int(round(d.dwell * rate)) + 1
        self._sigma_win = SlidingMin(n_dwell)
        self._mode_win = SlidingMin(n_dwell)
        self.detectors = ChangeDetectors(setup, d.cusum_shift, d.isolation_llr, glr_window, physical)

    def update(self, t: float, out: FilterOutput, u: np.ndarray, dirs: RadiusDirections,
               z: Measurement | None = None) -> dict[str, float]:
        """Statistics after the filter step of time ``t`` (s) predicted with wheel rates ``u`` (rad/s) and
        updated with the measurement ``z`` (the change detectors hold when it is not given)."""
        s: dict[str, float] = dict.fromkeys(STAT_COLUMNS, math.nan)
        zR, zL, zw = drop_scores(out, dirs, self.R0, self.d.min_drop)
        s["sigma_z_R"], s["sigma_z_L"] = zR, zL
        s["sigma_stat"] = self._sigma_win.push(max(zR, zL, zw))
        split_ok = dirs.split_std <= self.d.max_split_sigma
        code = WHEEL_CODES[sigma_isolation(zR, zL, split_ok, self.d.k_sigma)] if max(zR, zL, zw) > self.d.k_sigma else 0
        s["sigma_wheel"] = float(code)
        if out.mode_probs is not None:
            self._mode(out, s)
        self._change(t, u, z, s, np.asarray(out.x, float)[3:5])
        return s

    def _mode(self, out: FilterOutput, s: dict[str, float]) -> None:
        score = mode_score(out, self.R0, self.d.min_drop)
        if score is None:
            return
        best, p, ok = score
        s["mode_stat"] = self._mode_win.push(p if ok else 0.0)
        s["mode_wheel"] = float(WHEEL_CODES[best] if ok else 0)

    def _change(self, t: float, u: np.ndarray, z: Measurement | None, s: dict[str, float],
                radii: np.ndarray) -> None:
        """CUSUM and GLR of the residual generator (advanced when a measurement is given; the null model's
        demand read at the estimator's ``radii``, m)."""
        det = self.detectors
        if z is not None:
            det.step(t, u, z, radii)
        if det.white is not None:
            s["white_innovation_1"] = float(det.white[0])
            if det.white.size > 1 and self.setup.yaw_rate_sigma is not None:
                s["white_innovation_2"] = float(det.white[1])
        s["cusum_stat"] = det.cusum_stat
        s["cusum_wheel"] = float(WHEEL_CODES[det.wheel("cusum")])
        s["glr_stat"] = det.glr_stat
        s["glr_wheel"] = float(WHEEL_CODES[det.wheel("glr")])
        s["glr_drop"], s["glr_onset"] = det.glr_drop, det.glr_onset
