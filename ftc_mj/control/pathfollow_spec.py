"""The numbers of the path-following problem and the robot-derived pieces of its constraints.

:class:`PathFollowingSpec` holds the weights and bounds of the problem described in
:mod:`ftc_mj.control.pathfollow`; :class:`RobotLimits` the physical robot's limits the sim layer derives
from the plant model. The free functions compute, per sample, the servo-compliance offset of the wheel
rates, the signs of the traction rows and the wheel-rate box.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .spec import ProblemSpec

SLACK_MAX = 100.0
"""Upper bound of the lateral-acceleration slack (m/s²; any violation the applied command can cause)."""


@dataclass(frozen=True)
class RobotLimits:
    """Numbers of the physical robot the path-following NMPC is given (derived by the sim layer from the plant
    model, :func:`ftc_mj.plant.limits.lateral_accel_limits`; the control layer knows no plant)."""

    liftoff_accel: float
    """Lateral acceleration (m/s²) at which the robot starts to lift its inner wheel, without braking."""
    yaw_compliance: float = 0.0
    """Commanded minus actual yaw rate (rad/s) per m/s² of lateral acceleration with the nominal tyres (s/m)."""
    braking_trade: float = 0.0
    """Loss of the lift-off limit per m/s² of braking (dimensionless)."""


@dataclass(frozen=True)
class RadiusInterval:
    """The radii [R_R, R_L] (m) the robot's wheels may have, per wheel ``lo ≤ R ≤ hi``: what the degraded
    mode hands the path-following NMPC from the first alarm until the interval collapses
    (:mod:`ftc_mj.reconfiguration.degraded`). ``skid`` flags (right, left) the wheels whose no-slip test
    fails (for the telemetry)."""

    lo: np.ndarray
    hi: np.ndarray
    skid: tuple[bool, bool] = (False, False)

    def corners(self) -> tuple[np.ndarray, np.ndarray]:
        """``(upper, lower)``: the radii of largest and of smallest lateral acceleration over the interval.
        The robot's ``a = V psidot = (R_R² omega_R² − R_L² omega_L²)/(4 b)`` grows with ``R_R`` and falls with
        ``R_L`` whatever the signs of the wheel rates, so its largest value over the box is at
        ``(hi_R, lo_L)`` and its smallest at ``(lo_R, hi_L)``: two rows per node bound it at every radius."""
        return np.array([self.hi[0], self.lo[1]]), np.array([self.lo[0], self.hi[1]])


@dataclass(frozen=True)
class PathFollowingSpec:
    """Numbers of the path-following problem (units in the field comments).

    ``problem`` supplies the grid and the robot (``nodes``, ``horizon``, ``half_track``,
    ``omega_max``, ``omega_rate_max``, ``rate_penalty``, ``max_lateral_accel`` — the bound on the
    robot's lateral acceleration, ``max_longitudinal_accel``); its tracking weights are not used.
    """

    problem: ProblemSpec
    desired_speed: float = 10.0  # m/s
    q_contour: float = 30.0  # 1/m² s
    q_lag: float = 10.0  # 1/m² s
    q_heading: float = 10.0  # 1/rad² s
    q_progress: float = 1.0  # s/m²
    progress_rate_penalty: float = 0.1  # s³/m²
    max_progress_speed: float = 20.0  # m/s
    yaw_compliance: float = 0.0  # s/m
    braking_trade: float = 0.0  # lateral bound lost per m/s² of longitudinal acceleration
    sample_time: float = 0.1  # s
    slack_penalty: float = 1.0e4  # per m/s² of slack
    max_lag: float = 0.0  # m, largest |lag| of the carried progress at t0 (0: re-projected at every sample)



def compliance_offset(spec: PathFollowingSpec, u_applied: np.ndarray | None, radii: np.ndarray,
                      nominal_radii: np.ndarray) -> np.ndarray:
    """The wheel rates (rad/s) of the robot minus the commanded ones at the applied command ``u``.

    The velocity servos yield under the tyres' yaw couple ``F = M a x_G / (2 b)`` (the robot understeers): the
    outer (right, for a left turn) wheel lags by ``F R_R / k_v``, the inner runs ahead by ``F R_L / k_v``, so
    ``δ = k a (−R_R, R_L)`` with ``a`` the robot's lateral acceleration and ``k = c b / R_0²`` from
    ``yaw_compliance`` ``c`` (s/m, the yaw-rate deficit per m/s² with the nominal tyres ``R_0``). With the
    model's ``V0, r0`` of ``u``, the robot's are ``V = V0 + p a`` and ``r = r0 − q a`` (``p = k (R_L² − R_R²)/2``,
    ``q = k (R_R² + R_L²)/(2 b)``), and ``a = V r`` is the root of ``−p q a² + (p r0 − q V0 − 1) a + V0 r0 = 0``
    that tends to ``V0 r0 / (1 + q V0)`` as ``p → 0``. Zero with ``c = 0`` or before the first command."""
    if spec.yaw_compliance == 0.0 or u_applied is None:
        return np.zeros(2)
    b = spec.problem.half_track
    k = spec.yaw_compliance * b / (0.5 * float(nominal_radii @ nominal_radii))
    V0 = 0.5 * float(radii @ u_applied)
    r0 = (radii[0] * u_applied[0] - radii[1] * u_applied[1]) / (2.0 * b)
    p = 0.5 * k * (radii[1] ** 2 - radii[0] ** 2)
    q = 0.5 * k * float(radii @ radii) / b
    B = p * r0 - q * V0 - 1.0
    disc = max(B * B + 4.0 * p * q * V0 * r0, 0.0)
    a = 2.0 * V0 * r0 / (-B + np.sqrt(disc)) if -B + np.sqrt(disc) > 0.0 else 0.0
    return k * a * np.array([-radii[0], radii[1]])


def lateral_sides(spec: PathFollowingSpec, at_t0: bool = False) -> tuple[tuple[float, float], ...]:
    """Signs ``(s_lat, s_lon)`` of the rows ``s_lat a + s_lon β dV/dt − σ ≤ A`` that make
    ``|a| + β |dV/dt| ≤ A + σ`` at the nodes, or (``at_t0``) the extra rows at ``t0`` with ``dV/dt`` the change
    of speed from the applied command's (none when ``β = 0``)."""
    if spec.braking_trade == 0.0:
        return () if at_t0 else ((1.0, 0.0), (-1.0, 0.0))
    return ((1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0))


def wheel_bounds(spec: PathFollowingSpec, N: int, u_applied: np.ndarray | None, offset: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Bounds (rad/s) of the model's wheel rates ``[omega_R(N), omega_L(N)]``: the command is the model's rate
    minus ``offset`` (:func:`compliance_offset`, rad/s), so the box is ``±omega_max + offset``;
    at ``t0`` also within ``u_applied + offset ± omega_rate_max T_s`` (no such row without an applied command)."""
    om = spec.problem.omega_max
    lo = np.repeat(offset - om, N)
    hi = np.repeat(offset + om, N)
    if u_applied is not None:
        d = spec.problem.omega_rate_max * spec.sample_time
        lo[[0, N]] = np.maximum(lo[[0, N]], u_applied + offset - d)
        hi[[0, N]] = np.minimum(hi[[0, N]], u_applied + offset + d)
    return lo, hi

