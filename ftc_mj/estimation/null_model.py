"""The change detectors' null model of the physical robot: what the no-slip kinematic model misses on a
healthy robot.

Measured on the MuJoCo robot without a fault (development seed 1 of scenario 1 — 10 m/s on the 50 m circle,
feedback off —, whose trajectory does not depend on the noise seed; the numbers are per-wheel
effective-radius errors as fractions of ``R0``, the single-wheel equivalent of the yaw-rate residual over
√2):

1. **The one-step lag.** The estimator predicts step ``k`` with the wheel rates measured at ``k - 1`` and
   compares the speed and yaw rate measured at ``k`` with the no-slip model at those rates. The body
   follows the wheels within a step, so the measurement at ``k`` is that of the rates at ``k``: a residual
   ``≈ dt · ψ̈`` (fitted slope 0.0112 s at dt = 0.01 s), 0.013 rad/s rms — above a 0.01 rad/s gyro's σ —
   wherever the controller turns the robot, and spikes where a command update starts or stops the servos'
   acceleration, which no extrapolation of the rates foresees. The physical detectors therefore run one
   step behind: at step ``k`` the residual generator takes the measurement of ``k - 1`` with the rates
   measured at ``k - 1`` (the rates the estimator hands over at ``k``). The yaw-rate residual below 0.3 g
   is then 0.016–0.04 % of ``R0`` rms (0.001–0.002 rad/s); the price is one step (0.01 s) of delay.
2. **Tyre slip near the grip limit.** When the demanded lateral acceleration ``q = |V ψ̇| / g`` (from the wheel
   rates the command produced, at the residual generator's radii — nominal until a declared change —, or
   the lower of that and the demand at the estimator's radius estimates where the two depart by more than
   :data:`RADIUS_GAP` of ``R0``: the generator lags a change until it is re-anchored, and a lagging radius
   reads the controller's compensating rates as a demand of several g)
   approaches the tyres' grip a wheel slips: its effective rolling radius departs from the nominal one,
   0.12 % rms at 0.30–0.33 g, 0.3 % at 0.33–0.36 g, 0.7 % at 0.36–0.40 g, 1.2–2.6 % above 0.40 g, and
   for 0.1 s after the demand falls back below 0.40 g (0.6 % rms in the first 0.05 s, 0.2 % in the next).
   A slip of wheel ``i`` moves the
   measurements exactly as a change of its radius does, so it enters as random effective-radius noise of
   σ ``s(q) · R0`` per wheel along the radius columns ``h_i`` of the measurement Jacobian,
   ``S ← S + Σ_i (s(q) R0)² h_i h_iᵀ``, with ``s`` the piecewise-linear :data:`SLIP_FRACTION` (1.2–2 × the
   measured rms: the slip is correlated over tenths of a second, which white noise of its rms does not
   describe) and ``q`` the largest demand of the last :data:`HOLD_S`. A speed or yaw-rate channel whose
   slip noise exceeds :data:`BLIND_RATIO` of its sensor's σ is not used (the generator only predicts, the
   detectors hold). The longitudinal demand ``ΔV/dt`` is left out: the wheel rates of a punctured tyre
   jump (the servo spins the smaller wheel faster), which would read as a demand of several g and blind
   the detectors at the very puncture they are there to see.

Every number is a fraction of the nominal radius, of g or of the sensor's σ, so a rescaled robot gets the
same rule. The
rule costs sensitivity to a radius change only while the robot is at its grip limit, where a slip and a
puncture look alike. The run lengths it gives are measured on the physical plant by
``benchmarks/calibration.py`` (docs/fdi.md, "Calibration on the physical plant").
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np

G = 9.81
"""Standard gravity (m/s²): the demanded acceleration is read in g."""
SLIP_FRACTION: tuple[tuple[float, float], ...] = ((0.0, 0.0003), (0.20, 0.0005), (0.30, 0.0012), (0.33, 0.0025),
                                                  (0.36, 0.005), (0.40, 0.009), (0.45, 0.016), (0.50, 0.024),
                                                  (0.60, 0.032))
"""Knots ``(q, s)`` of the effective-radius noise: σ ``s · R0`` per wheel (fraction of the nominal radius) at
a demanded acceleration of ``q`` g; linear between knots, constant beyond the last."""
RADIUS_GAP = 0.05
"""The demand is read at the estimator's radii instead of the residual generator's only where the two depart by
more than this fraction of the nominal radius on a wheel (half the smallest declared drop, ``min_drop`` 0.1 m
of a 2 m wheel): a radius change the generator has not caught up with. Below it the generator's radii stand —
the estimator reads a wheel's slip as a change of its radius, which lowers the demand it implies exactly when
the tyre slips (with the lower of the two demands everywhere, ARL0 / design fell from 0.83 to 0.36 on replays
of dev seeds 0–9 with the gyro)."""
HOLD_S = 0.1
"""How long (s) a demand counts after it: a tyre that slipped takes that long to grip again."""
BLIND_RATIO = 2.0
"""A speed or yaw-rate channel whose slip noise's σ exceeds this multiple of its sensor's σ is not used (the
generator only predicts, the detectors hold): the slip, correlated over tenths of a second, then dominates
what no white-noise σ describes."""


def interp_knots(q: float, knots: tuple[tuple[float, float], ...]) -> float:
    """The piecewise-linear function through ``knots`` (increasing abscissae) at ``q``, constant beyond the ends:
    ``np.interp(q, *zip(*knots))`` for one scalar, in the same arithmetic (the slope of the knots' interval times
    the offset from its left knot plus that knot's value; a knot's own value at a knot), without building arrays
    at every filter step."""
    if not q >= knots[0][0]:  # below the first knot (NaN falls through to np.interp's NaN below)
        return knots[0][1] if q < knots[0][0] else math.nan
    j = bisect.bisect_right(knots, q, key=_abscissa) - 1
    if j >= len(knots) - 1:
        return knots[-1][1]
    (x0, y0), (x1, y1) = knots[j], knots[j + 1]
    if q == x0:
        return y0
    res = (y1 - y0) / (x1 - x0) * (q - x0) + y0
    return res if not math.isnan(res) else (y1 - y0) / (x1 - x0) * (q - x1) + y1


def _abscissa(knot: tuple[float, float]) -> float:
    return knot[0]


@dataclass(frozen=True)
class NullModel:
    """The healthy physical robot's departures from the no-slip model (module docstring)."""

    R0: float
    """Nominal wheel radius (m)."""
    b: float
    """Half track (m)."""
    dt: float
    """Filter step (s)."""
    knots: tuple[tuple[float, float], ...] = SLIP_FRACTION
    """``(q g, fraction of R0)`` knots of the effective-radius noise."""

    def demand(self, u: np.ndarray, radii: np.ndarray) -> float:
        """Demanded lateral acceleration (g) at wheel rates ``u`` (rad/s): ``|V ψ̇| / g`` at the wheel ``radii``
        (m; the residual generator's, so that after a declared puncture the compensating rates are read at
        the radius the tyre has)."""
        V = 0.5 * (radii[0] * u[0] + radii[1] * u[1])
        w = (radii[0] * u[0] - radii[1] * u[1]) / (2.0 * self.b)
        return abs(V * w) / G

    def slip_sigma(self, q: float) -> float:
        """σ (m) of each wheel's effective-radius noise at a demanded acceleration of ``q`` g."""
        return interp_knots(float(q), self.knots) * self.R0

    def drops(self, q: float, u: np.ndarray, sigma: float | None, channel: str) -> bool:
        """The ``speed`` or ``yaw`` channel of sensor σ ``sigma`` (m/s, rad/s; ``None``: not measured) is not used
        at a demanded acceleration of ``q`` g and wheel rates ``u`` (rad/s): its slip noise's σ exceeds
        :data:`BLIND_RATIO` of the sensor's."""
        if sigma is None:
            return False
        gain = math.hypot(u[0], u[1]) * (0.5 if channel == "speed" else 0.5 / self.b)  # |dh/dR| per wheel, both
        return self.slip_sigma(q) * gain > BLIND_RATIO * sigma

    def covariance(self, S: np.ndarray, H: np.ndarray, q: float) -> np.ndarray:
        """The innovation covariance ``S`` with the slip noise at ``q`` g added along the radius columns of the
        step's measurement Jacobian ``H`` (m, 5)."""
        s = self.slip_sigma(q)
        Hr = H[:, 3:5]
        return np.asarray(S, float) + (s * s) * (Hr @ Hr.T)
