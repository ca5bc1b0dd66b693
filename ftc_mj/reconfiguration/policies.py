"""Which wheel radii the controller's model uses at each solve: the reconfiguration policy
(``reconfiguration.policy``, a name registered in :data:`ftc_mj.registry.policies`).

Built-in policies:

``none``
    Nominal radii for ever (the paper's "feedback off").
``direct``
    The latest filter estimate at every solve, floored at a positive radius (the paper's
    "feedback on"). On a physical plant this can run away (docs/findings.md): a wrong estimate makes the
    controller drive the robot somewhere the kinematic model no longer holds, which makes the
    estimate worse.
``safe``
    Hand the estimate over only when (a) the fault decision has declared a fault *and isolated the
    wheel*, (b) the filter's covariance says the radii are identified — σ of each radius and σ
    along the split direction the speed cannot observe (:mod:`~ftc_mj.estimation.observability`)
    at most ``max_sigma`` — and (c) the filter is healthy (no divergence reset since the last solve,
    mean NIS per measurement over ``nis_window`` at most ``max_nis_ratio``; a single NIS per
    measurement above ``spike_nis_ratio`` since the last solve holds instead). Only the isolated
    wheel(s) are changed (with ``condition_on_healthy`` and one wheel isolated, its radius is the filter's estimate
    conditioned on the other radius being nominal); radii are clamped to [``min_radius``, nominal] and rate-limited to
    ``max_rate`` — and an isolated wheel's radius *grows* by at most ``max_growth_rate``: a punctured
    tyre does not re-inflate, and an estimate that climbs back quickly is the filter leaving the
    kinematic model's domain (a lifted wheel; the measured case is in docs/findings.md); a *fall* within
    ``noise_band`` σ of the estimate is followed at that rate too (no ratchet on a noisy estimate) unless the
    estimate falls steadily over ``trend_window``, faster than that and no faster than ``trend_max_rate`` (a tyre
    that keeps deflating); a fall beyond the band that the next sample's estimate does not confirm is undone at
    ``max_rate`` (one sample's dip, a filter overshooting as it converges after a step). A declared
    but unidentified fault *holds* the radii in use. Filter trouble *reverts* to the radii handed over
    (as rate-limited, i.e. as the controller used them) at least ``trust_lag`` before it (or
    nominal); a withdrawn decision reverts to nominal.
``truth``
    The true radii (an oracle: the best any policy could do with this controller).

Every change of the ``safe`` policy's state is an :class:`~ftc_mj.telemetry.Event`, and the state
is a trace column (``reconfig_state``: 0 nominal, 1 hold, 2 handed over, 3 reverted).

A policy (built-in or plug-in) is a :class:`ReconfigurationPolicy`: the loop calls ``observe`` at
every estimator step and ``radii`` at every controller sample, logs ``state`` and collects
``events``. A run without an estimator uses ``none`` unless its policy is registered with
``needs_estimator=False`` (``truth``).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections import deque
from enum import IntEnum
from typing import Literal

import numpy as np
from pydantic import Field

from ..context import RunContext
from ..estimation.base import FilterOutput
from ..estimation.decision import DecisionState
from ..estimation.observability import radius_directions
from ..fields import Flag, NonNegFloat, Options, PosFloat, StrictModel, component, options_of
from ..registry import BUILTIN, policies
from ..telemetry import Event


class ReconfigurationSettings(StrictModel):
    """How the estimated radii reach the controller's model: the policy and its settings (the ``[reconfiguration]``
    section without its ``excitation`` and ``degraded`` tables, which the config adds). A policy built directly
    takes ``condition_on_healthy = "auto"`` as off; the wiring resolves it for the run's controller."""

    policy: component("policies") = "safe"
    """A registered reconfiguration policy (:data:`ftc_mj.registry.policies`). Built-in: ``none``:
    nominal radii (the paper's "feedback off"). ``direct``: the latest estimate at every solve (the
    paper's "feedback on"). ``safe``: hand radii over only after the fault decision has
    declared and isolated a fault and the estimate is identified (σ of each radius and of the
    unobservable split below ``max_sigma``, innovations consistent); clamped to
    [``min_radius``, nominal], rate-limited to ``max_rate``; reverts to the last trusted values on
    filter divergence and to nominal when the decision is withdrawn. ``truth``: the true radii
    (an oracle upper bound for comparisons; not realisable)."""
    max_sigma: PosFloat = 0.1
    """Largest standard deviation (m) of each radius and of the radius split accepted for hand-over."""
    min_radius: PosFloat = 0.05
    """Lower clamp (m) of a handed-over radius (upper clamp: the nominal radius)."""
    max_rate: PosFloat = 5.0
    """Largest change of a handed-over radius (m/s): a 50 % step (1 m) is handed over in 0.2 s."""
    max_growth_rate: NonNegFloat = 0.05
    """Largest *increase* (m/s) of a handed-over radius while the fault stays declared. A punctured tyre
    does not re-inflate: an estimate that grows quickly is the filter leaving the kinematic model's
    domain (a lifted or skidding wheel), not the tyre; this rate still lets the model radius recover
    from a transient undershoot (0.2 m in 4 s). Reverts (filter trouble, withdrawn decision) are not
    limited by it. Chosen by the rule of the built-in study ``tune_growth`` on the development seeds
    0–9 (docs/studies.md)."""
    noise_band: NonNegFloat = 4.0
    """Half-width, in standard deviations of the filter's estimate of an isolated wheel's radius (conditioned as
    handed over), of the band in which a *fall* of the estimate below the radius in use is taken as the
    estimate's noise and follows at ``max_growth_rate`` only, like a rise: only a fall beyond it is handed over
    at ``max_rate``. Without it the asymmetric limits are a ratchet on a noisy estimate — every dip is taken at
    once, every recovery at 0.05 m/s — and the radius in use settles below the estimate's mean: 3–4 % below a
    50 % tyre with the speed sensor and 10 Hz pose fixes but no gyro (dev seeds 0–1, docs/findings.md), which
    the path-following NMPC's traction bound turns into a 4–5 m excursion. At 2 σ the estimate's dips (nearly
    white at the 10 Hz fixes) still crossed the band every few seconds; 4 σ is beyond them. 0 = the ratchet."""
    trend_window: NonNegFloat = 2.0
    """Window (s) of the least-squares lines through each wheel's radius as it would be handed over (the estimate,
    conditioned as handed over, clamped), recorded at every controller sample whatever the state — so at a
    declaration the estimate's course before it is known at once; a filter reset starts the record afresh. Where an
    isolated wheel's radius *falls steadily* — the lines through the whole window and through each half of it all
    fall faster than ``max_growth_rate`` and none faster than ``trend_max_rate`` — the tyre keeps deflating (ftc-v2's
    puncture ramps, 0.05–0.2 m/s) and a fall within ``noise_band`` is followed at ``max_rate`` like one beyond it;
    otherwise at ``max_growth_rate``. Without it the radius in use fell ever further behind a ramp (0.1–0.25 m on
    ftc-v2 dev draw 49 without a gyro: 1.07 m off the path). A stationary estimate's lines are flat (a 2 s line's
    slope has σ 0.017 m/s on that draw's 1.05 m tyre; a 1 s half's, 0.04 m/s), so its dips are still followed at
    ``max_growth_rate``. The line needs 90 % of the window. Chosen on development draws and seeds
    (docs/config-defaults.md). 0 = off."""
    trend_max_rate: PosFloat = 0.3
    """Fastest fall (m/s) of the lines of ``trend_window`` taken as a tyre deflating: an estimate converging after
    a step falls faster (0.5–2 m/s after a 1 m step) and then levels off, and following its convergence at
    ``max_rate`` undershoots (scenario 2 without a gyro, the ``pathfollow`` settings, dev seeds 0–9: 0.5–3.8 m off
    the path from 15 s, against 0.34–1.88 m with the step's fall left to the noise band). Above ftc-v2's fastest ramp
    (0.2 m/s)."""
    condition_on_healthy: Literal["auto"] | Flag = "auto"
    """With one wheel isolated, hand over the filter's estimate of its radius *conditioned on the other wheel's
    radius being nominal* (``R_iso + P_io / P_oo (R_nom − R_other)``, the Gaussian posterior given what the
    decision asserts) instead of the raw estimate. The filter's two radii errors are strongly correlated (ρ ≈
    0.995 with a yaw-rate gyro: a common scale error, while the ratio is well identified); pairing the raw
    estimate of one wheel with the nominal other turns that scale error into a ratio, i.e. yaw-rate, error of
    the controller's model. ``auto`` (default): on with a controller registered to take radius intervals
    (``pf-nmpc``), off with the others (the time-parametrised NMPC tipped over with it in scenarios 3 and 4,
    docs/config-defaults.md); ``true``: on; ``false``: the raw estimate."""
    nis_window: PosFloat = 1.0
    """Window (s) of the innovation-consistency check (mean NIS)."""
    max_nis_ratio: PosFloat = 5.0
    """Mean NIS per measurement over ``nis_window`` above which the filter is taken as inconsistent:
    no new hand-over, and a revert to the last trusted radii (a consistent filter gives ≈ 1)."""
    spike_nis_ratio: PosFloat = 12.0
    """A NIS per measurement above this at any step since the last solve *holds* the radii in use
    (a sudden jump of the estimate is not handed over; P(χ²₁ > 12) ≈ 5e-4)."""
    trust_lag: NonNegFloat = 1.0
    """On a revert, the last trusted radii are those handed over at least this long (s) before the
    filter reported trouble (its estimate may already have been drifting)."""
    options: Options = Field(default_factory=dict, validate_default=True)
    """Settings of a plug-in policy (its registered settings model); built-in policies take none."""

    _options = options_of("policies", "policy")


class ReconfigState(IntEnum):
    """State of the ``safe`` policy (other policies stay ``NOMINAL`` or ``HANDED``)."""

    NOMINAL = 0
    HOLD = 1
    HANDED = 2
    REVERTED = 3


ISOLATED = {"right": (True, False), "left": (False, True), "both": (True, True)}
"""Per decision ``wheel``: the wheels (right, left) it isolates (``unknown`` or none: no entry)."""


class ReconfigurationPolicy(ABC):
    """Base of the policies: turns filter outputs and fault decisions into the radii [R_R, R_L] (m)
    handed to the controller.

    :meth:`observe` is called at every estimator step (after the filter and the decision), and
    :meth:`radii` at every controller sample; ``state`` (a :class:`ReconfigState` value) is logged in
    the ``reconfig_state`` column at every step and ``events`` (:class:`~ftc_mj.telemetry.Event`)
    are the run's events. Subclasses override :meth:`radii` (and :meth:`observe` if they keep a
    history); ``self.settings`` (the policy's settings: the ``[reconfiguration]`` section),
    ``self.nominal`` (the model's nominal radii, m) and ``self.floor`` (the estimator's ``min_radius``, m)
    are set here from the settings and the :class:`~ftc_mj.context.RunContext`.
    """

    initial_state = ReconfigState.NOMINAL

    def __init__(self, settings: ReconfigurationSettings, context: RunContext | None = None) -> None:
        if not isinstance(context, RunContext):
            raise TypeError(f"{type(self).__name__}: ReconfigurationPolicy(cfg) is the old contract; take (settings, "
                            "context) and call super().__init__(settings, context) (docs/plugins.md of the source "
                            "repository)")
        self.settings = settings
        self.nominal = np.array(context.nominal_radii, dtype=float)
        self.floor = context.min_radius
        self.state: int = self.initial_state
        self.events: list[Event] = []

    def observe(self, out: FilterOutput) -> None:  # noqa: B027 (an optional hook: the base keeps no history)
        """This estimator step's output (the base keeps nothing)."""

    @abstractmethod
    def radii(self, t: float, out: FilterOutput | None, decision: DecisionState | None, filter_reset: bool,
              omega: np.ndarray, truth: tuple[float, float]) -> np.ndarray:
        """Radii (m) for the solve at ``t`` (s) from the latest filter output ``out`` and decision
        (``None`` before the first filter step or without a filter). ``filter_reset``: the filter reset
        itself since the last solve; ``omega``: wheel rates (rad/s) measured at this sample (they set
        which radius combination the speed observes); ``truth``: the plant's true radii (m; only an
        oracle may use them)."""


class NominalPolicy(ReconfigurationPolicy):
    """``none``: the nominal radii for ever (the paper's "feedback off")."""

    def radii(self, t: float, out: FilterOutput | None, decision: DecisionState | None, filter_reset: bool,
              omega: np.ndarray, truth: tuple[float, float]) -> np.ndarray:
        return self.nominal.copy()


class DirectPolicy(ReconfigurationPolicy):
    """``direct``: the latest finite estimate at every solve, floored at ``estimator.min_radius``."""

    initial_state = ReconfigState.HANDED

    def __init__(self, settings: ReconfigurationSettings, context: RunContext) -> None:
        super().__init__(settings, context)
        self._current = self.nominal.copy()

    def radii(self, t: float, out: FilterOutput | None, decision: DecisionState | None, filter_reset: bool,
              omega: np.ndarray, truth: tuple[float, float]) -> np.ndarray:
        if out is None:
            return self.nominal.copy()
        est = np.asarray(out.x[3:5], dtype=float)
        if np.all(np.isfinite(est)):
            self._current = np.maximum(est, self.floor)
        return self._current.copy()


class TruthPolicy(ReconfigurationPolicy):
    """``truth``: the true radii, floored at ``estimator.min_radius`` (an oracle)."""

    initial_state = ReconfigState.HANDED

    def radii(self, t: float, out: FilterOutput | None, decision: DecisionState | None, filter_reset: bool,
              omega: np.ndarray, truth: tuple[float, float]) -> np.ndarray:
        return np.maximum(np.asarray(truth, dtype=float), self.floor)


class SafePolicy(ReconfigurationPolicy):
    """``safe``: gated, clamped, rate-limited hand-over with holds and reverts (module docstring)."""

    def __init__(self, settings: ReconfigurationSettings, context: RunContext) -> None:
        super().__init__(settings, context)
        rc = settings
        self.min_radius = rc.min_radius
        self.max_sigma = rc.max_sigma
        self.max_nis_ratio = rc.max_nis_ratio
        self.trust_lag = rc.trust_lag
        self.condition_on_healthy = rc.condition_on_healthy is True
        self.max_step = rc.max_rate / context.controller_rate
        self.max_grow_rate = min(rc.max_growth_rate, rc.max_rate)  # m/s
        self.max_grow = self.max_grow_rate / context.controller_rate  # m per controller sample
        self.noise_band = rc.noise_band
        self.trend_max_rate = rc.trend_max_rate
        self.trend_window = rc.trend_window
        self._trend: deque[tuple[float, np.ndarray]] = deque()
        self._nis: deque[float] = deque(maxlen=max(1, round(rc.nis_window * context.estimator_rate)))
        self._nis_sum = 0.0
        self.spike_nis_ratio = rc.spike_nis_ratio
        self._recent_max = 0.0
        self._current = self.nominal.copy()
        self._fell: tuple[np.ndarray, np.ndarray] | None = None  # (wheels, radii before): the last sample's falls
        self._trusted: list[tuple[float, np.ndarray]] = []
        self._why = "nominal"

    # ---------------------------------------------------------------- estimator rate
    def observe(self, out: FilterOutput) -> None:
        """Record this step's NIS per measurement (rejected measurements count as inconsistent; a step
        without any measurement, a sensor dropout's predict-only step, is no evidence and is skipped)."""
        if np.size(out.innovation) == 0 and not out.rejected:
            return
        m = max(int(np.size(out.innovation)), 1)
        r = float(out.nis) / m if np.isfinite(out.nis) and not out.rejected else 1e3
        if len(self._nis) == self._nis.maxlen:
            self._nis_sum -= self._nis[0]
        self._nis.append(r)
        self._nis_sum += r
        self._recent_max = max(self._recent_max, r)

    @property
    def nis_ratio(self) -> float:
        """Mean NIS per measurement over the window (≈ 1 for a consistent filter)."""
        return self._nis_sum / len(self._nis) if self._nis else 0.0

    # ---------------------------------------------------------------- controller rate
    def radii(self, t: float, out: FilterOutput | None, decision: DecisionState | None, filter_reset: bool,
              omega: np.ndarray, truth: tuple[float, float]) -> np.ndarray:
        if out is None:
            return self.nominal.copy()
        recent, self._recent_max = self._recent_max, 0.0
        est = np.asarray(out.x[3:5], dtype=float)
        self._record_trend(t, out, est, filter_reset)
        return self._safe(t, out, est, decision, filter_reset, omega, recent)

    def _safe(self, t: float, out: FilterOutput, est: np.ndarray, decision: DecisionState | None,
              filter_reset: bool, omega: np.ndarray, recent_nis: float) -> np.ndarray:
        declared = decision is not None and decision.detected
        fell, self._fell = self._fell, None  # set again below when this sample hands over
        healthy = not filter_reset and self.nis_ratio <= self.max_nis_ratio and bool(np.all(np.isfinite(est)))
        if not declared:
            if np.any(self._current != self.nominal):
                self._enter(ReconfigState.REVERTED, "withdrawn", t, "warn",
                            "reconfiguration revert to nominal: fault decision withdrawn")
            else:
                self._enter(ReconfigState.NOMINAL, "nominal", t, "info", "reconfiguration: nominal radii")
            return self._move(self.nominal)
        if not healthy:
            why = "filter reset (divergence)" if filter_reset else f"inconsistent innovations (mean NIS/dim " \
                                                                   f"{self.nis_ratio:.1f})"
            target = self._last_trusted(t)
            self._enter(ReconfigState.REVERTED, "reset" if filter_reset else "nis", t, "error",
                        f"reconfiguration revert to R_R {target[0]:.2f} m, R_L {target[1]:.2f} m: {why}")
            return self._move(target)
        assert decision is not None
        dirs = radius_directions(out.P, omega)
        sig = np.sqrt(np.clip(np.diag(out.P)[3:5], 0.0, None))
        iso = ISOLATED.get(decision.wheel or "")
        identified = float(np.max(sig)) <= self.max_sigma and dirs.split_std <= self.max_sigma
        if iso is None or not identified or recent_nis > self.spike_nis_ratio:
            if iso is None:
                why, tag = "wheel not isolated", "isolation"
            elif not identified:
                why, tag = (f"radii not identified (σ R {sig[0]:.2f}/{sig[1]:.2f} m, split {dirs.split_std:.2f} m)",
                            "identification")
            else:
                why, tag = f"surprising innovation (NIS/dim {recent_nis:.1f})", "spike"
            self._enter(ReconfigState.HOLD, tag, t, "warn", f"reconfiguration hold: {why}")
            return self._move(self._current)
        sd = sig.copy()  # the σ (m) of each radius as handed over
        if self.condition_on_healthy and iso.count(True) == 1:
            i = iso.index(True)
            est, sd[i] = self._conditioned(est, out.P, i), self._conditioned_std(out.P, i)
        target = np.where(iso, np.clip(est, self.min_radius, self.nominal), self.nominal)
        self._enter(ReconfigState.HANDED, str(decision.wheel), t, "info",
                    f"reconfiguration hand-over ({decision.wheel}): R_R {target[0]:.2f} m, R_L {target[1]:.2f} m")
        # an isolated wheel's radius grows no faster than max_growth_rate (a puncture does not re-inflate), and
        # falls no faster either while the fall lies within the estimate's noise band (no ratchet) and the estimate
        # does not fall steadily (a ramp: _steady_fall); a wheel the decision no longer isolates returns to
        # nominal at the full rate; a fall beyond the band that this sample's estimate does not confirm is undone
        # at the full rate (_rebound)
        isolated = np.asarray(iso)
        noise = isolated & (target >= self._current - self.noise_band * sd)
        in_band_fall = np.where(self._steady_fall(t), self.max_step, self.max_grow)
        target, grow = self._rebound(target, np.where(isolated, self.max_grow, self.max_step), fell, isolated)
        before = self._current
        in_use = self._move(target, grow, np.where(noise, in_band_fall, self.max_step))
        self._fell = (isolated & ~noise & (in_use < before) & (before < self.nominal), before)
        # what is trusted is what the controller was given, not the target the rate limits held back:
        # a revert must not jump to an estimate the growth limit refused
        self._trusted.append((t, in_use.copy()))
        return in_use

    # ---------------------------------------------------------------- helpers
    def _rebound(self, target: np.ndarray, grow: np.ndarray, fell: tuple[np.ndarray, np.ndarray] | None,
                 iso: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``target`` (m) and the largest rise (m per sample) ``grow``, where the previous controller sample took a
        fall beyond the noise band (``fell``: those wheels and their radii before it; ``None`` if that sample did
        not hand over), the wheel is still isolated (``iso``) and this sample's estimate lies above the radius in
        use: the fall was one sample's dip, not the tyre, and is undone at ``max_rate`` as far as the estimate,
        never above the radius before the fall (a first hand-over, a fall from nominal, is the declaration's
        evidence and is never undone this way). A filter converging after a step overshoots for a sample
        (scenario 3 with the gyro, dev seed 0: 1.13, 0.95, 1.01 m for a 1.00 m tyre, the dip 6 σ below the 1.13 m
        in use); kept, the dip climbed back at ``max_growth_rate`` only and the radius in use stayed 3–4 % low for
        1.5 s while the robot recovered 1.1 m of cross-track error at 10 m/s (a wheel lifted 0.24 s). A fall the
        next sample confirms (a step, a ramp) is untouched."""
        if fell is None:
            return target, grow
        wheels, before = fell
        back = wheels & iso & (target > self._current)
        return np.where(back, np.fmin(target, before), target), np.where(back, self.max_step, grow)

    def _record_trend(self, t: float, out: FilterOutput, est: np.ndarray, filter_reset: bool) -> None:
        """Keep each wheel's radius as it would be handed over (conditioned on the other wheel being nominal where
        ``condition_on_healthy``, clamped) at ``t`` (s) for the last ``trend_window``, whatever the state: at a
        declaration the trend of the estimate before it is known at once. A filter reset (its estimate jumps)
        or a non-finite estimate starts the record afresh."""
        if self.trend_window <= 0.0:
            return
        if filter_reset or not np.all(np.isfinite(est)):
            self._trend.clear()
            return
        r = est.copy()
        if self.condition_on_healthy:
            r = np.array([self._conditioned(est, out.P, 0)[0], self._conditioned(est, out.P, 1)[1]])
        self._trend.append((t, np.clip(r, self.min_radius, self.nominal)))
        while self._trend[0][0] < t - self.trend_window - 1e-9:
            self._trend.popleft()

    def _steady_fall(self, t: float) -> np.ndarray:
        """Whether each wheel's radius (:meth:`_record_trend`) falls steadily at ``t`` (s): the least-squares lines
        through the whole ``trend_window`` and through each of its halves all fall faster than ``max_growth_rate``
        and none faster than ``trend_max_rate`` (m/s). False until the record spans 90 % of the window."""
        if not self._trend or t - self._trend[0][0] < 0.9 * self.trend_window:
            return np.zeros(2, dtype=bool)
        ts = np.fromiter((s[0] for s in self._trend), float, len(self._trend))
        rs = np.array([s[1] for s in self._trend])
        late = ts >= 0.5 * (ts[0] + ts[-1])
        falls = np.array([-_slope(ts[p], rs[p]) for p in (slice(None), ~late, late)])  # m/s, (line, wheel)
        return (falls.min(axis=0) > self.max_grow_rate) & (falls.max(axis=0) <= self.trend_max_rate)

    def _conditioned(self, est: np.ndarray, P: np.ndarray, i: int) -> np.ndarray:
        """``est`` with radius ``i`` (0 R_R, 1 R_L) replaced by its Gaussian conditional mean given that the other
        radius is nominal (``condition_on_healthy``); unchanged if the covariance is not usable."""
        o = 1 - i
        p_oo, p_io = float(P[3 + o, 3 + o]), float(P[3 + i, 3 + o])
        if not (np.isfinite(p_oo) and np.isfinite(p_io) and p_oo > 0.0):
            return est
        out = est.copy()
        out[i] = est[i] + p_io / p_oo * (self.nominal[o] - est[o])
        return out

    @staticmethod
    def _conditioned_std(P: np.ndarray, i: int) -> float:
        """Standard deviation (m) of radius ``i`` given the other radius (:meth:`_conditioned`):
        ``√(P_ii − P_io² / P_oo)``; the marginal one if the covariance is not usable."""
        o = 1 - i
        p_ii, p_oo, p_io = float(P[3 + i, 3 + i]), float(P[3 + o, 3 + o]), float(P[3 + i, 3 + o])
        if not (np.isfinite(p_oo) and np.isfinite(p_io) and p_oo > 0.0):
            return float(np.sqrt(max(p_ii, 0.0)))
        return float(np.sqrt(max(p_ii - p_io * p_io / p_oo, 0.0)))

    def _enter(self, state: ReconfigState, why: str, t: float, level: str, text: str) -> None:
        """Switch to ``state`` for reason ``why``; an event when either changes."""
        if (state, why) != (self.state, self._why):
            self.state, self._why = state, why
            self.events.append(Event(t, level, text))

    def _move(self, target: np.ndarray, max_grow: float | np.ndarray | None = None,
              max_fall: float | np.ndarray | None = None) -> np.ndarray:
        """Step the radii in use towards ``target`` by at most ``max_fall`` down and ``max_grow`` up (m per
        sample, per wheel; each default ``max_step``)."""
        up = self.max_step if max_grow is None else max_grow
        down = self.max_step if max_fall is None else max_fall
        self._current = self._current + np.clip(target - self._current, -down, up)
        return self._current.copy()

    def _last_trusted(self, t: float) -> np.ndarray:
        for t_acc, r in reversed(self._trusted):
            if t_acc <= t - self.trust_lag:
                return r
        return self.nominal


def _slope(t: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Slope (per s) of the least-squares line through samples ``r`` (n, k) at times ``t`` (n,), per column;
    0 for fewer than two distinct times."""
    dt = t - t.mean()
    den = float(dt @ dt)
    return dt @ (r - r.mean(axis=0)) / den if den > 0.0 else np.zeros(r.shape[1])


policies.register("none", NominalPolicy, origin=BUILTIN)
policies.register("direct", DirectPolicy, origin=BUILTIN)
policies.register("safe", SafePolicy, origin=BUILTIN, section=ReconfigurationSettings)
policies.register("truth", TruthPolicy, origin=BUILTIN, needs_estimator=False)

