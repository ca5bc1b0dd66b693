"""Accommodation per diagnosed mode: what the loop changes for each fault a diagnosis declares, and the safe
stop when the remaining actuation cannot follow the path.

:class:`Accommodation` reads the declarations (:class:`~ftc_mj.model.diagnosis.Diagnosis`, from a diagnoser or
the truth, :mod:`.oracle`) at every controller sample and decides, per mode:

==========================  =================================================================================
diagnosed mode              accommodation
==========================  =================================================================================
tyre ``puncture``           the radii, as the reconfiguration policy hands them over (:mod:`.policies`; the
                            declared size while it holds the nominal radius), or
                            with ``tyre = "diagnosis"`` the declared size × the nominal radius; a tyre left
                            with at most ``stop_radius_fraction`` of its radius: safe stop
servo ``loss``              the controller's actuator model scaled by the effectiveness ``e``
                            (``set_actuator_effectiveness``: the path-following NMPC's servo-compliance
                            offset of that wheel grows by ``1/e``, its lateral and longitudinal bounds
                            follow the weakest servo's torque, ``pathfollow_spec.servo_limited``);
                            ``e ≤ stop_effectiveness``: safe stop
servo ``lock``,             safe stop: a wheel that cannot turn, or turns only with the ground, cannot
``unresponsive``            steer the robot along the path (the other wheel brakes and steers: the stop's
                            one-wheel laws, :mod:`ftc_mj.control.stop`)
sensor ``bias``, ``drift``  the reading corrected by the diagnosed offset (``size``, or ``size (t − onset)``)
                            before the filter sees it
pose ``bias``, ``jump``     the fixes' position corrected by the diagnosed displacement
                            (:attr:`~ftc_mj.model.diagnosis.Diagnosis.offset`, ``(dx, dy)`` m) before the
                            filter sees them — the controller's pose is the filter's, so both see the same
                            corrected fixes; the diagnoser re-declares the offset as it re-estimates it (a
                            jump seen to return: offset ``(0, 0)``, the correction withdrawn). A record
                            without an offset, or whose σ (larger axis) exceeds ``pose_correct_sigma`` of its
                            length: excluded, as a dropout
sensor ``dropout``          the channel excluded from the filter (and a pose sensor's from the controller's
                            pose, which then is the filter's estimate) until it delivers again: its first
                            reading after the declaration ends the dropout, and the readings are taken as
                            they come from then on (a later dropout is declared, and excluded, anew)
==========================  =================================================================================

*Safe stop* (:class:`~ftc_mj.control.stop.SafeStop`): entered at the first sample after a declaration that
leaves the path out of reach, and final (a stopped robot does not drive on when a diagnosis is withdrawn); the
controller is replaced by the stop law, which brakes along the path within the nominal robot's braking and
lateral limits. Its reason is kept (:attr:`Accommodation.stop_reason`) for the events and the run summary.

The state is :class:`AccommodationMode` (trace column ``accommodation_mode``); every change of it, and of
the actuator model handed to the controller, is an :class:`~ftc_mj.telemetry.Event`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from enum import IntEnum
from typing import Any, Literal

import numpy as np
from pydantic import Field

from ..control.base import ControlOutput
from ..control.stop import SafeStop, SafeStopSettings
from ..estimation.base import FilterOutput, Measurement
from ..estimation.decision import DecisionState
from ..fields import StrictModel, ranged, ranged_int
from ..model.diagnosis import Diagnosis
from ..telemetry import Event
from .policies import ISOLATED

ACCOMMODATION_COLUMNS: tuple[str, ...] = ("accommodation_mode", "actuator_effectiveness_R", "actuator_effectiveness_L")
"""Trace columns of a run with the accommodation: its :class:`AccommodationMode` and the servo effectiveness per
wheel handed to the controller's actuator model (fractions; 1 healthy)."""

_SIDE = {"right": 0, "left": 1}
_CHANNEL = {"speed sensor": "speed", "gyro": "yaw_rate", "pose sensor": "position"}


class AccommodationSettings(StrictModel):
    """What is accommodated and when the robot stops instead (``[reconfiguration.accommodation]``)."""

    mode: Literal["radii", "all"] = "radii"
    """``radii``: only the reconfiguration policy's radii reach the controller (the behaviour before
    accommodation; every other fault is met by robustness alone). ``all``: every diagnosed mode is accommodated
    and a fault that leaves the path out of reach stops the robot (module docstring); the declarations come from
    the run's diagnoser (``[diagnosis]``), or from the truth with ``oracle = true``."""
    tyre: Literal["policy", "diagnosis"] = "policy"
    """Where a diagnosed tyre's radius comes from (with ``mode = "all"``): ``policy`` — the reconfiguration
    policy's radii, and the declared size where the policy still holds the nominal radius of a declared tyre (its
    decision rule has not isolated the wheel); ``diagnosis`` — the declared size times the model's nominal radius, for
    each wheel with a declared puncture (the policy's radii for the others)."""
    stop_effectiveness: ranged(0.0, 1.0) = 0.05
    """A servo diagnosed with at most this fraction of its gain and torque left stops the robot (m/s² of
    turning it can still give scale with it; at 5 % the shipped robot's servo carries 0.4 m/s² of lateral
    acceleration, ``e τ_max R / (c b k_v)``)."""
    stop_radius_fraction: ranged(0.0, 1.0) = 0.02
    """A tyre diagnosed with at most this fraction of its radius left stops the robot: its wheel carries at most
    this fraction of the nominal speed at the servo's rate limit (0.7 m/s on the shipped robot at 2 %). Scenario 4's
    tyre ends at 5 % (0.1 m), where the path-following NMPC still follows the path at 1.78 m/s: not a stop."""
    pose_settle: ranged(0.0, 10.0) = 0.5
    """A pose offset is subtracted only once its declaration has stood this long (s); until then the pose sensor
    is excluded. Right after a displacement the diagnoser's window holds few displaced fixes and its first
    estimates of a large step can be far off (re-declared within tenths of a second: dev draws 201, 263)."""
    pose_max_declarations: ranged_int(1, 100) = 3
    """A pose sensor whose displacement has been declared (bias or jump) more than this many times in the run is
    taken as unidentifiable and excluded for the rest of it: a displacement and its return are two declarations,
    a refined estimate a third; more means the diagnoser's estimate cannot be trusted."""
    pose_correct_sigma: ranged(0.0, 10.0) = 0.5
    """A declared pose offset is subtracted from later fixes when its σ (the larger axis) is at most this fraction
    of its length — the corrected fixes then keep at most half the displacement's error (RMS) — else the pose
    sensor is excluded. The built-in diagnoser declares a displacement at ≥ 3σ of the fix, with an offset σ a few
    times smaller, so its offsets are corrected."""
    stop: SafeStopSettings = Field(default_factory=SafeStopSettings)


class AccommodationMode(IntEnum):
    """The accommodation's state (trace column ``accommodation_mode``)."""

    NOMINAL = 0
    """Nothing declared."""
    ACCOMMODATED = 1
    """Faults declared and accommodated; the controller follows the path."""
    STOPPING = 2
    """Safe stop: braking along the path."""
    AT_REST = 3
    """Safe stop: the planned speed has reached 0."""


class Accommodation:
    """Maps the declared diagnoses to the loop (module docstring): :meth:`update` at every controller sample,
    then :meth:`correct` (readings), :meth:`controller_pose`, :meth:`command` (the safe stop) as the loop needs."""

    def __init__(self, settings: AccommodationSettings, stop: SafeStop) -> None:
        self.settings = settings
        self.stop = stop
        self.state = AccommodationMode.NOMINAL
        self.events: list[Event] = []
        self.effectiveness = np.ones(2)
        self.stop_reason: str | None = None
        self.corrections: dict[str, Diagnosis] = {}
        self.excluded: frozenset[str] = frozenset()
        self._dropouts: dict[str, Diagnosis] = {}  # excluded channel → the dropout declaration that excludes it
        self._returned: dict[str, float] = {}  # channel → declaration time (s) of the dropout it came back from
        self._pose_declared: set[float] = set()  # the declaration times (s) of the pose displacements seen
        self._pose_action = "none"
        self._pose_last: float | None = None
        self.tyres: dict[int, float] = {}
        """The declared tyre sizes (fraction of the nominal radius) per wheel (0 right, 1 left)."""
        self._stop_started = False
        self._declared: frozenset[tuple[str, str, str]] = frozenset()
        self.free: int | None = None
        """The wheel (0 right, 1 left) whose servo alone is declared unresponsive, else ``None``."""
        self.locked: int | None = None
        """The wheel (0 right, 1 left) alone declared locked, else ``None``."""

    @property
    def stopping(self) -> bool:
        """The safe stop is in force (from its entry to the end of the run)."""
        return self.stop_reason is not None

    def update(self, t: float, diagnoses: Sequence[Diagnosis]) -> bool:
        """Take the declarations in force at ``t`` (s); returns whether the actuator model changed (then hand it
        to the controller: :meth:`hand_actuator`)."""
        self._pose_changes(t, diagnoses)
        eff = np.ones(2)
        corrections: dict[str, Diagnosis] = {}
        excluded: set[str] = set()
        dropouts: dict[str, Diagnosis] = {}
        for d in diagnoses:
            if d.component == "servo":
                eff[_SIDE[d.target]] *= d.size if d.mode == "loss" else 0.0
            elif d.component in _CHANNEL:
                action = self._sensor_action(d, t)
                if action == "correct":
                    corrections[_CHANNEL[d.component]] = d
                elif action == "exclude":
                    excluded.add(_CHANNEL[d.component])
                    if d.mode == "dropout":
                        dropouts[_CHANNEL[d.component]] = d
            if self.stop_reason is None:
                self._check_stop(t, d)
        self.corrections, self.excluded, self._dropouts = corrections, frozenset(excluded), dropouts
        self.tyres = {_SIDE[d.target]: float(d.size) for d in diagnoses
                      if (d.component, d.mode) == ("tyre", "puncture")}
        free = [_SIDE[d.target] for d in diagnoses if (d.component, d.mode) == ("servo", "unresponsive")]
        self.free = free[0] if len(free) == 1 else None
        locked = [_SIDE[d.target] for d in diagnoses if (d.component, d.mode) == ("servo", "lock")]
        self.locked = locked[0] if len(locked) == 1 else None
        changed = not np.array_equal(eff, self.effectiveness)
        self.effectiveness = np.clip(eff, 0.0, 1.0)
        declared = frozenset(d.key for d in diagnoses)
        if not self.stopping and declared != self._declared:
            what = ", ".join(_describe(d, self._sensor_action(d, t)) for d in diagnoses) or "nothing declared"
            self._enter(AccommodationMode.ACCOMMODATED if diagnoses else AccommodationMode.NOMINAL, t,
                        "accommodation: " + what)
        self._declared = declared
        return changed

    def _sensor_action(self, d: Diagnosis, t: float) -> Literal["correct", "exclude", "none"]:
        """What a sensor declaration ``d`` does to its channel at ``t`` (s): a speed or gyro bias or drift is
        corrected; a pose bias or jump with a non-zero offset known to ``pose_correct_sigma`` of its length is
        corrected once declared ``pose_settle`` ago, excluded before; a pose offset of ``(0, 0)`` (a jump seen to
        return) does nothing; a dropout excludes the channel until the channel delivers again (:meth:`correct`),
        then does nothing; a pose offset unknown or too uncertain to subtract, or a pose sensor declared displaced
        more than ``pose_max_declarations`` times excludes the channel."""
        s = self.settings
        if d.mode == "dropout":
            return "none" if self._returned.get(_CHANNEL[d.component]) == d.declared else "exclude"
        if d.component != "pose sensor":
            return "correct" if d.mode in ("bias", "drift") else "exclude"
        if d.offset is None or len(self._pose_declared) > s.pose_max_declarations:
            return "exclude"
        length = float(np.hypot(*d.offset))
        if length == 0.0:
            return "none"
        if t + 1e-9 < d.declared + s.pose_settle:
            return "exclude"
        return "correct" if max(d.offset_sigma) <= s.pose_correct_sigma * length else "exclude"

    def _pose_changes(self, t: float, diagnoses: Sequence[Diagnosis]) -> None:
        """Count the pose displacements declared so far and log an event when what is done with the pose fixes
        changes without a new declaration (a settled offset corrected from now on)."""
        pose = [d for d in diagnoses if d.component == "pose sensor"]
        self._pose_declared.update(d.declared for d in pose if d.mode != "dropout")
        action = self._sensor_action(pose[0], t) if pose else "none"
        same = bool(pose) and pose[0].declared == self._pose_last  # (a new declaration has its own events)
        back = bool(pose) and pose[0].mode == "dropout"  # a dropout's end has its own event (:meth:`correct`)
        if action != self._pose_action and same and not back and not self.stopping:
            self.events.append(Event(t, "warn", "accommodation: " + _describe(pose[0], action)))
        self._pose_action, self._pose_last = action, pose[0].declared if pose else None

    def radii(self, radii: np.ndarray, nominal: float) -> np.ndarray:
        """The radii [R_R, R_L] (m) for the controller: the policy's ``radii``, or with ``tyre = "diagnosis"`` the
        declared size × ``nominal`` (m) for each wheel whose tyre is declared punctured. With ``policy`` a declared
        tyre whose radius the policy still holds at ``nominal`` (its decision rule has not isolated the wheel: a 5 %
        puncture) takes the declared size too — the nominal radius of a tyre declared smaller is a yaw-rate error
        of the model (95 % tyre, gyro, dev seeds 0–1: lift-off 0.6–1.0 s and 0.28 m with it, none and 0.02 m
        without)."""
        if not self.tyres:
            return radii
        out = np.array(radii, dtype=float)
        for i, size in self.tyres.items():
            if self.settings.tyre == "diagnosis" or out[i] >= nominal:
                out[i] = nominal * size
        return out

    def isolation(self, decision: DecisionState | None) -> DecisionState | None:
        """The fault decision as the reconfiguration policy is to read it: where the decision has declared a fault and
        isolated a wheel, every wheel whose tyre is declared punctured counts as isolated too. The policy conditions
        an isolated wheel's radius on the other being nominal (``condition_on_healthy``): after a second puncture,
        while the decision still isolates the first wheel, that put the first wheel's radius below its tyre by the
        second's drop (ftc-v2 dev draw 111, no gyro: handed 0.65 m for a 1.11 m tyre, regained at the growth
        limit over 9 s, 7.9 m off the path), which the diagnoser's declaration of the second tyre rules out."""
        if decision is None or not decision.detected or not self.tyres:
            return decision
        isolated = {i for i, on in enumerate(ISOLATED.get(decision.wheel or "", ())) if on}
        if not isolated or isolated >= set(self.tyres):
            return decision
        return dataclasses.replace(decision, wheel="both")  # one wheel isolated, the other's tyre declared

    def hand_actuator(self, t: float, controller: Any) -> None:
        """Give ``controller`` the actuator model (servo effectiveness per wheel) in force at ``t`` (s), with an
        event; a controller without one (no ``set_actuator_effectiveness``) is left as it is, and the event
        says so."""
        eR, eL = self.effectiveness
        what = f"servo effectiveness R {eR:.0%}, L {eL:.0%}"
        if hasattr(controller, "set_actuator_effectiveness"):
            controller.set_actuator_effectiveness(self.effectiveness.copy())
            self.events.append(Event(t, "warn", f"accommodation: the controller's actuator model changed: {what}"))
        else:
            self.events.append(Event(t, "warn", f"accommodation: {what}; the controller has no actuator model "
                                                "(unchanged)"))

    def _check_stop(self, t: float, d: Diagnosis) -> None:
        """Enter the safe stop if declaration ``d`` leaves the path out of reach."""
        s = self.settings
        why = None
        if d.component == "servo" and d.mode in ("lock", "unresponsive"):
            why = f"{d.target} servo {d.mode} declared at {d.declared:.2f} s: that wheel cannot steer the robot"
        elif d.component == "servo" and d.size <= s.stop_effectiveness:
            why = (f"{d.target} servo at {d.size:.0%} effectiveness (≤ {s.stop_effectiveness:.0%}) declared at "
                   f"{d.declared:.2f} s: too weak to follow the path")
        elif d.component == "tyre" and d.size <= s.stop_radius_fraction:
            why = (f"{d.target} tyre at {d.size:.0%} of its radius (≤ {s.stop_radius_fraction:.0%}) declared at "
                   f"{d.declared:.2f} s: too small to follow the path")
        if why is not None:
            self.stop_reason = why
            self._enter(AccommodationMode.STOPPING, t, f"safe stop: {why}", "error")

    def _enter(self, state: AccommodationMode, t: float, text: str, level: str = "warn") -> None:
        """Switch to ``state`` at ``t`` (s), with an event (the caller calls it when the state or the set of
        declarations changes)."""
        self.state = state
        self.events.append(Event(t, level if state != AccommodationMode.NOMINAL else "info", text))

    def correct(self, t: float, z: Measurement) -> Measurement:
        """The readings at ``t`` (s) with the diagnosed offsets removed (a pose fix's position less the declared
        displacement ``(dx, dy)``, m) and the excluded channels absent. A channel excluded for a dropout that
        delivers a reading has come back: the dropout has ended (an event), and the reading is taken, as every
        later one (the truth withdraws a dropout at its end in the same way: :mod:`.oracle`)."""
        for channel, d in list(self._dropouts.items()):
            if getattr(z, channel) is not None:
                self._returned[channel] = d.declared
                del self._dropouts[channel]
                self.excluded = self.excluded - {channel}
                if not self.stopping:
                    self.events.append(Event(t, "warn", f"accommodation: {_describe(d, 'none')}"))
        if not self.corrections and not self.excluded:
            return z
        values: dict[str, Any] = {}
        for channel, d in self.corrections.items():
            v = getattr(z, channel)
            if v is None:
                continue
            if channel == "position":  # the fix's (x, y) less the declared displacement; its heading untouched
                values[channel] = np.asarray(v, dtype=float) - np.asarray(d.offset, dtype=float)
            else:
                values[channel] = v - (d.size if d.mode == "bias" else d.size * max(t - d.onset, 0.0))
        for channel in self.excluded:
            values[channel] = None
        return dataclasses.replace(z, **values)

    def controller_pose(self, pose: np.ndarray, out: FilterOutput | None) -> np.ndarray:
        """The pose the controller is given: the sensors' ``pose``, or the filter's estimate when the pose
        sensor is excluded (and a filter runs)."""
        if "position" in self.excluded and out is not None:
            return np.asarray(out.x[:3], dtype=float)
        return pose

    def command(self, t: float, pose: np.ndarray, radii: np.ndarray, u_applied: np.ndarray | None,
                rates: np.ndarray | None = None) -> ControlOutput:
        """The safe stop's command at ``t`` (s) (only while :attr:`stopping`): the first call starts the braking
        profile from the speed of the command in force (m/s, with ``radii``); with one servo declared
        unresponsive its wheel, turning at the measured ``rates`` (rad/s), is left free and the other steers; with
        one wheel declared locked the other brakes at its torque limit and steers
        (:meth:`~ftc_mj.control.stop.SafeStop.solve`)."""
        if not self._stop_started:
            speed = 0.0 if u_applied is None else 0.5 * float(np.asarray(radii, float) @ np.asarray(u_applied, float))
            self.stop.begin(t, speed)
            self._stop_started = True
        if self.state == AccommodationMode.STOPPING and t + 1e-9 >= self.stop.rest_time():
            self._enter(AccommodationMode.AT_REST, t, f"safe stop: planned speed 0 at {t:.2f} s", "info")
        return self.stop.solve(t, pose, radii, u_applied, self.free, rates, self.locked)


def _describe(d: Diagnosis, sensor: str) -> str:
    """``left servo loss (30%): effectiveness to the actuator model``: one declaration in an event, with what is done
    about it (``sensor``: :meth:`Accommodation._sensor_action` for a sensor's)."""
    size = f"{d.size:.0%}" if d.component in ("tyre", "servo") else f"{d.size:.3g}"
    if d.component == "tyre":
        action = "radii by the policy"
    elif d.component == "servo":
        action = "effectiveness to the actuator model" if d.mode == "loss" else "safe stop"
    elif sensor == "correct":
        action = ("reading corrected" if d.offset is None else
                  f"fixes corrected by ({d.offset[0]:.3g}, {d.offset[1]:.3g}) m")
    elif sensor == "none" and d.mode == "dropout":
        action = "delivers again: " + ("fixes" if d.component == "pose sensor" else "readings") + " taken as they come"
    elif sensor == "none":
        action = "returned: fixes taken as they come"
    else:
        action = "excluded from the filter" + (" and the controller's pose" if d.component == "pose sensor" else "")
    return f"{d.target} {d.component} {d.mode} ({size}): {action}"
