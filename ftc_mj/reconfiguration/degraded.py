"""The degraded robust mode of the path-following NMPC and the no-slip test of the identification.

From the first alarm until the fault is isolated and identified, the controller is handed, for each wheel
that may be faulty, a radius *interval* instead of a point (:class:`~ftc_mj.control.pathfollow_spec.RadiusInterval`),
and bounds the robot's lateral acceleration at every radius of it; the speed reduction follows from those
constraints. The interval of a suspect wheel is ``[max(min_radius, estimate − depth), estimate]``: the filter's
estimate is an upper bound of the true radius while the tyre is dragged (a tyre dragged slower than it rolls
shows the effective radius ``(V ∓ b psidot)/omega``, larger than its own) — never ``estimate ± kσ``: during
a skid the covariance is many σ off while the innovations stay consistent. ``depth`` (default 0: the interval
is the point the model uses) sets how far below it the lateral bound must also hold; on the development seeds
every depth > 0 made the lift-off longer (docs/findings.md): the rows brake the robot, and braking lowers the
dragged wheel's rate while the chassis keeps its speed, which drags the tyre harder.

**Follow the upper bound.** From the first alarm, the model radius of a suspect wheel follows its estimate
*downwards* (the smaller of the policy's radius and the estimate, rate-limited by the policy's ``max_rate``)
as long as the filter has identified the radii (the largest σ of the radius block at most the policy's
``max_sigma``: a speed-only filter cannot tell the wheels apart, and its estimate of one wheel is not a
bound of anything). Handing over an upper bound cannot spin the wheel faster than it rolls, so each hand-over
raises the dragged wheel's rate towards rolling and lowers the next effective radius; the drag ends when
the effective radius has come down to the true one, which the no-slip test then sees as constant. Waiting
for the fault decision's dwell and the policy's gates instead left the skid running for 1.2–1.5 s after a
puncture (docs/findings.md).

**The no-slip test** (:class:`NoSlipCheck`). The kinematic model the filter uses assumes the tyres roll. A
dragged tyre breaks it without the innovations showing anything: with speed and yaw rate measured, the two
radii are two unknowns that any pair of contact speeds fits, so the filter follows the skidding tyre's
*effective* radius with a consistent NIS (a field review measured 1.8–2.0 m against a true 1.0 m at NIS/dim
≈ 1). Yaw rate against the wheel kinematics cannot tell either, for the same reason: the estimated radii are
the ones that make them agree. What a skid cannot fake is *constancy*: a rolling tyre's radius is a property
of the tyre, constant after a puncture (or shrinking slowly while it deflates), whereas the effective radius
of a dragged tyre is the ratio of a ground speed the chassis dynamics set and a wheel rate the servo sets, and
it moves whenever either changes — in the measured skid the estimate fell 1.9 → 1.0 m in 1.2 s. The test
flags a wheel whose estimate, averaged over the latest ``window/2`` s, differs from its average over the
``window/2`` s before by more than ``max_radius_rate · window/2 + k_sigma σ`` (σ the filter's standard
deviation of that radius: the allowance for the estimate's own scatter). A flagged wheel is not
*identified*: its interval stays open (or reopens), so the policy's hand-over does not end the mode while
the estimate still moves, and the model keeps following the estimate down.

**Drag evidence** (:class:`DragEvidence`, ``mode = "auto"``). Following the estimate down is right only where
a tyre can be dragged: the estimate is an upper bound of the radius because the ground pulls the tyre off its
rolling speed. A dragged tyre pulls on its wheel too, and a velocity servo carries that torque with a rate
error (``F R / k_v``): the measured wheel rate leaves the command in force. Where the wheels follow their
commands exactly (the ideal kinematic machine: no force on the tyres moves them) the estimate is the rolling
radius itself, no bound to follow, and following it made scenarios 2 and 3 worse (docs/config-defaults.md).
So ``auto`` arms the mode from the first evidence, on the measurements alone, that the wheels yield to the
ground: a window's mean of measured minus commanded wheel rate (the command clipped to the rate limit)
beyond :data:`DRAG_FLOOR` plus :data:`DRAG_K_SIGMA` standard errors of the encoder noise, on either wheel. Until
then the mode hands the policy's radii through and no interval (as if it were off); once armed it stays armed.
On the MuJoCo robot the servos' yaw couple on a curve (``plant/limits.py``) or the drag of a puncture arms it
within half a no-slip window; nothing in it asks which simulator runs.

**The mode.** A wheel is suspect from the first alarm: its estimate below nominal by the decision's
``k_sigma`` σ and ``min_drop`` (the sigma rule's candidate, before any dwell), the decision suspecting a
fault it has not isolated (both wheels) or declaring one (the isolated wheels), or a failing no-slip test.
A suspect wheel's interval collapses to the radius in use once the policy hands it over (state ``HANDED``,
the wheel isolated) and its no-slip test passes; the mode ends when no wheel's interval is open. Entry and
exit are events; the interval, the mode and the flagged wheels are trace columns of the controller
(``pf_degraded``, ``pf_R_*_lo/hi``, ``pf_skid``) and series of the Rerun recording.
"""

from __future__ import annotations

from collections import deque
from typing import Literal

import numpy as np

from ..context import RunContext
from ..control.pathfollow_spec import RadiusInterval
from ..estimation.base import FilterOutput
from ..estimation.decision import DecisionState, departures
from ..fields import NonNegFloat, PosFloat, StrictModel, ranged
from ..telemetry import Event
from .policies import ReconfigState

_WHEELS = {"right": (True, False), "left": (False, True), "both": (True, True), "unknown": (True, True)}


class DegradedSettings(StrictModel):
    """The degraded mode and the no-slip test of the identification (:mod:`~ftc_mj.reconfiguration.degraded`):
    from the first alarm until the fault is isolated and identified, the model radius of each suspect wheel
    follows its estimate down (an upper bound of the true radius while the tyre is dragged), a controller that
    takes radius intervals (``pf-nmpc``) bounds the robot's lateral acceleration over each suspect wheel's
    interval, and a wheel whose estimate moves faster than a tyre's radius can (a skid) is not identified."""

    mode: Literal["auto", "on", "off"] = "auto"
    """``auto`` (default): on with the ``safe`` policy, a controller registered to take radius intervals
    (``pf-nmpc``) and a sensor that tells the wheels apart (a yaw-rate gyro or position fixes), armed once the
    measured wheel rates show the tyres can be dragged (:class:`DragEvidence`: where the wheels follow their
    commands exactly the estimate is no upper bound, and following it made scenarios 2 and 3 worse on the
    kinematic plant, docs/config-defaults.md), else off;
    ``on``: with any policy but ``none`` and ``truth`` (and such a controller), armed from the start; ``off``:
    never. From the first alarm the model radius of a suspect wheel follows its estimate down; with it the
    pf-nmpc's lift-off after a puncture fell from 0.25–1.05 s to 0.03–0.11 s on the development seeds 0–5
    (docs/findings.md)."""
    min_radius: PosFloat = 0.05
    """Smallest radius (m) a fault can leave: the floor of a suspect wheel's interval and model radius (the tyre
    down to its rim; scenario 4 deflates to 0.1 m)."""
    depth: NonNegFloat = 0.0
    """How far (m) below the estimate a suspect wheel's interval reaches: the lateral bound holds for every
    radius in ``[max(min_radius, estimate − depth), estimate]``. 0 (default): the point the model uses. On the
    development seeds 0–5 a depth of 0.2 m and 0.5 m lengthened the lift-off (scenario 3: 0.05–0.11 s at 0,
    0.17–0.36 s at 0.2, 0.31–0.53 s at 0.5): the rows brake the robot, which drags the punctured tyre harder."""
    skid_window: ranged(0.02, 10.0, unit="s") = 0.5
    """Window (s) of the no-slip test: the mean estimate of its second half is compared with that of its first."""
    max_radius_rate: NonNegFloat = 0.2
    """Fastest change (m/s) of a rolling tyre's radius the no-slip test accepts (a deflation; scenario 4's is
    0.1 m/s). A skid moved the estimate at 0.4–1.2 m/s in the measured case (docs/findings.md)."""
    skid_k_sigma: NonNegFloat = 2.0
    """Allowance of the no-slip test for the estimate's own scatter, in standard deviations of the radius."""


class NoSlipCheck:
    """Per wheel, whether the filter's radius estimate moves faster than a rolling tyre's radius can (module
    docstring). ``observe`` at every estimator step; ``slipping`` (right, left) after it."""

    def __init__(self, window: float, max_radius_rate: float, k_sigma: float, estimator_rate: float) -> None:
        self.half = max(1, round(0.5 * window * estimator_rate))
        self.allow = max_radius_rate * self.half / estimator_rate
        self.k_sigma = float(k_sigma)
        self._r: deque[np.ndarray] = deque(maxlen=2 * self.half)
        self.sigma = np.zeros(2)
        self.slipping: tuple[bool, bool] = (False, False)
        self.moved = np.zeros(2)
        """Difference (m) of the two half-window means of each radius at the last step."""

    def observe(self, out: FilterOutput) -> None:
        """Record this step's radius estimates (m) and update the flags."""
        r = np.asarray(out.x[3:5], dtype=float)
        if not np.all(np.isfinite(r)):
            return
        self._r.append(r.copy())
        self.sigma = np.sqrt(np.clip(np.diag(out.P)[3:5], 0.0, None))
        if len(self._r) < 2 * self.half:
            return
        arr = np.asarray(self._r)
        self.moved = arr[self.half:].mean(axis=0) - arr[: self.half].mean(axis=0)
        flag = np.abs(self.moved) > self.allow + self.k_sigma * self.sigma
        self.slipping = (bool(flag[0]), bool(flag[1]))

    def reset(self) -> None:
        """Forget the history."""
        self._r.clear()
        self.slipping = (False, False)
        self.moved = np.zeros(2)


DRAG_FLOOR = 1.0e-3
"""Smallest mean servo rate error (rad/s) taken as evidence that the wheels yield to ground forces (above the
round-off of a kinematic plant's exact rates, far below the 0.01–0.2 rad/s of the MuJoCo robot's servos on a
curve or dragging a punctured tyre)."""
DRAG_K_SIGMA = 6.0
"""Allowance of the drag evidence, in standard errors of a window's mean rate error under the encoder noise: the
evidence latches, so a false one over a run's thousands of windows must be rare (one-sided tail 1e-9 each)."""


class DragEvidence:
    """Whether the measured wheel rates have left the commanded ones (module docstring, "Drag evidence"):
    ``observe(measured, commanded)`` at every estimator step (rad/s; ``commanded`` ``None`` before the first
    command); ``seen`` latches.

    Args:
        window: estimator steps averaged.
        encoder_sigma: the encoder noise (rad/s) of one measured rate.
        omega_max: the wheel-rate limit (rad/s) the commands are clipped to.
    """

    def __init__(self, window: int, encoder_sigma: float, omega_max: float) -> None:
        self.window = max(1, int(window))
        self.limit = DRAG_FLOOR + DRAG_K_SIGMA * float(encoder_sigma) / np.sqrt(self.window)
        self.omega_max = float(omega_max)
        self._e: deque[np.ndarray] = deque(maxlen=self.window)
        self.seen = False

    def observe(self, measured: np.ndarray, commanded: np.ndarray | None) -> None:
        """This step's measured wheel rates against the command in force while they were reached (rad/s)."""
        if self.seen or commanded is None:
            return
        e = np.asarray(measured, float) - np.clip(np.asarray(commanded, float), -self.omega_max, self.omega_max)
        if not np.all(np.isfinite(e)):
            return
        self._e.append(e)
        if len(self._e) == self.window:
            self.seen = bool(np.any(np.abs(np.mean(self._e, axis=0)) > self.limit))


class DegradedMode:
    """The radius interval from the first alarm and the skid-proof hand-over (module docstring).

    ``observe(out)`` at every estimator step; ``hand_over(t, radii, out, decision, policy_state)`` at every
    controller sample turns the policy's radii into the radii the controller uses and the interval it is
    handed (``None`` outside the mode); ``events`` are the mode's entries, exits and skid holds.
    """

    def __init__(self, settings: DegradedSettings, context: RunContext, k_sigma: float, min_drop: float,
                 max_rate: float, max_sigma: float, evidence: DragEvidence | None = None) -> None:
        self.settings = settings
        self.nominal = np.array(context.nominal_radii, dtype=float)
        self.min_radius = float(settings.min_radius)
        self.k_sigma, self.min_drop = float(k_sigma), float(min_drop)
        rate = context.estimator_rate or 1.0 / context.estimator_dt
        self.skid = NoSlipCheck(settings.skid_window, settings.max_radius_rate, settings.skid_k_sigma, rate)
        self.max_step = max_rate * context.controller_dt
        self.max_sigma = float(max_sigma)
        self.dt = context.controller_dt
        self.evidence = evidence
        """``None``: armed from the start (``mode = "on"``); else armed once it has seen a drag."""
        self._armed_told = False
        self.events: list[Event] = []
        self.active = False
        self._radii = self.nominal.copy()
        self._flagged = (False, False)
        self._open = np.zeros(2, dtype=bool)  # the wheels whose interval is open (latched from the alarm)
        self._identified = np.zeros(2, dtype=bool)  # the wheels whose interval collapsed (reopened by a skid)
        self._quiet = np.zeros(2)  # time (s) each open wheel has been without an alarm

    def observe(self, out: FilterOutput, measured: np.ndarray | None = None, commanded: np.ndarray | None = None
                ) -> None:
        """This estimator step's output (fed to the no-slip test) and, for the drag evidence, the wheel rates
        measured at it and the command in force while they were reached (rad/s)."""
        self.skid.observe(out)
        if self.evidence is not None and not self.evidence.seen and measured is not None:
            self.evidence.observe(measured, commanded)

    @property
    def armed(self) -> bool:
        """Whether the mode acts (module docstring, "Drag evidence")."""
        return self.evidence is None or self.evidence.seen

    def suspects(self, out: FilterOutput, decision: DecisionState | None) -> np.ndarray:
        """Per wheel (right, left): may be faulty — first alarm, suspected or declared fault, failing no-slip test."""
        below = np.array(departures(out, float(self.nominal[0]), self.k_sigma, self.min_drop)[0])
        s = below | np.array(self.skid.slipping)
        if decision is not None:
            if decision.suspected:
                s |= True
            if decision.detected:
                s |= np.array(_WHEELS.get(decision.wheel or "", (False, False)))
        return s

    def hand_over(self, t: float, radii: np.ndarray, out: FilterOutput | None, decision: DecisionState | None,
                  policy_state: int) -> tuple[np.ndarray, RadiusInterval | None]:
        """The radii (m) for the controller's model and the interval (or ``None``) at ``t`` (s) from the policy's
        ``radii`` (m) and state, the filter output and the decision."""
        if out is None or not self.armed:
            return np.asarray(radii, float).copy(), None
        if self.evidence is not None and not self._armed_told:
            self._armed_told = True
            self.events.append(Event(t, "info", "degraded mode armed: the measured wheel rates leave their commands "
                                                "(the tyres yield to ground forces)"))
        skid = np.array(self.skid.slipping)
        est = np.asarray(out.x[3:5], dtype=float)
        isolated = np.array(_WHEELS.get(decision.wheel or "", (False, False))) if (
            decision is not None and decision.detected and decision.wheel != "unknown") else np.zeros(2, bool)
        collapsed = isolated & (policy_state == ReconfigState.HANDED) & ~skid
        # an alarm opens the wheel's interval (an identified wheel's only by a failing no-slip test); it closes
        # when the wheel is identified (collapsed), or when the alarm has been quiet for a whole no-slip window
        # (a false alarm), not at the first quiet sample
        alarm = np.where(self._identified, skid, self.suspects(out, decision))
        self._quiet = np.where(alarm, 0.0, self._quiet + self.dt)
        self._identified = (self._identified | (collapsed & self._open)) & ~skid
        self._open = (self._open | alarm) & ~collapsed & (self._quiet < self.settings.skid_window)
        open_ = self._open
        target = np.asarray(radii, dtype=float)
        if self._identified_block(out):  # follow an open wheel's estimate down: an upper bound while it is dragged
            target = np.where(open_, np.fmin(target, np.clip(est, self.min_radius, self.nominal)), target)  # NaN: keep
        self._radii = self._radii + np.clip(target - self._radii, -self.max_step, self.max_step)
        self._skid_events(t, skid)
        hi = np.where(open_, np.clip(np.nan_to_num(est, nan=self.nominal[0]), self.min_radius, self.nominal),
                      self._radii)
        lo = np.where(open_, np.maximum(self.min_radius, hi - self.settings.depth), self._radii)
        interval = RadiusInterval(lo, np.maximum(hi, lo), (bool(skid[0]), bool(skid[1]))) if open_.any() else None
        self._mode_events(t, interval)
        return self._radii.copy(), interval

    def _identified_block(self, out: FilterOutput) -> bool:
        """The filter tells the two radii apart: the largest σ (m) of its radius block is at most ``max_sigma``."""
        block = np.asarray(out.P, dtype=float)[3:5, 3:5]
        if not np.all(np.isfinite(block)):
            return False
        return float(np.sqrt(max(float(np.linalg.eigvalsh(block)[-1]), 0.0))) <= self.max_sigma

    def _skid_events(self, t: float, skid: np.ndarray) -> None:
        for i, name in enumerate(("right", "left")):
            if skid[i] and not self._flagged[i]:
                self.events.append(Event(t, "warn", f"no-slip test fails ({name} radius estimate moved "
                                                    f"{self.skid.moved[i]:+.2f} m in {self.skid.half * 2} steps): "
                                                    f"not identified, its interval stays open"))
        self._flagged = (bool(skid[0]), bool(skid[1]))

    def _mode_events(self, t: float, interval: RadiusInterval | None) -> None:
        if interval is not None and not self.active:
            self.events.append(Event(t, "warn", f"degraded mode from the first alarm: R_R in [{interval.lo[0]:.2f}, "
                                                f"{interval.hi[0]:.2f}] m, R_L in [{interval.lo[1]:.2f}, "
                                                f"{interval.hi[1]:.2f}] m"))
        elif interval is None and self.active:
            self.events.append(Event(t, "info", f"degraded mode ends: interval collapsed to R_R "
                                                f"{self._radii[0]:.2f} m, R_L {self._radii[1]:.2f} m"))
        self.active = interval is not None
