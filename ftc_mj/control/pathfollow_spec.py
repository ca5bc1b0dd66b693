"""The settings and numbers of the path-following problem and the robot-derived pieces of its constraints.

:class:`PathFollowingSettings` declares the path-following NMPC's own settings (``controller.path_following``);
:class:`PathFollowingSpec` holds the weights and bounds of the problem described in
:mod:`ftc_mj.control.pathfollow`, built by :func:`path_following_problem` from those settings (it declares no
defaults of its own); :class:`RobotLimits` the physical robot's limits the sim layer derives from the plant
model. The free functions compute, per sample, the servo-compliance offset of the wheel rates, the signs of
the traction rows and the wheel-rate box.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..fields import Flag, NonNegFloat, PosFloat, StrictModel, ranged
from .spec import ProblemSpec

SLACK_MAX = 100.0
"""Upper bound of the lateral-acceleration slack (m/s²; any violation the applied command can cause)."""


class PathFollowingSettings(StrictModel):
    """Settings of the path-following NMPC (``controller.kind = "pf-nmpc"``, :mod:`ftc_mj.control.pathfollow`;
    the ``controller.path_following`` table). It shares ``nodes``, ``horizon``, ``omega_rate_max``, ``solver``,
    ``max_iter`` and the budgets with the NMPC, but carries every cost term it needs as its own setting (the
    actuation-rate weight included: ``controller.rate_penalty`` is the tracking NMPC's and is not read here);
    its desired speed is ``reference.speed``. Cost weights are per second of horizon (Gauss–Lobatto
    quadrature)."""

    q_contour: NonNegFloat = 30.0
    """Weight (1/(m² s)) on the squared contouring error (distance from the path, normal to it)."""
    q_lag: NonNegFloat = 10.0
    """Weight (1/(m² s)) on the squared lag error (position along the tangent relative to the progress point)."""
    q_heading: NonNegFloat = 10.0
    """Weight (1/(rad² s)) on the squared heading error to the path tangent."""
    q_progress: NonNegFloat = 1.0
    """Weight (s/m²) on the squared deviation of the progress speed from ``reference.speed``."""
    rate_penalty: NonNegFloat = 1.0
    """Weight (s³, per (rad/s²)²) on the squared wheel accelerations ``‖d omega/dt‖²`` (the actuation-rate term).
    Without it the controller is not usable on the MuJoCo robot: the wheel-rate plans chatter between their
    bounds, the servos cannot follow and the robot leaves the path (27.6 m off and 361 solver failures on
    scenario 2 in one run with 0; docs/findings.md)."""
    fix_heading_rate_penalty: NonNegFloat | None = 5.0
    """The actuation-rate weight (as ``rate_penalty``) used instead of ``rate_penalty`` when the controller's heading
    comes from pose fixes without a yaw-rate gyro (``sensors.pose_source = "sensor"``, no ``yaw_rate_sigma``): the
    filter's heading then carries the fixes' noise (σ 0.04 rad, correlated over 0.1–0.2 s, against 0.018 rad
    averaged over 1 s: the yaw rate between fixes comes from the wheel radii, whose estimates the fixes jolt), and
    at weight 1 the plan answers each excursion with a turn to the lateral bound that the robot then has to undo
    (scenario 2, dev seeds 0–3: 0.16–0.86 m off before the fault; with 5, 0.14–0.43 m; docs/findings.md).
    ``None`` = ``rate_penalty`` always."""
    progress_rate_penalty: NonNegFloat = 0.1
    """Weight (s³/m²) on the squared rate of the progress speed."""
    max_lag: ranged(0.0, 100.0, unit="m") = 0.0
    """Progress feedback: the progress is carried from plan to plan (the previous plan's prediction for now) and
    only pulled back to within this distance (m) of the path point nearest the robot, so the lag error at ``t0``
    is the progress the robot failed (or exceeded) to make and the lag cost feeds it back; 0 = the progress is
    re-projected onto the nearest path point at every sample (no feedback of the progress made)."""
    max_progress_speed: PosFloat | None = None
    """Upper bound (m/s) of the progress speed; ``None`` = twice ``reference.speed``."""
    lateral_accel_margin: ranged(0.0, 1.0, lo_open=True) = 0.9
    """The bound on the robot's lateral acceleration as a fraction of its lift-off limit, which the sim layer
    derives from the MJCF (:func:`ftc_mj.plant.limits.lateral_accel_limits`: 3.92 m/s² for
    the built-in ``diffdrive.xml``, where the inner tyre reaches its friction circle; measured onset of lift-off
    4.1–4.2 m/s², docs/findings.md)."""
    max_lateral_accel: ranged(0.0, 20.0, lo_open=True, unit="m/s²") | None = None
    """Explicit bound (m/s²) on the robot's lateral acceleration; ``None`` = ``lateral_accel_margin`` × the
    derived lift-off limit."""
    compensate_yaw_compliance: Flag = True
    """Bound the robot's lateral acceleration, not the kinematic model's: on the MuJoCo plant the velocity servos
    yield under the tyres' yaw couple, so the model's ``V psidot`` (from the commanded rates) is ``1 + c V``
    times the robot's, with ``c`` derived from the MJCF (0.0375 s/m: 1.375 at 10 m/s). ``False`` (and the
    kinematic plant) bounds the model's ``V psidot``."""
    braking_trade: Flag = True
    """Bound ``|a_lat| + β |dV/dt|`` instead of ``|a_lat|``: braking loads the inner tyre too, so its lift-off limit
    falls by β (0.75 for the built-in ``diffdrive.xml``, derived from the MJCF) per m/s² of braking."""
    max_longitudinal_accel: ranged(0.0, 20.0, lo_open=True, unit="m/s²") | None = 3.0
    """Bound (m/s²) on ``dV/dt`` at every node and on the change of the speed from the applied command's within
    one control period; ``None`` = no bound. The motors' torque limit allows about 4 m/s² (built-in model)."""
    slack_penalty: PosFloat = 1.0e4
    """Exact-penalty weight on the slack of the lateral bound (per m/s²); it must exceed the bound's multiplier
    for the slack to stay 0 whenever the bound can be met."""


@dataclass(frozen=True)
class RobotLimits:
    """Numbers of the physical robot the path-following NMPC is given (derived by the sim layer from the plant
    model, :func:`ftc_mj.plant.limits.lateral_accel_limits`; the control layer knows no plant)."""

    liftoff_accel: float
    """Lateral acceleration (m/s²) at which the robot starts to lift its inner wheel, without braking."""
    yaw_compliance: float
    """Commanded minus actual yaw rate (rad/s) per m/s² of lateral acceleration with the nominal tyres (s/m)."""
    braking_trade: float
    """Loss of the lift-off limit per m/s² of braking (dimensionless)."""
    servo_lateral_accel: float | None = None
    """Lateral acceleration (m/s²) at which one healthy servo's torque limit carries the yaw couple
    (:func:`ftc_mj.plant.limits.servo_limits`; ``None``: no servo, the kinematic plant)."""
    servo_longitudinal_accel: float | None = None
    """Longitudinal acceleration (m/s²) at which one healthy servo's torque limit carries its wheel's half
    (``None``: no servo)."""


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
    """Numbers of the path-following problem (units in the field comments); built by
    :func:`path_following_problem` from :class:`PathFollowingSettings` (whose docstrings explain each).

    ``problem`` supplies the grid and the robot (``nodes``, ``horizon``, ``half_track``,
    ``omega_max``, ``omega_rate_max``, ``rate_penalty``, ``max_lateral_accel`` — the bound on the
    robot's lateral acceleration, ``max_longitudinal_accel``); its tracking weights are not used.
    """

    problem: ProblemSpec
    desired_speed: float  # m/s
    q_contour: float  # 1/m² s
    q_lag: float  # 1/m² s
    q_heading: float  # 1/rad² s
    q_progress: float  # s/m²
    progress_rate_penalty: float  # s³/m²
    max_progress_speed: float  # m/s
    yaw_compliance: float  # s/m
    braking_trade: float  # lateral bound lost per m/s² of longitudinal acceleration
    sample_time: float  # s
    slack_penalty: float  # per m/s² of slack
    max_lag: float  # m, largest |lag| of the carried progress at t0 (0: re-projected at every sample)
    servo_lateral_accel: float | None = None  # m/s², lateral bound a healthy servo allows (× the margin); None: none
    servo_longitudinal_accel: float | None = None  # m/s², longitudinal bound a healthy servo allows; None: none


def path_following_problem(problem: ProblemSpec, settings: PathFollowingSettings, desired_speed: float,
                           limits: RobotLimits | None = None) -> PathFollowingSpec:
    """The path-following problem of ``settings`` at ``desired_speed`` (m/s, the reference's) on the grid and
    robot of ``problem`` (the MPC settings' tracking problem), with the cost terms of ``settings`` (its own
    actuation-rate weight, not the tracking problem's): the bound on the robot's lateral acceleration is
    ``settings.max_lateral_accel`` if set, else ``lateral_accel_margin`` × the robot's lift-off limit in
    ``limits`` (which the sim layer derives from the plant model); the yaw compliance and the braking trade-off
    of ``limits`` are used when switched on. ``ValueError`` when neither bound nor limits are given."""
    pf = settings
    bound = pf.max_lateral_accel
    if bound is None:
        if limits is None:
            raise ValueError("controller.path_following: the pf-nmpc needs the robot's lift-off limit "
                             "(derived by the sim layer) or an explicit max_lateral_accel")
        bound = pf.lateral_accel_margin * float(limits.liftoff_accel)
    lim = limits or RobotLimits(liftoff_accel=bound, yaw_compliance=0.0, braking_trade=0.0)
    V = desired_speed
    own = dataclasses.replace(problem, max_lateral_accel=bound, max_longitudinal_accel=pf.max_longitudinal_accel,
                              rate_penalty=pf.rate_penalty)
    return PathFollowingSpec(
        problem=own, desired_speed=V, q_contour=pf.q_contour, q_lag=pf.q_lag, q_heading=pf.q_heading,
        q_progress=pf.q_progress, progress_rate_penalty=pf.progress_rate_penalty,
        max_progress_speed=pf.max_progress_speed or 2.0 * V,
        yaw_compliance=lim.yaw_compliance if pf.compensate_yaw_compliance else 0.0,
        braking_trade=lim.braking_trade if pf.braking_trade else 0.0,
        sample_time=problem.sample_time, slack_penalty=pf.slack_penalty, max_lag=pf.max_lag,
        servo_lateral_accel=(None if lim.servo_lateral_accel is None
                             else pf.lateral_accel_margin * lim.servo_lateral_accel),
        servo_longitudinal_accel=lim.servo_longitudinal_accel,
    )


def servo_limited(spec: PathFollowingSpec, effectiveness: np.ndarray) -> PathFollowingSpec:
    """The problem of ``spec`` with its bounds following the servos' remaining ``effectiveness`` [e_R, e_L]
    (fractions of gain and torque limit; the accommodation of a diagnosed servo loss).

    A servo at ``e`` has the torque ``e τ_max``, while the loads it must carry are the robot's: the yaw couple's
    tyre force grows with the lateral acceleration ``a`` and the wheel's share of the driving or braking force
    with ``dV/dt`` (:class:`~ftc_mj.plant.limits.ServoLimits`), so the weakest servo ``e = min(e_R, e_L)``
    carries ``e a_s`` and ``e a_x,s``. The lateral bound becomes ``min(A, e · margin · a_s)`` and the
    longitudinal ``min(a_lon, e a_x,s)``; with them the speed follows too, on a path of curvature ``κ`` at most
    ``√(A_e / |κ|)`` (the traction rows bound ``V ψ̇``). Unchanged where ``spec`` has no servo numbers (the
    kinematic plant) or no such bound."""
    e = float(np.clip(np.min(effectiveness), 0.0, 1.0))
    pr = spec.problem
    lat, lon = pr.max_lateral_accel, pr.max_longitudinal_accel
    if lat is not None and spec.servo_lateral_accel is not None:
        lat = min(lat, e * spec.servo_lateral_accel)
    if lon is not None and spec.servo_longitudinal_accel is not None:
        lon = min(lon, e * spec.servo_longitudinal_accel)
    return dataclasses.replace(spec, problem=dataclasses.replace(pr, max_lateral_accel=lat,
                                                                 max_longitudinal_accel=lon))


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

