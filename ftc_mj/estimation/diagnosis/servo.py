"""The servo channel's load test: a step of one wheel's lag behind its command at the same motion.

A velocity servo of gain ``e k_v`` (``e`` its effectiveness) drives a wheel loaded by the torque ``τ`` (the
tyre's force times the radius: drag, scrub, the turning couple) with the lag ``ω_cmd − ω = τ / (e k_v)``.
The load is set by the motion — the wheel rates, hence the robot's speed and curvature — not by the servo:
at the same wheel rates the same load is carried by a servo of any gain. So when the mean lag of one wheel
steps from ``ℓ₀`` to ``ℓ₁`` (same sign) while both wheels turn at the same mean rates as before, and the
other wheel's lag stays, the servo's gain fell by ``ℓ₀ / ℓ₁``: the size read directly, with no closed-loop
regression bias. This is the identifiability argument of Isermann (*Fault-Diagnosis Systems*, §9 on
parameter estimation in closed loop): the static gain of the load-to-lag map is identifiable from a step of
the output at a known (here: unchanged) operating point without any persistent excitation, whereas the
dynamic regression ``Δω = α (ω_cmd − ω) − β`` (:meth:`.history.History.regression`) needs the command to
vary — which the path-following NMPC's smooth commands do not do on a steady arc.

The test is a windowed GLR of a mean shift of the lag (Basseville & Nikiforov §2.4) at candidate change
times ``servo_afters`` before now, each against the ``reference_window`` before it (after ``launch``):
``D = ℓ₁ − ℓ₀``, ``σ_D² = s₁² c / T₁ + s₀² c / T₀ + (servo_lag_floor ℓ₀)²`` with ``s²`` the lag's variance in
each window and ``c`` = ``servo_correlation`` its correlation time (the loop's own fluctuation, not white),
and the floor the healthy lag's variation at one operating point. :class:`LagSums` keeps the running sums it
reads beside the history's; :func:`lag_step` is the test.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .history import History
from .settings import ResidualDiagnoserSettings

_KEYS = ("w_R", "w_L", "ll_R", "ll_L")


class LagSums:
    """The running sums the load test needs beyond its :class:`.history.History`'s (which already keeps each
    wheel's lag ``Σ (ω_cmd − ω)`` and the count of commanded steps, ``lag_*`` and ``n_cmd``): per estimator step
    with a command, each wheel's rate (rad/s) and its lag squared. :meth:`push` follows the history's push of the
    same step."""

    def __init__(self, history: History) -> None:
        self.history = history
        self.sums: dict[str, list[float]] = {k: [] for k in _KEYS}

    def push(self, omega: np.ndarray, command: np.ndarray | None) -> None:
        """Add one step: encoder rates ``omega`` and the command in force ``command`` (``None``: nothing)."""
        if command is None:
            inc = (0.0,) * len(_KEYS)
        else:
            lR, lL = float(command[0] - omega[0]), float(command[1] - omega[1])
            inc = (float(omega[0]), float(omega[1]), lR * lR, lL * lL)
        for k, v in zip(_KEYS, inc, strict=True):
            seq = self.sums[k]
            seq.append((seq[-1] if seq else 0.0) + v)

    def window(self, j: int, k: int) -> dict[str, float] | None:
        """The means over steps ``(j, k]`` of each wheel's rate, lag and lag variance (``w_*``, ``l_*``,
        ``v_*``) and the step count ``n``; ``None`` with fewer than 10 commanded steps."""
        s, h = self.sums, self.history
        n = h.delta("n_cmd", j, k)
        if n < 10:
            return None
        out = {"n": n}
        for side in "RL":
            out[f"w_{side}"] = (s[f"w_{side}"][k] - s[f"w_{side}"][j]) / n
            mean = h.delta(f"lag_{side}", j, k) / n
            out[f"l_{side}"] = mean
            out[f"v_{side}"] = max((s[f"ll_{side}"][k] - s[f"ll_{side}"][j]) / n - mean * mean, 0.0)
        return out


@dataclass(frozen=True, slots=True)
class LagStep:
    """A lag step of one wheel found by :func:`lag_step`: its GLR (nats), the gain ratio ``ℓ₀/ℓ₁`` (the
    remaining fraction of the servo), its σ, and the candidate change time (s)."""

    glr: float
    ratio: float
    sigma: float
    onset: float


def comparable(settings: ResidualDiagnoserSettings, side: str, before: dict[str, float], after: dict[str, float]
               ) -> bool:
    """Whether wheel ``side``'s lags in the windows ``before`` and ``after`` (:meth:`LagSums.window`) compare as its
    servo's gain: the same motion — each wheel's mean rate moved by at most ``servo_motion_tol`` of the mean wheel
    rate before, so the lags carry the same load — and a load to carry: the lag before at least ``servo_min_lag``
    of that rate (a wheel that carries no load says nothing of its servo's gain)."""
    s = settings
    scale = 0.5 * (abs(before["w_R"]) + abs(before["w_L"]))
    if scale <= 0.0 or any(abs(after[f"w_{w}"] - before[f"w_{w}"]) > s.servo_motion_tol * scale for w in "RL"):
        return False
    return abs(before[f"l_{side}"]) >= s.servo_min_lag * scale


def _candidate(settings: ResidualDiagnoserSettings, side: str, before: dict[str, float], after: dict[str, float],
               spans: tuple[float, float]) -> tuple[float, float, float] | None:
    """``(glr, ratio, σ_ratio)`` of wheel ``side``'s lag step between the windows ``before`` and ``after`` of
    ``spans`` (s) seconds, or ``None`` when a gate fails: the windows do not compare (:func:`comparable`: the motion
    changed, or the wheel carried no load), the lag changed sign or shrank, or the other wheel's lag changed by as
    much (a load change, not a servo)."""
    s = settings
    if not comparable(s, side, before, after):
        return None
    l0, l1 = before[f"l_{side}"], after[f"l_{side}"]
    if l0 * l1 <= 0.0 or abs(l1) <= abs(l0):
        return None
    other = "L" if side == "R" else "R"
    o0, o1 = before[f"l_{other}"], after[f"l_{other}"]
    if abs(o1 - o0) > s.servo_other_fraction * abs(l1 - l0):
        return None
    c = s.servo_correlation
    var0 = before[f"v_{side}"] * c / spans[0] + (s.servo_lag_floor * l0) ** 2  # the reference, with the floor
    var1 = after[f"v_{side}"] * c / spans[1]
    d = l1 - l0
    glr = d * d / (2.0 * (var0 + var1)) if var0 + var1 > 0.0 else math.inf
    sigma = math.sqrt(var0 / l1**2 + l0**2 * var1 / l1**4)  # δ(l0/l1) to first order, the windows independent
    return glr, l0 / l1, sigma


def lag_step(settings: ResidualDiagnoserSettings, sums: LagSums, times: list[float], side: str,
             step_at: Callable[[float], int | None]) -> LagStep | None:
    """The strongest lag step of wheel ``side`` (``_candidate``) over the candidate change times
    ``servo_afters`` (s) before the latest step ``times[-1]``, each against the ``reference_window`` before it
    (starting after ``launch``, at least as long as the test window); ``None`` when no candidate passes the
    gates. ``step_at(t)`` gives the last step at or before ``t`` (:meth:`.history.History.step_at`)."""
    s = settings
    now = times[-1]
    k = len(times) - 1
    best: LagStep | None = None
    for span in s.servo_afters:
        j = step_at(now - span)
        i = step_at(max(now - span - s.reference_window, s.launch))
        if i is None or j is None or times[j] - times[i] < span - 1e-9 or j >= k:
            continue
        before, after = sums.window(i, j), sums.window(j, k)
        if before is None or after is None:
            continue
        found = _candidate(s, side, before, after, (times[j] - times[i], now - times[j]))
        if found is not None and (best is None or found[0] > best.glr):
            best = LagStep(found[0], found[1], found[2], times[j])
    return best
