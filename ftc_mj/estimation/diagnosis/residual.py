"""The built-in diagnoser: structured residuals, each sensitive to one component, a windowed GLR on each,
and an isolation table that reads which residuals fired (Gertler's structured residuals; the
window-limited GLR of Willsky & Jones and Basseville & Nikiforov §2.4; the residual table of Blanke et al.
ch. 6). docs/fdi.md says why this design and what each channel can and cannot see.

Every residual compares two measurements that a healthy robot makes agree, against a reference that no
other fault moves:

- ``tyre_R``/``tyre_L``: the arc each wheel's contact point rolled between two pose fixes
  (``s ± b Δψ``) over the angle its encoder turned (``R0 Δθ``) — its rolling ratio, a fraction of the
  nominal radius — after a candidate change against the window before it: a puncture only;
- ``servo_R``/``servo_L``: a step of the wheel's lag behind its command at unchanged wheel rates, the other
  wheel's lag unchanged (:mod:`.servo`: the same motion carries the same load, so the lag ratio is the gain
  ratio); else the gain ``α`` of the wheel's response to its command (the regression
  ``Δω_k = α (ω_cmd − ω)_{k−1} − β``) after a candidate change over the gain before it: a servo loss or an
  unresponsive servo only (a puncture raises it);
- ``lock_R``/``lock_L``: the wheel turns at under ``lock_ratio`` of its command;
- ``speed``: the speed sensor's mean reading minus the pose's arc per second; ``gyro``: the gyro's mean
  minus the pose's heading change per second: the sensor's own faults only;
- ``speed_dropout``/``gyro_dropout``: how long the sensor has delivered nothing;
- ``pose``: a displacement of the pose fixes against the track dead-reckoned from the encoders
  (:mod:`.pose`); ``pose_dropout``: how long the pose sensor has delivered no fix, in its own intervals.

The GLR of a mean shift ``D`` of variance ``σ²`` is ``D² / (2 σ²)``, maximised over the candidate change
times :attr:`~.settings.ResidualDiagnoserSettings.windows` before the latest pose fix; σ² is the noise of
the sensors involved (from their configured σ) plus a model floor relative to the nominal quantity.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ...context import RunContext
from ...model.diagnosis import Diagnosis
from .base import CHANNELS, DiagnosisInput, DiagnosisStep
from .change import TyreChangeAlarm
from .history import History
from .pose import PoseStep, fix_interval, step_glr
from .servo import LagStep, LagSums, comparable, lag_step
from .settings import ResidualDiagnoserSettings
from .shape import ShapeFit, shape_fit

WHEEL_SIDES = {"R": "right", "L": "left"}


@dataclass(frozen=True, slots=True)
class Reading:
    """One channel's verdict at a step: its statistic and threshold, and what a declaration would say."""

    stat: float
    threshold: float
    size: float = float("nan")
    sigma: float = float("nan")
    onset: float = float("nan")
    reference: float = 1.0
    """A tyre's rolling ratio before the change, which its size is relative to."""

    @property
    def alarm(self) -> bool:
        """The statistic lies above its threshold."""
        return bool(self.stat > self.threshold)


QUIET = Reading(0.0, math.inf)
"""A channel with nothing to say this step (no data, or not applicable)."""


def _physical(size: float) -> bool:
    """A tyre size (fraction of the nominal radius) a tyre can have: finite, above 0 and at most 1."""
    return math.isfinite(size) and 0.0 < size <= 1.0


class ResidualDiagnoser:
    """The structured-residual diagnoser (module docstring) for the robot of ``context``.

    Args:
        settings: its settings (:class:`~.settings.ResidualDiagnoserSettings`).
        context: the run context: the nominal radius and half track, the estimator period, the sensors' σ.
        change: the fast tyre detector (:mod:`.change`; the ``tyre_change`` channel), ``None``: that channel
            stays quiet.
    """

    def __init__(self, settings: ResidualDiagnoserSettings, context: RunContext,
                 change: TyreChangeAlarm | None = None) -> None:
        self.settings = settings
        self.change = change
        self.R0 = float(context.nominal_radii[0])
        self.b = float(context.half_track)
        self.dt = float(context.estimator_dt)
        self.omega_max = float(context.omega_max)
        sensors = context.sensors
        self.sigma_v = float(getattr(sensors, "speed_sigma", 0.5))
        gyro = getattr(sensors, "yaw_rate_sigma", None)
        self.sigma_g = None if gyro is None else float(gyro)
        self.history = History(self.dt)
        self.lags = LagSums(self.history)
        self.load_steps: dict[str, tuple[float, LagStep | None]] = {"R": (-math.inf, None), "L": (-math.inf, None)}
        self.readings: dict[str, Reading] = {c: QUIET for c in CHANNELS}
        self.since: dict[str, float | None] = {c: None for c in CHANNELS}
        self.missing = {"speed": 0.0, "gyro": 0.0}
        self.refit = {"speed": 0.0, "gyro": 0.0}
        self.tyre_reference = {"R": 1.0, "L": 1.0}
        self.next_glr = 0.0
        self.declared: list[Diagnosis] = []
        self.pose_sigma = (self.R0 * settings.pose_floor, settings.pose_floor)
        self._pairs_at: tuple[int, list[tuple[int, int, int | None]]] = (-1, [])  # (fixes, pairs): :meth:`_pairs`
        self.pose_step: PoseStep | None = None
        self._interval: tuple[int, float | None] = (0, None)  # (fixes seen, the pose sensor's median interval)
        self.pose_rms: list[float] = []  # the pose window's RMS model residual (m) at each evaluation

    # ---------------------------------------------------------------- the step
    def step(self, z: DiagnosisInput) -> DiagnosisStep:
        """Add the measurements of this step, update every channel, declare what the alarms isolate."""
        h = self.history
        pose = z.pose
        if pose is not None and self.settings.pose_rate is not None:
            if h.fix_t and z.t < h.fix_t[-1] + 1.0 / self.settings.pose_rate - 1e-9:
                pose = None  # not due yet at pose_rate
        h.push(z.t, np.asarray(z.omega, float), z.command, z.speed, z.yaw_rate, pose)
        self.lags.push(z.omega, z.command)
        floor_p, floor_psi = self.R0 * self.settings.pose_floor, self.settings.pose_floor
        self.pose_sigma = (max(z.pose_sigma, floor_p), max(z.pose_sigma, floor_psi))
        self._dropouts(z)
        for side in "RL":
            self.readings[f"lock_{side}"] = self._lock(side)
            self.readings[f"servo_{side}"] = self._servo(side)
        if h.fix_steps and h.fix_steps[-1] == h.k and z.t >= self.next_glr - 1e-9:  # with a new fix only,
            self.next_glr = z.t + self.settings.glr_period                              # every glr_period
            for side in "RL":
                self.readings[f"tyre_{side}"] = self._tyre(side)
            self.readings["speed"] = self._sensor("speed")
            self.readings["gyro"] = self._sensor("gyro") if self.sigma_g is not None else QUIET
            self.readings["pose"] = self._pose()
        self.readings["pose_dropout"] = self._pose_dropout(z.t)
        if self.change is not None:
            self.readings["tyre_change"] = Reading(*self.change.step(z))
        alarms = {c: r.alarm for c, r in self.readings.items()}
        since = self.since
        for c, alarm in alarms.items():
            if not alarm:
                since[c] = None
            elif since[c] is None:
                since[c] = z.t
        if self._quiet(alarms):
            return DiagnosisStep(statistics={c: r.stat for c, r in self.readings.items()}, alarms=alarms, new=[],
                                 declared=list(self.declared))
        new = self._isolate(z.t)  # (a declaration may read a channel again: the alarms after it are reported)
        self.declared.extend(new)
        if self.change is not None and new:
            self.change.anchor(z.radii)  # matched again to "no further change" (its readings now corrected)
        return DiagnosisStep(statistics={c: r.stat for c, r in self.readings.items()},
                             alarms={c: r.alarm for c, r in self.readings.items()}, new=new,
                             declared=list(self.declared))

    # ---------------------------------------------------------------- the channels
    def _dropouts(self, z: DiagnosisInput) -> None:
        """How long (s) the speed sensor and the gyro have delivered nothing."""
        s = self.settings
        for name, value, present in (("speed", z.speed, True), ("gyro", z.yaw_rate, self.sigma_g is not None)):
            missing = present and (value is None or not math.isfinite(value))
            self.missing[name] = self.missing[name] + self.dt if missing else 0.0
            onset = z.t - self.missing[name] + self.dt
            self.readings[f"{name}_dropout"] = (Reading(self.missing[name], s.dropout_min - 1e-9,
                                                        self.missing[name], 0.0, onset)
                                                if present else QUIET)

    def _pose_dropout(self, t: float) -> Reading:
        """How long (s) the pose sensor has delivered no fix, against ``pose_dropout_intervals`` of its interval
        (at least ``dropout_min``)."""
        h, s = self.history, self.settings
        if self._interval[0] != len(h.fix_t):  # the median interval again only with a new fix
            self._interval = (len(h.fix_t), fix_interval(h))
        interval = self._interval[1]
        if interval is None:
            return QUIET
        missing = t - h.fix_t[-1]
        return Reading(missing, max(s.dropout_min, s.pose_dropout_intervals * interval) - 1e-9, missing, 0.0,
                       h.fix_t[-1] + interval)

    def _pose(self) -> Reading:
        """The GLR of a displacement of the pose fixes over the last ``pose_window`` (s) (:func:`.pose.step_glr`,
        the fix's σ at least the median RMS residual of the windows so far), 0 for a displacement under
        ``pose_min_offset`` σ or one that came with a change of the encoders' yaw rate against the fixes'
        headings (a wheel's fault); the size: the displacement along the fault library's diagonal
        (``(dx + dy) / √2``, m)."""
        s, h = self.settings, self.history
        a = h.fix_at(h.fix_t[-1] - s.pose_window)
        sigma = max(self.pose_sigma[0], float(np.median(self.pose_rms)) if self.pose_rms else 0.0)
        step = None if a is None else step_glr(h, a, len(h.fix_t) - 1, (self.R0, self.b),
                                                     (sigma, self.pose_sigma[1]), s.pose_recent)
        self.pose_step = step
        if step is None:
            return QUIET
        self.pose_rms.append(step.rms)
        del self.pose_rms[:-s.pose_rms_count]
        small = math.hypot(*step.offset) < s.pose_min_offset * sigma or step.turn > s.threshold  # or a wheel
        size = (step.offset[0] + step.offset[1]) * math.sqrt(0.5)
        return Reading(0.0 if small else step.stat, s.pose_threshold, size, step.sigma, step.onset)

    def _lock(self, side: str) -> Reading:
        """``1 − |mean ω| / |mean command|`` over the last ``lock_window`` (s) of wheel ``side``."""
        s, h = self.settings, self.history
        j = h.step_at(h.t[-1] - s.lock_window)
        if j is None or j == h.k:
            return QUIET
        n = h.delta("n_cmd", j, h.k)
        if n < 1:
            return QUIET
        cmd = h.delta(f"cmd_{side}", j, h.k) / n
        turn = abs(h.delta(f"th_{side}", j, h.k)) / (h.t[-1] - h.t[j])
        if cmd < s.lock_min_command * self.omega_max:
            return QUIET
        return Reading(1.0 - turn / cmd, 1.0 - s.lock_ratio, 0.0, 0.0, h.t[-1] - s.lock_window)

    def _servo(self, side: str) -> Reading:
        """The servo channel: the load test's lag step (:mod:`.servo`, evaluated every ``glr_period``) when its
        GLR exceeds ``threshold`` and it says at least ``servo_min_loss`` of the gain was lost — the size its gain
        ratio — else the regression's reading (:meth:`_servo_regression`)."""
        s, h = self.settings, self.history
        at, found = self.load_steps[side]
        if h.t[-1] >= at + s.glr_period - 1e-9:
            found = lag_step(s, self.lags, h.t, side, h.step_at)
            self.load_steps[side] = (h.t[-1], found)
        if found is not None and found.glr > s.threshold and 1.0 - found.ratio >= s.servo_min_loss:
            return Reading(1.0 - found.ratio, s.servo_min_loss - 1e-9, found.ratio, found.sigma, found.onset)
        return self._servo_regression(side)

    def _servo_regression(self, side: str) -> Reading:
        """``1 − g_after / g_before``: the fraction of the servo's gain lost over the last ``servo_window`` (s)
        against the ``reference_window`` before it. The gain is the regression's α while the command excites
        the wheel (the variance of ``ω_cmd − ω`` in the reference window above ``servo_min_excitation``);
        on a steady command, the inverse of the mean lag ``ω_cmd − ω`` (a servo of gain ``e k_v`` lags a
        steady load ``τ`` by ``τ / (e k_v)``)."""
        s, h = self.settings, self.history
        k = h.k
        j = h.step_at(h.t[-1] - s.servo_window)
        # the reference window starts after the launch from rest (whose gain differs) and lasts at least
        # as long as the test window
        i = h.step_at(max(h.t[-1] - s.servo_window - s.reference_window, s.launch))
        if i is None or j is None or h.t[j] - h.t[i] < s.servo_window - 1e-9:
            return QUIET
        after, before = h.regression(side, j, k), h.regression(side, i, j)
        if after is None or before is None:
            return QUIET
        lag_before = h.delta(f"lag_{side}", i, j) / max(h.delta("n_cmd", i, j), 1.0)
        lag_after = h.delta(f"lag_{side}", j, k) / max(h.delta("n_cmd", j, k), 1.0)
        # a servo that lost gain lags the same load more: without that, a change of α is the loop's (a dither)
        grew = lag_before * lag_after > 0.0 and abs(lag_after) > s.servo_lag_growth * abs(lag_before)
        if not grew:
            ratio, size = 1.0, 1.0
        elif before[1] >= s.servo_min_excitation and before[0] > 0.0:
            ratio = after[0] / before[0]
            size = float(np.clip(ratio, 0.0, 1.0)) ** s.servo_size_exponent
        elif not self._comparable(side, i, j, k):  # one load at one motion, and a load to carry
            ratio, size = 1.0, 1.0
        else:
            ratio = size = lag_before / lag_after
        onset = h.t[j] if self.since[f"servo_{side}"] is None else self.since[f"servo_{side}"] - 0.5 * s.servo_window
        return Reading(1.0 - ratio, 1.0 - s.servo_ratio, size, float("nan"), onset)

    def _comparable(self, side: str, i: int, j: int, k: int) -> bool:
        """Wheel ``side``'s mean lags over the steps ``(i, j]`` and ``(j, k]`` compare as its servo's gain
        (:func:`.servo.comparable`, the load test's gates): on a steady command after a cruise that loaded the
        wheel with nothing, a correction of the path grows the lag many times over (ftc-v2 dev draw 76: 0.0001 →
        0.005 rad/s at 4.4 rad/s, read as a servo left with 2 % of its gain)."""
        before, after = self.lags.window(i, j), self.lags.window(j, k)
        return before is not None and after is not None and comparable(self.settings, side, before, after)

    def _dead(self, side: str) -> bool:
        """The wheel lags its command by more than ``unresponsive_lag`` of it over the last ``servo_window``:
        no torque follows the command (a lossy servo's lag stays bounded by its reduced torque)."""
        s, h = self.settings, self.history
        j = h.step_at(h.t[-1] - s.servo_window)
        if j is None or j == h.k:
            return False
        n = max(h.delta("n_cmd", j, h.k), 1.0)
        cmd = h.delta(f"cmd_{side}", j, h.k) / n
        return cmd > 0.0 and abs(h.delta(f"lag_{side}", j, h.k)) / n > s.unresponsive_lag * cmd

    def _window_pairs(self) -> list[tuple[int, int, int | None]]:
        """``(j, k, i)`` pose-fix indices of each GLR window: the latest fix ``k``, the fix ``j`` a window
        before it, the fix ``i`` a ``reference_window`` before ``j`` (``None`` before the run has one);
        longest window first, each at most once."""
        s, h = self.settings, self.history
        k = len(h.fix_t) - 1
        out, seen = [], set()
        for w in sorted(s.windows, reverse=True):
            j = h.fix_at(h.fix_t[k] - w)
            if j is None or j >= k or j in seen or h.fix_t[k] - h.fix_t[j] < 0.5 * w:
                continue
            seen.add(j)
            out.append((j, k, h.fix_at(h.fix_t[j] - s.reference_window)))
        return out

    def _pairs(self) -> list[tuple[int, int, int | None]]:
        """:meth:`_window_pairs`, computed once per pose fix (the GLRs of every channel at a fix share them)."""
        n = len(self.history.fix_t)
        if self._pairs_at[0] != n:
            self._pairs_at = (n, self._window_pairs())
        return self._pairs_at[1]

    def _ratio(self, side: str, j: int, k: int) -> tuple[float, float] | None:
        """The rolling ratio (fraction of nominal radius) of wheel ``side`` between pose fixes ``j`` and
        ``k`` and its variance from the pose noise; ``None`` when the wheel turned too little."""
        h = self.history
        turn = h.delta(f"th_{side}", h.fix_steps[j], h.fix_steps[k])
        if abs(turn) < self.settings.tyre_min_turn:
            return None
        arc, dpsi = h.motion(j, k)
        sign = 1.0 if side == "R" else -1.0
        sp, spsi = self.pose_sigma
        var = (2.0 * sp**2 + 2.0 * (self.b * spsi) ** 2) / (self.R0 * turn) ** 2
        return (arc + sign * self.b * dpsi) / (self.R0 * turn), var

    def _glr(self, shift: Callable[[int, int, int | None], Reading | None]) -> Reading:
        """The largest of ``shift(j, k, i)`` — one candidate change's reading — over the candidate windows
        (:meth:`_window_pairs`): the window-limited GLR."""
        best = Reading(0.0, self.settings.threshold)
        for j, k, i in self._pairs():
            r = shift(j, k, i)
            if r is not None and r.stat > best.stat:
                best = r
        return best

    def _tyre(self, side: str) -> Reading:
        """The GLR of a drop of wheel ``side``'s rolling ratio against the window before the change."""
        s, h = self.settings, self.history
        # a punctured tyre tilts the chassis, which moves the other tyre's contact point: a larger drop needed
        min_drop = s.tyre_min_drop_second if self._has("tyre") is not None else s.tyre_min_drop

        def shift(j: int, k: int, i: int | None) -> Reading | None:
            after = self._ratio(side, j, k)
            if after is None:
                return None
            before = self._ratio(side, i, j) if i is not None and i < j else None
            # a skidding wheel rolls more than a turn's worth (a ratio above 1): the reference is capped at
            # the nominal radius, so the end of a skid is not a drop
            ref, var_ref = (min(before[0], 1.0), before[1]) if before is not None else (1.0, (3.0 * s.tyre_floor) ** 2)
            drop = after[0] - ref
            var = after[1] + var_ref + s.tyre_floor**2
            stat = drop**2 / (2.0 * var) if drop < -min_drop else 0.0
            # the size: the ratio since the change, relative to the one before
            return Reading(stat, s.threshold, after[0] / ref, math.sqrt(var), h.fix_t[j], ref)

        return self._glr(shift)

    def residual(self, name: str, j: int, k: int) -> tuple[float, float] | None:
        """The ``speed`` (m/s) or ``gyro`` (rad/s) residual between pose fixes ``j`` and ``k``: the sensor's
        mean minus the pose's rate, with its variance; ``None`` without samples."""
        h = self.history
        a, b = h.fix_steps[j], h.fix_steps[k]
        key, sig = ("v", self.sigma_v) if name == "speed" else ("g", self.sigma_g or 0.0)
        n = h.delta(f"n_{key}", a, b)
        if n < 5:
            return None
        span = h.fix_t[k] - h.fix_t[j]
        arc, dpsi = h.motion(j, k)
        ref, sp = (arc / span, self.pose_sigma[0]) if name == "speed" else (dpsi / span, self.pose_sigma[1])
        floor = (self.settings.speed_floor if name == "speed" else self.settings.gyro_floor) * abs(ref)
        var = sig**2 / n + 2.0 * sp**2 / span**2 + floor**2
        return h.delta(key, a, b) / n - ref, var

    def _sensor(self, name: str) -> Reading:
        """The GLR of an offset of the ``speed`` sensor or the ``gyro`` over the candidate windows."""
        s, h = self.settings, self.history

        def shift(j: int, k: int, i: int | None) -> Reading | None:
            r = self.residual(name, j, k)
            return None if r is None else Reading(r[0] ** 2 / (2.0 * r[1]), s.threshold, r[0], math.sqrt(r[1]),
                                                  h.fix_t[j])

        return self._glr(shift)

    # ---------------------------------------------------------------- isolation
    def _confirmed(self, channel: str, t: float) -> bool:
        """The channel's alarm has held for ``confirm`` (``servo_confirm`` for a servo, ``lock_confirm`` for a lock)
        seconds."""
        since = self.since[channel]
        s = self.settings
        hold = s.servo_confirm if channel.startswith("servo") else s.lock_confirm if channel.startswith("lock") \
            else s.confirm
        return since is not None and t - since >= hold - 1e-9

    def _has(self, component: str, target: str | None = None) -> Diagnosis | None:
        """The latest declaration on ``component`` (and ``target``), if any."""
        for d in reversed(self.declared):
            if d.component == component and (target is None or d.target == target):
                return d
        return None

    def _quiet(self, alarms: dict[str, bool]) -> bool:
        """Nothing can be declared at this step: no channel is in alarm and nothing has been declared before —
        every declaration of :meth:`_isolate` needs a confirmed alarm (a channel in alarm now) or an earlier
        declaration that it updates. A shortcut for the cost of a step (most steps of a run are quiet); a
        declaration rule added to :meth:`_isolate` that needs neither must change this too
        (tests/estimation/test_history_reference.py runs the diagnoser with and without it)."""
        return not self.declared and not any(alarms.values())

    def _isolate(self, t: float) -> list[Diagnosis]:
        """At most one new declaration per step, from the confirmed alarms, in the order: dropouts, lock,
        servo, tyre, speed sensor, gyro (the isolation table of docs/fdi.md)."""
        for maker in (self._declare_dropout, self._declare_pose, self._declare_servo, self._declare_tyre,
                      self._declare_sensor):
            if maker in (self._declare_tyre, self._declare_sensor) and self._pose_first():
                continue  # a displaced fix moves the arc and the heading the tyres' and sensors' residuals read
            d = maker(t)
            if d is not None:
                return [d]
        return []

    def _make(self, component: str, target: str, mode: str, r: Reading, t: float, **vector: object) -> Diagnosis:
        """The declaration of ``r`` at ``t`` (s); ``vector``: a pose offset and its σ per axis (m)."""
        return Diagnosis(component, target, mode, float(r.size), float(r.sigma), float(min(r.onset, t)), t,
                         float(r.stat), float(r.threshold), **vector)

    def _declare_dropout(self, t: float) -> Diagnosis | None:
        for name, component, target in (("speed", "speed sensor", "speed"), ("gyro", "gyro", "yaw_rate")):
            r = self.readings[f"{name}_dropout"]
            last = self._has(component)
            if r.alarm and (last is None or last.mode != "dropout" or last.onset < r.onset - 1e-9):
                return self._make(component, target, "dropout", r, t)
        return None

    def _pose_first(self) -> bool:
        """The pose channel's alarm is up and no tyre alarm came before it."""
        p = self.since["pose"]
        tyres = [self.since[f"tyre_{side}"] for side in "RL"]
        return p is not None and not any(s is not None and s < p - 1e-9 for s in tyres)

    def _pose_blocked(self) -> bool:
        """No pose displacement is declared after a tyre or servo fault (the dead-reckoned track then rolls on a
        wheel that no longer measures the travel), while a lock or servo alarm is up, or after a tyre alarm that
        came before the pose's."""
        if self._has("tyre") is not None or self._has("servo") is not None:
            return True
        if any(self.readings[f"{c}_{side}"].alarm for c in ("lock", "servo") for side in "RL"):
            return True
        return self.since["pose"] is not None and not self._pose_first()

    def _declare_pose(self, t: float) -> Diagnosis | None:
        """A pose-sensor dropout at once; a displacement of its fixes once confirmed: a ``bias``, taken off the
        fixes from its onset on (:meth:`.history.History.shift_fixes`) — or, when it takes a declared bias back
        (the total displacement left is under half the declared one), a ``jump`` of the declared bias's size
        and onset, whose correction is withdrawn (the fixes from the return on are taken as they come). The
        record's :attr:`~ftc_mj.model.diagnosis.Diagnosis.offset` is the total displacement taken off the fixes
        from now on (``(0, 0)`` after a jump's return), with the latest step's σ per axis: the fixes are tested
        again with it taken off, so a later step re-estimates it."""
        r = self.readings["pose_dropout"]
        last = self._has("pose sensor")
        if r.alarm and (last is None or last.mode != "dropout" or last.onset < r.onset - 1e-9):
            return self._make("pose sensor", "pose", "dropout", r, t)
        step = self.pose_step
        if not self._confirmed("pose", t) or step is None or step.alone is None or self._pose_blocked():
            return None
        h, alone = self.history, step.alone
        before = h.fix_offset
        total = (before[0] + alone.offset[0], before[1] + alone.offset[1])
        returned = last is not None and last.mode == "bias" and math.hypot(*total) < 0.5 * math.hypot(*before)
        h.shift_fixes(alone.fix, (-before[0], -before[1]) if returned else alone.offset)
        self.pose_step = None
        for c in ("pose", "tyre_R", "tyre_L", "speed", "gyro"):  # read again from the corrected fixes
            self.readings[c], self.since[c] = QUIET, None
        vector = {"offset": h.fix_offset, "offset_sigma": alone.axis_sigma}
        if returned:
            return self._make("pose sensor", "pose", "jump", Reading(step.stat, self.settings.pose_threshold, last.size,
                                                                    last.sigma, last.onset), t, **vector)
        size = (total[0] + total[1]) * math.sqrt(0.5)
        return self._make("pose sensor", "pose", "bias", Reading(step.stat, self.settings.pose_threshold, size,
                                                                alone.sigma, alone.onset), t, **vector)

    def _declare_servo(self, t: float) -> Diagnosis | None:
        """A lock, else a servo loss or an unresponsive servo (re-declared as such if a loss's wheel stops
        following its command); one servo fault per run (a lock or a dead servo drags the robot so that the
        other servo's regression moves too). After a puncture a lock still (a wheel at rest under its command is
        a lock whatever its tyre), but no servo loss: the puncture changes the wheel-chassis coupling the servo
        regression identifies. Nor while the fast tyre detector (``tyre_change``) is in alarm: its residual takes
        the measured wheel rates as inputs, so a servo's gain does not move it, while a tyre shrinking under the
        wheel changes the wheel's lag and its response to the command as a weaker servo would (a puncture ramp
        read as an unresponsive servo 0.75 s after its onset, dev draw 239 of ftc-v2, before the rolling-ratio
        channel could confirm the tyre)."""
        last = self._has("servo")
        if last is not None and last.mode == "loss" and self._dead(last.target[0].upper()):
            return self._make("servo", last.target, "unresponsive",
                              Reading(last.statistic, last.threshold, 0.0, last.sigma, last.onset), t)
        if last is not None:
            return None
        for side in "RL":
            if self._confirmed(f"lock_{side}", t):
                return self._make("servo", WHEEL_SIDES[side], "lock", self.readings[f"lock_{side}"], t)
        if self._has("tyre") is not None or self.readings["tyre_change"].alarm:
            return None  # a radius changing now explains a lag change as well as a servo does (docstring)
        for side in "RL":
            r = self.readings[f"servo_{side}"]
            if self._confirmed(f"servo_{side}", t) and not self.readings[f"tyre_{side}"].alarm:
                dead = r.size < self.settings.unresponsive_below or self._dead(side)
                mode = "unresponsive" if dead else "loss"
                size = 0.0 if mode == "unresponsive" else r.size
                return self._make("servo", WHEEL_SIDES[side], mode, Reading(r.stat, r.threshold, size, r.sigma,
                                                                              r.onset), t)
        return None

    def _declare_tyre(self, t: float) -> Diagnosis | None:
        """A puncture (see :meth:`_isolate`), or a declared one's size again when its rolling ratio has dropped
        by ``tyre_min_drop`` and 3σ since (a step puncture's tyre settles over about a second; a ramp goes on)."""
        for side in "RL":
            target = WHEEL_SIDES[side]
            last = self._has("tyre", target)
            if last is not None:
                update = self._tyre_update(side, last, t)
                if update is not None:
                    return update
                continue
            if self.readings[f"lock_{side}"].alarm:
                continue
            servo = self._has("servo")
            if servo is not None and servo.mode != "loss":
                continue  # a dragged wheel skids: its rolling ratio says nothing of its tyre
            r = self.readings[f"tyre_{side}"]
            if self._confirmed(f"tyre_{side}", t) and _physical(r.size):
                self.tyre_reference[side] = r.reference
                return self._make("tyre", target, "puncture", r, t)
        return None

    def _tyre_update(self, side: str, last: Diagnosis, t: float) -> Diagnosis | None:
        """``last``'s puncture with the size of the wheel's rolling ratio over the last ``tyre_update_window``
        (s), relative to the one before the change, when it is below ``last``'s by ``tyre_min_drop`` and 3σ;
        at most once per ``tyre_update_window``. A ratio that leaves the physical range (0, 1] — the wheel turns
        one way while the contact point rolls the other or not at all: a spin or a skid once the loop has lost
        the path, not a tyre — says nothing of the tyre, nor does one measured while the other wheel slips too
        (:meth:`_rolls`): the declared size then stands."""
        s, h = self.settings, self.history
        if t - last.declared < s.tyre_update_window - 1e-9 or not h.fix_t:
            return None
        k = len(h.fix_t) - 1
        j = h.fix_at(h.fix_t[k] - s.tyre_update_window)
        now = self._ratio(side, j, k) if j is not None and j < k else None
        if now is None:
            return None
        size = now[0] / self.tyre_reference[side]
        sigma = math.sqrt(now[1] + s.tyre_floor**2)
        if last.size - size < max(s.tyre_min_drop, 3.0 * sigma) or not _physical(size):
            return None  # a tyre does not re-inflate (a ratio back up is a skid) nor roll on a radius ≤ 0
        if not self._rolls(WHEEL_SIDES["L" if side == "R" else "R"], j, k):
            return None  # the other wheel slips too: the rolling ratios say nothing of a tyre
        return self._make("tyre", last.target, "puncture", Reading(last.statistic, last.threshold, size, sigma,
                                                                    last.onset), t)

    def _rolls(self, target: str, j: int, k: int) -> bool:
        """Wheel ``target``'s rolling ratio between pose fixes ``j`` and ``k`` is the one its tyre should give —
        its declared size times its reference ratio, or 1 — within ``tyre_min_drop_second`` and 3σ (the other
        tyre's tilt moves its contact point that much): it rolls without slip, so the no-slip model that turns a
        rolling ratio into a tyre size holds there. A wheel that turned too little says nothing (True)."""
        s = self.settings
        side = target[0].upper()
        ratio = self._ratio(side, j, k)
        if ratio is None:
            return True
        declared = self._has("tyre", target)
        expected = 1.0 if declared is None else declared.size * self.tyre_reference[side]
        return abs(ratio[0] - expected) <= max(s.tyre_min_drop_second, 3.0 * math.sqrt(ratio[1] + s.tyre_floor**2))

    def _declare_sensor(self, t: float) -> Diagnosis | None:
        """A speed-sensor or gyro bias or drift once its alarm is confirmed and ``shape_min`` (s) has passed
        since the GLR's onset and since each shape's fitted one: mode, size and onset from :func:`.shape.shape_fit`
        of the integrated residual; a bias declared is fitted again every ``shape_min`` and re-declared as a
        drift once the drift's likelihood ratio over the bias exceeds ``drift_llr``."""
        for name, component, target in (("speed", "speed sensor", "speed"), ("gyro", "gyro", "yaw_rate")):
            r = self.readings[name]
            last = self._has(component)
            if (last is None and not self._confirmed(name, t)) or (last is not None and last.mode != "bias"):
                continue
            since = r.onset if last is None else last.declared
            if t - since < self.settings.shape_min - 1e-9 or (last is not None and t - self.refit[name] <
                                                              self.settings.shape_min - 1e-9):
                continue
            self.refit[name] = t
            fit = self._shape(name, t)
            if fit is not None and t - fit.latest < self.settings.shape_min - 1e-9:
                continue  # too little since either model's fitted onset to tell a bias from a drift yet
            if fit is not None and (last is None or fit.mode == "drift"):
                return self._make(component, target, fit.mode, Reading(r.stat, r.threshold, fit.size, fit.sigma,
                                                                       fit.onset), t)
        return None

    def integrated(self, name: str, t: float) -> tuple[np.ndarray, np.ndarray, float, float] | None:
        """The ``speed`` (m) or ``gyro`` (rad) residual integrated from fix to fix over the last ``fit_window``
        (s) before ``t`` (after ``launch``): the times (s) and values at the fixes, the fix's variance ``r``
        and the sensor's random-walk variance ``q`` per second (:mod:`.shape`). An interval without samples
        takes the previous interval's mean reading."""
        h, s = self.history, self.settings
        first = h.fix_at(max(t - s.fit_window, s.launch))
        last = len(h.fix_t) - 1
        if first is None or last - first < 6:
            return None
        key, sig = ("v", self.sigma_v) if name == "speed" else ("g", self.sigma_g or 0.0)
        times, values, mean, rates, total = [h.fix_t[first]], [0.0], None, [], 0.0
        for j in range(first, last):
            a, b = h.fix_steps[j], h.fix_steps[j + 1]
            span = h.fix_t[j + 1] - h.fix_t[j]
            n = h.delta(f"n_{key}", a, b)
            mean = h.delta(key, a, b) / n if n > 0 else mean
            if mean is None or span <= 0.0:
                return None
            arc, dpsi = h.motion(j, j + 1)
            move = arc if name == "speed" else dpsi
            total += mean * span - move
            rates.append(abs(move) / span)
            times.append(h.fix_t[j + 1])
            values.append(total)
        floor = (s.speed_floor if name == "speed" else s.gyro_floor) * float(np.mean(rates))
        r = self.pose_sigma[0 if name == "speed" else 1] ** 2
        return np.asarray(times), np.asarray(values), r, sig**2 * self.dt + floor**2 * s.shape_bin

    def _shape(self, name: str, t: float) -> ShapeFit | None:
        """:func:`.shape.shape_fit` of the ``speed`` or ``gyro`` channel's integrated residual (:meth:`integrated`),
        the candidate onsets every ``shape_bin`` / 5 from ``shape_min`` after its first sample to
        ``shape_bin`` before ``t``."""
        s = self.settings
        data = self.integrated(name, t)
        if data is None:
            return None
        times, values, r, q = data
        stride = max(1, math.ceil(times.size / s.fit_samples))  # the integral decimated: its Cholesky is O(n³)
        times, values = times[::-1][::stride][::-1], values[::-1][::stride][::-1]
        starts = np.arange(times[0] + s.shape_min, t - s.shape_bin, 0.2 * s.shape_bin)
        return shape_fit(times, values, r, q, starts, s.drift_llr)
