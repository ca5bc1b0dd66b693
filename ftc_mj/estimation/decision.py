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
    For an estimator that declares its hypotheses (an IMM bank, ``FilterOutput.hypotheses``): the
    probability of a fault *class* — the sum of the mode probabilities of the members whose
    hypothesis makes that wheel faulty (``right``; ``left``, e.g. 50 % left + left ramp; ``both``),
    read from the hypotheses, whatever their number, order or severities — above
    ``mode_threshold`` for ``dwell`` seconds, **and** the combined radius estimate of the
    implicated wheel(s) below nominal by more than ``min_drop``. With the paper's 4-model bank every
    class has exactly one member, i.e. this is "a fault-mode probability above the threshold" (the
    radius condition then holds by construction: the member pins a 50 % radius). The radius
    condition matters for the ramp member, which can also explain a small constant offset of the
    left radius. An estimator with mode probabilities but no hypotheses cannot be read by this rule
    (the run fails saying so).
``auto``
    ``mode`` when the output declares hypotheses, else ``sigma``.
``cusum`` / ``glr``
    A CUSUM / Willsky–Jones GLR for a radius drop (:mod:`.change`) on the whitened innovations of the
    residual generator matched to the no-fault hypothesis (:mod:`.residual`: an EKF with constant
    radii, the same for every estimator, whose innovations are i.i.d. ``N(0, I)`` when nothing
    changes on the kinematic plant) reaches its threshold, set from the target mean time between false
    alarms ``arl0`` for that null model: an alarm. Half a GLR window later the GLR's estimated jump
    (wheel, size) re-anchors the generator and restarts the detectors, so a later puncture is detected
    too; a wheel is declared when its alarms' estimated drops within one GLR window reach ``min_drop``
    (no dwell: the threshold and the size are the evidence), ``'unknown'`` when no hypothesis leads by
    ``isolation_llr``. The declared wheel is the union of the wheels declared so far (left, then right:
    ``both``); hold-offs after the launch and after a declaration are in :class:`ChangeRule`. A
    declaration is never withdrawn: a tyre does not re-inflate.

Rules are registered by name (:data:`ftc_mj.registry.decision_rules`): a rule's factory takes the
run config and returns an object with a ``dwell`` (s) and ``candidate(step)`` giving the wheel it
would declare from this :class:`DecisionStep` (``None``: no fault evident); :class:`FaultDecision`
adds the dwell, change and clear logic, the severity and the anomaly flag around it. A rule may set
``declare_dwell`` (s) for its first declaration apart from ``dwell`` (the change detectors: 0) and
``needs_statistics`` to be handed every rule's statistic in :attr:`DecisionStep.statistics`.

Every rule's statistic is computed each step when ``decision.statistics`` is on (:mod:`.rule_statistics`)
and returned in :attr:`DecisionState.statistics` for the trace.

A declared fault is cleared when the condition has been false for ``dwell`` seconds, and its
isolated wheel changes only when the new candidate has held for ``dwell`` seconds. Every
declaration, change of isolated wheel and clear is appended to :attr:`FaultDecision.events` as
``(t, text)`` so the loop can count false alarms. Severity is the fractional radius loss
``clip(1 - R̂/R0, 0, 1)`` of each wheel from the (combined) estimate.

A radius estimate *above* nominal by ``k_sigma`` σ and ``min_drop`` (with any rule) is not a
puncture: it is reported as :attr:`DecisionState.anomaly` and never declared.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal, Protocol

import numpy as np

from .base import FilterOutput, Measurement
from .observability import RadiusDirections, radius_directions
from .residual import ChangeDetectors
from .rule_statistics import DecisionSettings, RuleStatistics, mode_score

Wheel = Literal["right", "left", "both", "unknown"]
CHANGE_RULES = ("cusum", "glr")


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
    statistics: dict[str, float] = field(default_factory=dict)
    """Every rule's decision statistic this step (:data:`~ftc_mj.estimation.rule_statistics.STAT_COLUMNS`),
    empty when ``decision.statistics`` is off and the rule needs none."""


@dataclass(frozen=True)
class DecisionStep:
    """What a rule sees at one estimator step."""

    t: float
    """Time (s) of the estimator output."""
    out: FilterOutput
    """The estimator's output of this step."""
    omega: np.ndarray | None
    """Wheel rates [omega_R, omega_L] (rad/s) the output was predicted with (``None`` if not given)."""
    dirs: RadiusDirections
    """The observed and unobservable-split radius directions at those rates, with the filter's σ (m)
    along each (:mod:`.observability`)."""
    statistics: dict[str, float] = field(default_factory=dict)
    """Every rule's statistic this step (:mod:`.rule_statistics`); empty unless ``decision.statistics``
    is on or the rule sets ``needs_statistics``."""
    z: Measurement | None = None
    """The measurement the estimator was updated with this step (``None`` if not given)."""


class DecisionRule(Protocol):
    """What :class:`FaultDecision` needs of a rule."""

    dwell: float
    """Time (s) a candidate must hold before it is declared, changed or cleared."""

    def candidate(self, step: DecisionStep) -> Wheel | None:
        """The wheel a fault would be declared on from this step alone (``None``: no fault evident;
        ``'unknown'``: a fault is evident, not which wheel)."""
        ...


def departures(out: FilterOutput, R0: float, k_sigma: float, min_drop: float
               ) -> tuple[tuple[bool, bool], tuple[bool, bool]]:
    """Per wheel (right, left): the radius estimate significantly below nominal ``R0`` (m), i.e. by
    more than ``k_sigma`` σ and ``min_drop`` (puncture-like), and significantly above it (anomaly)."""
    below, above = [], []
    for i in (3, 4):
        dep = float(out.x[i]) - R0
        std = math.sqrt(max(float(out.P[i, i]), 0.0))
        sig = math.isfinite(dep) and abs(dep) > k_sigma * std and abs(dep) > min_drop
        below.append(sig and dep < 0.0)
        above.append(sig and dep > 0.0)
    return (below[0], below[1]), (above[0], above[1])


class SigmaRule:
    """``sigma``: a radius below nominal by ``k_sigma`` σ and ``min_drop``, isolated when the split is
    identified (module docstring)."""

    def __init__(self, d: DecisionSettings, R0: float) -> None:
        self.dwell = d.dwell
        self.k_sigma, self.min_drop, self.max_split_sigma, self.R0 = d.k_sigma, d.min_drop, d.max_split_sigma, R0

    def candidate(self, step: DecisionStep) -> Wheel | None:
        out, dirs = step.out, step.dirs
        sus_R, sus_L = departures(out, self.R0, self.k_sigma, self.min_drop)[0]
        if (sus_R or sus_L) and dirs.split_std <= self.max_split_sigma:
            return "both" if sus_R and sus_L else "right" if sus_R else "left"
        if sus_R or sus_L:
            return "unknown"
        # the observed combination c = w·(R - R0) alone: a puncture-like departure is one that a smaller
        # radius of some wheel i produces, i.e. c·w_i < 0
        c = dirs.w[0] * (float(out.x[3]) - self.R0) + dirs.w[1] * (float(out.x[4]) - self.R0)
        big = math.isfinite(c) and abs(c) > self.k_sigma * dirs.sum_std and abs(c) > self.min_drop
        if big and (c * dirs.w[0] < 0.0 or c * dirs.w[1] < 0.0):
            return "unknown"
        return None


class ModeRule:
    """``mode``: the most probable fault class of the declared hypotheses above ``mode_threshold``,
    with the implicated radii dropped by ``min_drop`` (module docstring)."""

    def __init__(self, d: DecisionSettings, R0: float) -> None:
        self.dwell = d.dwell
        self.mode_threshold, self.min_drop, self.R0 = d.mode_threshold, d.min_drop, R0

    def candidate(self, step: DecisionStep) -> Wheel | None:
        out = step.out
        if out.mode_probs is None or out.hypotheses is None:
            raise ValueError("decision rule 'mode' needs an estimator that declares the hypotheses of its mode "
                             "probabilities (FilterOutput.hypotheses)")
        best, p, dropped = mode_score(out, self.R0, self.min_drop)  # type: ignore[misc]
        return best if p > self.mode_threshold and dropped else None  # type: ignore[return-value]


class AutoRule:
    """``auto``: :class:`ModeRule` for outputs that declare hypotheses, else :class:`SigmaRule`."""

    def __init__(self, d: DecisionSettings, R0: float) -> None:
        self.dwell = d.dwell
        self.mode, self.sigma = ModeRule(d, R0), SigmaRule(d, R0)

    def candidate(self, step: DecisionStep) -> Wheel | None:
        rule = self.mode if step.out.hypotheses is not None else self.sigma
        return rule.candidate(step)


class ChangeRule:
    """``cusum`` / ``glr``: the change detector's statistic on the no-fault residual generator at its
    ``arl0`` threshold, confirmed by the size of the change (module docstring).

    A crossing of the threshold is an *alarm* (what the operating characteristics of docs/fdi.md
    measure). The alarm is watched for a settling time of half the GLR window (a puncture on the
    physical plant takes a few steps to reach its full size); at its end the GLR's most likely jump —
    hypothesis and size — re-anchors the residual generator and both detectors restart.

    A wheel is declared when the drops of its settled alarms within one GLR window (``window`` s, alarm
    times) add up to ``min_drop`` (m, the sigma rule's guard; a ``both`` jump counts for each wheel):
    a puncture is an abrupt change, and on the physical plant its first alarms each size only part of it
    (the punctured tyre skids while its wheel is held at its rate). Alarms whose drops stay below that —
    millimetres on the physical plant, where the constant-radius null model is only approximate (slip,
    the controller's reaction) — and slower drifts only re-anchor. The declared wheel is the set added so
    far (``both`` for two); ``'unknown'`` when the drops of alarms that isolated no wheel reach
    ``min_drop`` (the sensing cannot separate them) and no wheel has been added.

    Alarms within ``holdoff`` seconds of the last addition, and of the start (the launch from rest is a
    transient the null model does not describe either), book nothing: the transient after a puncture,
    when the generator was re-anchored on a jump estimated while the tyre was still settling
    (``decision.change_holdoff``). Only additions start a hold-off, so a transient's small alarms cannot
    mask a later puncture. A puncture within ``holdoff`` of the start is not declared by this rule.
    """

    declare_dwell = 0.0

    def __init__(self, name: str, settings: DecisionSettings, threshold: float,
                 detectors: ChangeDetectors | None = None) -> None:
        """``name``: ``cusum`` or ``glr``; ``settings``: the decision's (its ``dwell`` (s); ``min_drop``, the
        summed estimated drop (m) that declares a wheel; ``change_holdoff`` (s) and ``glr_window`` (s): see the
        class docstring); ``threshold``: calibrated by the wiring for the target mean time between false
        alarms (:func:`.calibration.arl0_threshold`); ``detectors``: the run's residual generator and
        detectors (the wiring builds them for the run's filter; ``None``: the rule cannot run and says so at
        its first step)."""
        self.name, self.dwell = name, settings.dwell
        self.threshold = threshold
        """Threshold (log-likelihood-ratio units) for a mean time ``decision.arl0`` between false alarms."""
        self.detectors = detectors
        self.min_drop = settings.min_drop
        self.holdoff = settings.change_holdoff
        self.window = settings.glr_window
        self.alarms: list[tuple[float, str | None, float, float]] = []
        """Each settled alarm: its crossing time (s), isolated wheel, the GLR's drop (m per wheel) and onset (s)."""
        self.drops = {"right": 0.0, "left": 0.0}
        """Estimated drop (m) of each wheel over the alarms that added it."""
        self._wheels: set[str] = set()
        self._unknown = False
        self._recent: list[tuple[float, str, float]] = []
        self._alarm_time = 0.0
        self._settle_until: float | None = None
        self._last_added = -math.inf

    def candidate(self, step: DecisionStep) -> Wheel | None:
        det = self.detectors
        if det is None:
            raise ValueError(f"decision rule {self.name!r} needs its change detectors (built by the decision factory)")
        if step.z is None or step.omega is None:
            raise ValueError(f"decision rule {self.name!r} needs the step's measurement and wheel rates")
        det.step(step.t, step.omega, step.z, np.asarray(step.out.x, float)[3:5])
        if self._settle_until is None:
            if (det.cusum_stat if self.name == "cusum" else det.glr_stat) >= self.threshold:
                self._alarm_time = step.t
                self._settle_until = step.t + det.settle_time
        elif step.t >= self._settle_until - 1e-9:
            self._settle(step.t)
        return self._declared()

    def _settle(self, t: float) -> None:
        """The end of an alarm's settling time: confirm or not, book, re-anchor, restart."""
        det = self.detectors
        assert det is not None
        wheel, drop = det.wheel(self.name), det.glr_drop
        self.alarms.append((self._alarm_time, wheel, drop, det.glr_onset))
        quiet = self._alarm_time < max(self._last_added, 0.0) + self.holdoff
        if not quiet and wheel is not None and drop > 0.0:
            self._recent.append((self._alarm_time, wheel, drop))
        recent = self._recent_drops()
        if recent["unknown"] >= self.min_drop:
            self._unknown = True
        big = {w for w in ("right", "left") if recent[w] >= self.min_drop} - self._wheels
        if big:
            self._wheels |= big
            self._last_added = self._alarm_time
            for w in big:
                self.drops[w] += recent[w]
            self._recent.clear()
        det.correct()
        self._settle_until = None

    def _recent_drops(self) -> dict[str, float]:
        """Drop (m) per wheel (and of alarms that isolated none, ``unknown``) summed over the booked alarms
        within ``window`` seconds of the last alarm; older ones are forgotten."""
        self._recent = [r for r in self._recent if r[0] > self._alarm_time - self.window - 1e-9]
        sums = {"right": 0.0, "left": 0.0, "unknown": 0.0}
        for _, wheel, drop in self._recent:
            for w in (("right", "left") if wheel == "both" else (wheel,)):
                sums[w] += drop
        return sums

    def _declared(self) -> Wheel | None:
        """The wheels added so far (``both`` for two), else ``'unknown'`` once the drops of alarms that
        isolated none reached ``min_drop``, else ``None``."""
        if len(self._wheels) == 2:
            return "both"
        if self._wheels:
            return next(iter(self._wheels))  # type: ignore[return-value]
        return "unknown" if self._unknown else None


class FaultDecision:
    """Stateful fault-decision layer: ``FaultDecision(settings, R0, rule).update(t, out) -> DecisionState``.

    ``settings``: the ``[estimator.decision]`` section; ``R0``: the model's nominal wheel radius (m);
    ``rule``: the decision rule (an object as :class:`DecisionRule`); ``statistics``: every rule's
    statistics (:class:`.rule_statistics.RuleStatistics`), needed when ``settings.statistics`` is on or
    the rule sets ``needs_statistics`` (the wiring :func:`ftc_mj.wiring.decision.build_fault_decision`
    builds all of them from a run config).
    """

    def __init__(self, settings: DecisionSettings, R0: float, rule: DecisionRule,
                 statistics: RuleStatistics | None = None) -> None:
        d = settings
        self.rule = d.rule
        self.rule_impl: DecisionRule = rule
        self.dwell = self.rule_impl.dwell
        self.declare_dwell = float(getattr(self.rule_impl, "declare_dwell", self.dwell))
        self.statistics = statistics
        self.threshold = float(getattr(self.rule_impl, "threshold", math.nan))
        """The rule's threshold where it has one (``cusum``/``glr``: log-likelihood-ratio units)."""
        self.k_sigma = d.k_sigma  # the anomaly flag's thresholds (any rule)
        self.min_drop = d.min_drop
        self.R0 = R0
        self.events: list[tuple[float, str]] = []
        self.declared: Wheel | None = None
        self.first_time: float | None = None
        self.n_declarations = 0
        self._cond_since: float | None = None
        self._clear_since: float | None = None
        self._change_cand: Wheel | None = None
        self._change_since = 0.0

    # ---------------------------------------------------------------- update
    def update(self, t: float, out: FilterOutput, omega: np.ndarray | None = None,
               z: Measurement | None = None) -> DecisionState:
        """Feed the estimator output of time ``t`` (s), the wheel rates ``omega`` (rad/s) it was predicted
        with (they set which radius combination is observable) and the measurement ``z`` it was updated
        with (the change detectors' residual generator needs it); returns the decision."""
        dirs = radius_directions(out.P, omega)
        u = np.asarray(omega, float) if omega is not None else np.zeros(2)
        stats = self.statistics.update(t, out, u, dirs, z) if self.statistics is not None else {}
        above = departures(out, self.R0, self.k_sigma, self.min_drop)[1]
        cand = self.rule_impl.candidate(DecisionStep(t, out, omega, dirs, stats, z))
        eps = 1e-9
        if cand is not None:
            self._clear_since = None
            if self._cond_since is None:
                self._cond_since = t
            if self.declared is None and t - self._cond_since >= self.declare_dwell - eps:
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
            statistics=stats,
        )


def _loss(r: float, R0: float) -> float:
    """Fractional radius loss ``clip(1 - r/R0, 0, 1)``; 0 for a non-finite estimate."""
    return min(max(1.0 - r / R0, 0.0), 1.0) if math.isfinite(r) else 0.0
