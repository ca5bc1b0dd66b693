"""Fault decision on top of an estimator: declare a fault (time), isolate the wheel, give its severity.

Rules (``estimator.decision.rule``):

``sigma``
    A wheel is *suspect* when its radius estimate lies **below** nominal ``R0`` by more than
    ``k_sigma`` of its standard deviation **and** by more than ``min_drop`` (m): a puncture makes a
    radius smaller. The wheel is only *isolated* when the filter's covariance says the split between
    the two radii is identified (σ along the unobservable split direction ≤ ``max_split_sigma``, see
    :mod:`~ftc_mj.estimation.observability`); otherwise — and also when no single wheel is suspect
    but the observed radius combination ``w·R`` departs from ``w·R0`` by ``k_sigma`` σ and
    ``min_drop`` in the direction a smaller radius moves it — the candidate is ``'unknown'``: a fault
    is evident, which wheel is not. A fault is declared when a candidate has held for ``dwell``
    seconds; the isolated wheel is the set of suspect wheels (``'both'`` if both) or ``'unknown'``.
``mode``
    For an IMM: the probability of a fault *class* — the sum of the mode probabilities of the
    members hypothesising that wheel (``right``; ``left`` = 50 % left + left ramp; ``both``) —
    above ``mode_threshold`` for ``dwell`` seconds, **and** the combined radius estimate of the
    implicated wheel(s) below nominal by more than ``min_drop``. With the 4-model bank every class
    has exactly one member, i.e. this is "a fault-mode probability above the threshold" (the radius
    condition then holds by construction: the member pins a 50 % radius). The radius condition
    matters for the ramp member, which can also explain a small constant offset of the left radius.
``auto``
    ``mode`` when the output carries IMM mode probabilities, else ``sigma``.

A declared fault is cleared when the condition has been false for ``dwell`` seconds, and its
isolated wheel changes only when the new candidate has held for ``dwell`` seconds. Every
declaration, change of isolated wheel and clear is appended to :attr:`FaultDecision.events` as
``(t, text)`` so the loop can count false alarms. Severity is the fractional radius loss
``clip(1 - R̂/R0, 0, 1)`` of each wheel from the (combined) estimate.

A radius estimate *above* nominal by ``k_sigma`` σ and ``min_drop`` (with any rule) is not a
puncture: it is reported as :attr:`DecisionState.anomaly` and never declared.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from ..config import RunConfig
from .base import FilterOutput
from .imm import BANK_4, BANK_5
from .observability import RadiusDirections, radius_directions

Wheel = Literal["right", "left", "both", "unknown"]
_CLASSES: tuple[Wheel, ...] = ("right", "left", "both")


@dataclass
class DecisionState:
    """The decision after one estimator step."""

    detected: bool
    """A fault is currently declared."""
    time: float | None
    """Time (s) of the first declaration of the run, ``None`` if none yet."""
    wheel: Wheel | None
    """Isolated wheel(s) of the current declaration (``None`` when nothing is declared; ``'unknown'``
    when a fault is evident but the radius split is not identified)."""
    severity_R: float
    """Fractional radius loss of the right wheel, 0..1."""
    severity_L: float
    """Fractional radius loss of the left wheel, 0..1."""
    suspected: bool = False
    """A fault is evident (candidate or declaration) but not isolated (``'unknown'``)."""
    split_std: float = float("nan")
    """σ (m) of the filter's radius split along the unobservable direction this step."""
    active_mode: int | None = None
    """Most probable IMM mode (index into the bank), ``None`` for single filters."""
    anomaly: bool = False
    """A radius estimate lies above nominal by ``k_sigma`` σ and ``min_drop``: not a puncture (a radius
    does not grow), so not declared; reported separately."""
    events: list[tuple[float, str]] = field(default_factory=list)
    """All declaration / change / clear events so far (shared list, oldest first)."""


class FaultDecision:
    """Stateful fault-decision layer: ``FaultDecision(cfg).update(t, out) -> DecisionState``."""

    def __init__(self, cfg: RunConfig) -> None:
        d = cfg.estimator.decision
        self.rule = d.rule
        self.k_sigma = d.k_sigma
        self.min_drop = d.min_drop
        self.dwell = d.dwell
        self.mode_threshold = d.mode_threshold
        self.max_split_sigma = d.max_split_sigma
        self.R0 = cfg.model_wheel_radius
        self.events: list[tuple[float, str]] = []
        self.declared: Wheel | None = None
        self.first_time: float | None = None
        self.n_declarations = 0
        self._cond_since: float | None = None
        self._clear_since: float | None = None
        self._change_cand: Wheel | None = None
        self._change_since = 0.0

    # ---------------------------------------------------------------- candidate wheel per rule
    def _departs(self, dep: float, std: float) -> bool:
        """``dep`` (m) exceeds both ``k_sigma`` σ and ``min_drop`` in magnitude."""
        return math.isfinite(dep) and abs(dep) > self.k_sigma * std and abs(dep) > self.min_drop

    def _radius_departures(self, out: FilterOutput) -> tuple[tuple[bool, bool], tuple[bool, bool]]:
        """Per wheel (right, left): significantly below nominal (puncture-like), and above it (anomaly)."""
        below, above = [], []
        for i in (3, 4):
            dep = float(out.x[i]) - self.R0
            sig = self._departs(dep, math.sqrt(max(float(out.P[i, i]), 0.0)))
            below.append(sig and dep < 0.0)
            above.append(sig and dep > 0.0)
        return (below[0], below[1]), (above[0], above[1])

    def _sigma_candidate(self, out: FilterOutput, dirs: RadiusDirections, below: tuple[bool, bool]) -> Wheel | None:
        sus_R, sus_L = below
        if (sus_R or sus_L) and dirs.split_std <= self.max_split_sigma:
            return "both" if sus_R and sus_L else "right" if sus_R else "left"
        if sus_R or sus_L:
            return "unknown"
        # the observed combination c = w·(R - R0) alone: a puncture-like departure is one that a smaller
        # radius of some wheel i produces, i.e. c·w_i < 0
        c = dirs.w[0] * (float(out.x[3]) - self.R0) + dirs.w[1] * (float(out.x[4]) - self.R0)
        if self._departs(c, dirs.sum_std) and (c * dirs.w[0] < 0.0 or c * dirs.w[1] < 0.0):
            return "unknown"
        return None

    def _mode_candidate(self, out: FilterOutput) -> Wheel | None:
        mu = np.asarray(out.mode_probs, float)
        members = _class_members(mu.size)
        if members is None:
            return None
        m = mu.tolist()
        probs = {c: float(sum(m[i] for i in idx)) for c, idx in members}
        best = max(_CLASSES, key=lambda c: probs[c])
        if probs[best] <= self.mode_threshold:
            return None
        drop_R = self.R0 - float(out.x[3]) > self.min_drop
        drop_L = self.R0 - float(out.x[4]) > self.min_drop
        ok = {"right": drop_R, "left": drop_L, "both": drop_R and drop_L}[best]
        return best if ok else None

    # ---------------------------------------------------------------- update
    def update(self, t: float, out: FilterOutput, omega: np.ndarray | None = None) -> DecisionState:
        """Feed the estimator output of time ``t`` (s) and the wheel rates ``omega`` (rad/s) it was
        predicted with (they set which radius combination is observable); returns the decision."""
        dirs = radius_directions(out.P, omega)
        below, above = self._radius_departures(out)
        use_mode = self.rule == "mode" or (self.rule == "auto" and out.mode_probs is not None)
        if use_mode and out.mode_probs is not None:
            cand = self._mode_candidate(out)
        else:
            cand = self._sigma_candidate(out, dirs, below)
        eps = 1e-9
        if cand is not None:
            self._clear_since = None
            if self._cond_since is None:
                self._cond_since = t
            if self.declared is None and t - self._cond_since >= self.dwell - eps:
                self.declared = cand
                self.n_declarations += 1
                if self.first_time is None:
                    self.first_time = t
                self.events.append((t, f"declare {cand}"))
            elif self.declared is not None and cand != self.declared:
                # a change of the isolated wheel needs the same dwell as a declaration (no flapping)
                if cand != self._change_cand:
                    self._change_cand, self._change_since = cand, t
                if t - self._change_since >= self.dwell - eps:
                    self.declared = cand
                    self._change_cand = None
                    self.events.append((t, f"change {cand}"))
            else:
                self._change_cand = None
        else:
            self._cond_since = None
            self._change_cand = None
            if self.declared is not None:
                if self._clear_since is None:
                    self._clear_since = t
                if t - self._clear_since >= self.dwell - eps:
                    self.declared = None
                    self._clear_since = None
                    self.events.append((t, "clear"))
        sev = [_loss(float(out.x[i]), self.R0) for i in (3, 4)]
        active = int(np.argmax(out.mode_probs)) if out.mode_probs is not None else None
        return DecisionState(
            detected=self.declared is not None, time=self.first_time, wheel=self.declared,
            severity_R=sev[0], severity_L=sev[1], suspected="unknown" in (cand, self.declared),
            split_std=dirs.split_std, active_mode=active, anomaly=above[0] or above[1], events=self.events,
        )


@functools.cache
def _class_members(n: int) -> tuple[tuple[Wheel, tuple[int, ...]], ...] | None:
    """For the 4- or 5-model bank: each fault class with the indices of the members hypothesising it
    (computed once: the decision runs at every filter step); ``None`` for other bank sizes."""
    bank = BANK_4 if n == 4 else BANK_5 if n == 5 else None
    if bank is None:
        return None
    return tuple((c, tuple(i for i, h in enumerate(bank) if h.wheel == c)) for c in _CLASSES)


def _loss(r: float, R0: float) -> float:
    """Fractional radius loss ``clip(1 - r/R0, 0, 1)``; 0 for a non-finite estimate."""
    return min(max(1.0 - r / R0, 0.0), 1.0) if math.isfinite(r) else 0.0
