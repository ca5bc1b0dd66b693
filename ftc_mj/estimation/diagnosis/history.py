"""The running sums a windowed residual needs, one entry per estimator step (:class:`History`), and the
motion between two pose fixes (:func:`arc_between`).

Every quantity is kept as a cumulative sum from the start of the run, so the mean of any channel over any
window ``(j, k]`` of steps is one subtraction: the wheel angles turned (rad, trapezoidal), the command lag
``Σ (ω_cmd − ω)`` (rad/s · steps), the sums of the servo's regression ``Δω_k = α (ω_cmd − ω)_{k-1} − β``,
the speed and gyro readings with their counts (a missing sample adds nothing), and the pose fixes with the
step they arrived at, and the arc length rolled forward from fix to fix (each short step's displacement along
its mean heading: a side-slip, or a lateral pose error, adds nothing to first order).
"""

from __future__ import annotations

import bisect
import math

import numpy as np

SUMS = ("th_R", "th_L", "lag_R", "lag_L", "cmd_R", "cmd_L", "n_cmd", "v", "n_v", "g", "n_g",
        "see_R", "se_R", "sed_R", "sd_R", "see_L", "se_L", "sed_L", "sd_L", "n_reg")
"""The cumulative sums kept per step (module docstring)."""
_PUSH_ORDER = ("th_R", "lag_R", "cmd_R", "see_R", "se_R", "sed_R", "sd_R",
               "th_L", "lag_L", "cmd_L", "see_L", "se_L", "sed_L", "sd_L", "n_reg", "n_cmd", "v", "n_v", "g", "n_g")
"""The order of :meth:`History._increments`'s values."""


class History:
    """The cumulative sums of a run, grown by :meth:`push` once per estimator step of ``dt`` seconds."""

    def __init__(self, dt: float) -> None:
        self.dt = dt
        self.t: list[float] = []
        self.k = -1
        """The index of the latest step (−1 before the first)."""
        self.sums: dict[str, list[float]] = {name: [] for name in SUMS}
        self._order = tuple(self.sums[name] for name in _PUSH_ORDER)  # the lists, in :meth:`_increments`'s order
        self._regression = {side: tuple(self.sums[f"{name}_{side}"] for name in ("see", "se", "sed", "sd"))
                            for side in "RL"}  # the lists :meth:`regression` reads
        self.fix_steps: list[int] = []
        self.fix_t: list[float] = []
        self.fix_pose: list[tuple[float, float, float]] = []  # x, y, ψ unwrapped
        self.fix_s: list[float] = []  # arc length rolled forward since the first fix (m)
        self.fix_offset = (0.0, 0.0)  # the diagnosed displacement of the pose sensor (m), taken off each fix
        self._last_omega: np.ndarray | None = None
        self._last_err: np.ndarray | None = None

    def push(self, t: float, omega: np.ndarray, command: np.ndarray | None, speed: float | None,
             yaw_rate: float | None, pose: np.ndarray | None) -> None:
        """Add the step at ``t`` (s): wheel rates and command (rad/s), readings (m/s, rad/s; ``None``
        missing) and a pose fix ``[x, y, ψ]`` (m, m, rad) or ``None``."""
        self.t.append(t)
        self.k += 1
        prev = self._last_omega if self._last_omega is not None else omega
        sums = self._order
        if self.k:  # every sum grows by its increment (one list append each, no lookup by name)
            for seq, value in zip(sums, self._increments(prev, omega, command, speed, yaw_rate), strict=True):
                seq.append(seq[-1] + value)
        else:
            for seq, value in zip(sums, self._increments(prev, omega, command, speed, yaw_rate), strict=True):
                seq.append(0.0 + value)
        self._last_omega = np.asarray(omega, dtype=float)
        if pose is not None and all(math.isfinite(float(v)) for v in pose):
            psi = float(pose[2])
            if self.fix_pose:  # unwrap against the previous fix
                psi0 = self.fix_pose[-1][2]
                psi = psi0 + (psi - psi0 + math.pi) % (2.0 * math.pi) - math.pi
            here = (float(pose[0]) - self.fix_offset[0], float(pose[1]) - self.fix_offset[1], psi)
            self.fix_s.append(self.fix_s[-1] + arc_between(self.fix_pose[-1], here)[0] if self.fix_pose else 0.0)
            self.fix_steps.append(self.k)
            self.fix_t.append(t)
            self.fix_pose.append(here)

    def _increments(self, prev: np.ndarray, omega: np.ndarray, command: np.ndarray | None, speed: float | None,
                    yaw_rate: float | None) -> tuple[float, ...]:
        """This step's increment of every sum, in :data:`_PUSH_ORDER`: per wheel the angle turned (rad,
        trapezoidal over ``prev`` → ``omega``), the lag and ``|command|`` (rad/s), and the regression's pair
        ``(e_{k-1}, ω_k − ω_{k-1})`` with ``e_{k-1}`` the command in force over the step minus ``ω_{k-1}``
        (its ``e²``, ``e``, ``e·d``, ``d``); then the counts of commands, the readings and their counts (a
        missing one adds nothing)."""
        dt = self.dt
        thR, thL = 0.5 * (prev[0] + omega[0]) * dt, 0.5 * (prev[1] + omega[1]) * dt
        if command is None:
            zero = (0.0,) * 6
            wheels = (thR, *zero, thL, *zero, 0.0, 0.0)
        else:
            cR, cL = command[0], command[1]
            eR, eL = float(cR - prev[0]), float(cL - prev[1])
            dR, dL = float(omega[0] - prev[0]), float(omega[1] - prev[1])
            wheels = (thR, float(cR - omega[0]), abs(float(cR)), eR * eR, eR, eR * dR, dR,
                      thL, float(cL - omega[1]), abs(float(cL)), eL * eL, eL, eL * dL, dL, 1.0, 1.0)
        return (*wheels, 0.0 if speed is None else float(speed), 0.0 if speed is None else 1.0,
                0.0 if yaw_rate is None else float(yaw_rate), 0.0 if yaw_rate is None else 1.0)

    def shift_fixes(self, first: int, offset: tuple[float, float]) -> None:
        """Take a displacement ``offset`` (m, world x, y) of the pose sensor off the fixes from index ``first``
        on and off every later one (a diagnosed pose bias; its opposite when a jump returns), and roll the arc
        lengths forward again from there."""
        self.fix_offset = (self.fix_offset[0] + offset[0], self.fix_offset[1] + offset[1])
        for i in range(first, len(self.fix_pose)):
            x, y, psi = self.fix_pose[i]
            self.fix_pose[i] = (x - offset[0], y - offset[1], psi)
            if i > 0:
                self.fix_s[i] = self.fix_s[i - 1] + arc_between(self.fix_pose[i - 1], self.fix_pose[i])[0]

    def delta(self, name: str, j: int, k: int) -> float:
        """The sum ``name`` over the steps ``(j, k]``."""
        seq = self.sums[name]
        return seq[k] - seq[j]

    def step_at(self, t: float) -> int | None:
        """The last step at or before ``t`` (s), ``None`` before the first."""
        if not self.t or t < self.t[0] - 1e-9:
            return None
        return min(self.k, int(math.floor((t - self.t[0]) / self.dt + 1e-6)))

    def fix_at(self, t: float) -> int | None:
        """The index of the last pose fix at or before ``t`` (s), ``None`` before the first."""
        i = bisect.bisect_right(self.fix_t, t + 1e-9) - 1
        return i if i >= 0 else None

    def motion(self, j: int, k: int) -> tuple[float, float]:
        """``(s, Δψ)``: the arc (m) rolled forward and the heading change (rad) from pose fix ``j`` to ``k``."""
        return self.fix_s[k] - self.fix_s[j], self.fix_pose[k][2] - self.fix_pose[j][2]

    def regression(self, side: str, j: int, k: int) -> tuple[float, float] | None:
        """The servo regression ``Δω = α e − β`` of wheel ``side`` over steps ``(j, k]``: ``(α, var e)`` (1,
        (rad/s)²), ``None`` without commands or without spread of ``e`` (nothing to identify from)."""
        count = self.sums["n_reg"]
        n = count[k] - count[j]
        if n < 10:
            return None
        see, se, sed, sd = (seq[k] - seq[j] for seq in self._regression[side])
        var = see / n - (se / n) ** 2
        if var <= 1e-12:
            return None
        return (sed / n - se * sd / n**2) / var, var


def arc_between(a: tuple[float, float, float], b: tuple[float, float, float]) -> tuple[float, float]:
    """``(s, Δψ)``: the arc length (m) the robot rolled forward from pose ``a`` to pose ``b`` (x, y, ψ
    unwrapped) and its heading change (rad), for a constant curvature in between: the displacement along the
    mean heading (the chord, without side-slip) times ``(Δψ/2) / sin(Δψ/2)``."""
    dx, dy, dpsi = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    mid = 0.5 * (a[2] + b[2])
    half = 0.5 * dpsi
    factor = 1.0 if abs(half) < 1e-6 else half / math.sin(half)
    return (dx * math.cos(mid) + dy * math.sin(mid)) * factor, dpsi
