"""The safe stop: brake to rest along the path without tipping, steering towards the path while slowing.

When the remaining actuation cannot follow the path (a locked wheel, a dead servo: the accommodation's
decision, :mod:`ftc_mj.reconfiguration.accommodation`), the robot is brought to rest instead of driven on.
:class:`SafeStop` is that reference and the feedback that tracks it, sample by sample:

*Speed.* A planned profile from the speed ``V_0`` (m/s) in force when the stop begins at ``t_0``:
``V(t) = max(V_0 − a (t − t_0), 0)`` with the deceleration ``a`` (m/s²) the smaller of ``deceleration`` and
the nominal robot's braking margin (``max_longitudinal_accel``). The profile is open loop on purpose: a
locked wheel skids, so neither its rate nor the speed measured from it says how fast the robot goes.

*Steering.* The curvature command ``κ = κ_p(s) − k_ψ sin e_ψ − k_c e_c`` about the nearest path point
``s`` (contouring error ``e_c``, m, positive left; heading error ``e_ψ``, rad) makes the errors, as
functions of the distance travelled, a second-order system ``e_c'' + k_ψ e_c' + k_c e_c = 0`` with natural
length ``settle_length`` ``L`` (m) and damping ``damping`` ``ζ``: ``k_c = 1/L²``, ``k_ψ = 2 ζ / L``. The yaw
rate is ``r = V κ``, clipped to the traction bound ``|V r| ≤ A − β a`` (the lift-off limit ``A`` of the
nominal robot times ``lateral_margin``, less the braking trade ``β`` per m/s² of braking,
:mod:`ftc_mj.plant.limits`): the stop never asks for a turn that lifts the inner wheel while it brakes.

*Wheels.* ``(ω_R, ω_L) = ((V + b r)/R_R, (V − b r)/R_L)`` with the radii the controller is given, clipped to
``±omega_max`` and to ``omega_rate_max T_s`` from the command in force. At rest (``V = 0``) both are 0.

*One wheel locked* (:meth:`SafeStop._locked`): the locked tyre skids, its drag slows the robot and yaws it
towards the locked side; the planned profile would make the other wheel *push* whenever that drag alone
brakes harder than the plan (scenario 2: the robot slowed at 3.2 m/s² with the other wheel on the 3 m/s²
plan), which stops the robot later and yaws it further. So the other wheel is commanded below its measured
rate — full braking torque — and its command is shifted by the heading error to the direction towards the path
(less braking, then drive, where the robot must turn towards the locked side).

*One servo unresponsive* (:meth:`SafeStop._one_wheel`): the free wheel neither drives nor brakes; the other
one steers, but never pushes the robot above the planned speed — faster than the plan, it brakes within the
traction bound, and the robot turns towards it as it slows. It cannot bring the robot to rest: the working wheel's
ground force ``F`` acts at its contact and the tyres' lateral forces along the axle through it, so the angular
momentum about that contact, ``H = M_rr r ∓ b M_vv v`` (``M_vv`` the mass, ``M_rr`` the yaw inertia about the
axle midpoint, both with the wheels' spin inertia; ``v``, ``r`` the axle midpoint's speed and the yaw rate), changes
only by ``H' = −m x_G r u`` (``m x_G``: mass × the centre of mass's lead on the axle; ``u``: the working wheel's
ground speed). Braking that wheel to rest leaves the robot pivoting about it at ``r = H / (M_rr + b² M_vv)`` for
ever (0.43 V₀ rad/s on the shipped robot); the fastest any law sheds ``H`` falls with ``H²`` (``1/|H|`` grows by at
most ``m x_G / (4 b M_vv (M_rr + b² M_vv))`` per s, 1/6448 on the shipped robot), so at rest takes minutes, not
seconds (docs/findings.md). So the working wheel does not brake to rest but to ``one_wheel_roll`` of the free
wheel's speed: the robot circles a fixed point at ``b (1 + k)/(1 − k)`` while ``H`` decays.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..fields import PosFloat, StrictModel, ranged
from ..model.kinematics import inverse_rates
from .base import ControlOutput
from .reference import Path, path_errors, project


class SafeStopSettings(StrictModel):
    """The safe stop's profile and steering (``[reconfiguration.accommodation.stop]``)."""

    deceleration: ranged(0.0, 20.0, lo_open=True, unit="m/s²") = 3.0
    """Planned braking (m/s²); capped by the nominal robot's ``max_longitudinal_accel`` when it has one.
    3 m/s² stops the robot from 10 m/s in 3.3 s (17 m)."""
    lateral_margin: ranged(0.0, 1.0, lo_open=True) = 0.8
    """Bound on ``|V r| + β a`` as a fraction of the nominal robot's lift-off lateral acceleration."""
    settle_length: PosFloat = 6.0
    """Natural length ``L`` (m) of the steering's error dynamics over the distance travelled."""
    damping: ranged(0.0, 5.0, lo_open=True) = 0.8
    """Damping ``ζ`` of the steering's error dynamics."""
    lock_brake: ranged(0.0, 10.0, unit="rad/s") = 0.5
    """With one wheel locked: how far below its measured rate (rad/s) the other wheel is commanded when the robot
    heads where it should — beyond the shipped servo's saturation (``τ_max / k_v`` = 0.15 rad/s), i.e. its full
    braking torque (:meth:`SafeStop._locked`)."""
    one_wheel_roll: ranged(0.0, 1.0, hi_open=True) = 0.2
    """With one servo unresponsive: the least fraction of the free wheel's ground speed at which the other wheel keeps
    rolling forward while it brakes (:meth:`SafeStop.one_wheel_floor`). 0 brakes it to rest, where the robot pivots
    about it for ever (the braking force cannot change the angular momentum about its contact); ``k`` > 0 lets the
    robot circle at ``b (1 + k)/(1 − k)`` (1.5 m at 0.2) around a fixed point while its spin decays as ``1/t``
    (docs/findings.md)."""
    lock_heading_gain: ranged(0.0, 100.0, unit="rad/s per rad") = 5.0
    """With one wheel locked: the other wheel's command (rad/s) per rad of heading error to the direction towards
    the path; 0.1 rad towards the locked side turns its full braking torque into full drive on the shipped
    robot."""


@dataclass(frozen=True)
class StopLimits:
    """The nominal robot's numbers the stop respects (SI units): its half track ``b`` (m), wheel-rate and
    wheel-acceleration bounds (rad/s, rad/s²), controller period (s), lift-off lateral acceleration (m/s²),
    braking trade (dimensionless) and the longitudinal bound of the controller (m/s², ``None``: none)."""

    half_track: float
    omega_max: float
    omega_rate_max: float
    sample_time: float
    liftoff_accel: float
    braking_trade: float
    max_longitudinal_accel: float | None


class SafeStop:
    """Brake to rest along ``path`` (module docstring): :meth:`begin` once, then :meth:`solve` every sample."""

    def __init__(self, settings: SafeStopSettings, limits: StopLimits, path: Path) -> None:
        self.settings = settings
        self.limits = limits
        self.path = path
        a = settings.deceleration
        if limits.max_longitudinal_accel is not None:
            a = min(a, limits.max_longitudinal_accel)
        self.deceleration = a
        self.max_lateral = max(settings.lateral_margin * limits.liftoff_accel - limits.braking_trade * a, 0.0)
        self.max_lateral_coasting = settings.lateral_margin * limits.liftoff_accel
        L = settings.settle_length
        self.k_contour = 1.0 / (L * L)
        self.k_heading = 2.0 * settings.damping / L
        self.t0 = 0.0
        self.v0 = 0.0
        self.s: float | None = None

    def begin(self, t: float, speed: float) -> None:
        """Start braking at ``t`` (s) from ``speed`` (m/s, the speed in force; a negative one brakes from 0)."""
        self.t0, self.v0, self.s = float(t), max(float(speed), 0.0), None

    def speed(self, t: float) -> float:
        """The planned speed (m/s) at ``t`` (s)."""
        return max(self.v0 - self.deceleration * (t - self.t0), 0.0)

    def rest_time(self) -> float:
        """When the planned speed reaches 0 (s)."""
        return self.t0 + self.v0 / self.deceleration

    def errors(self, pose: np.ndarray, V: float) -> tuple[float, float, float]:
        """``(e_c, e_psi, κ_p)``: the contouring error (m, positive left), the heading error (rad) and the path's
        curvature (1/m) at the path point nearest ``pose`` (searched around the last one, within the distance a
        robot at ``V`` m/s may have gone)."""
        x, y, psi = (float(v) for v in pose[:3])
        guess = 0.0 if self.s is None else self.s
        self.s = project(self.path, x, y, guess, max(2.0 * V, 10.0) if self.s is not None else 1.0e3, step=0.5)
        g = self.path.geometry(np.array([self.s]))
        ec = float(path_errors(self.path, np.array([x]), np.array([y]), np.array([self.s]))[0][0])
        return ec, float(np.angle(np.exp(1j * (psi - float(g.heading[0]))))), float(g.curvature[0])

    def yaw_rate(self, pose: np.ndarray, V: float, coasting: bool = False) -> float:
        """The yaw rate (rad/s) that steers towards the path at speed ``V`` (m/s), within the traction bound (while
        braking, or ``coasting`` without the braking trade)."""
        if V <= 0.0:
            return 0.0
        ec, e_psi, kappa_p = self.errors(pose, V)
        kappa = kappa_p - self.k_heading * np.sin(e_psi) - self.k_contour * ec
        r_max = (self.max_lateral_coasting if coasting else self.max_lateral) / V
        return float(np.clip(V * kappa, -r_max, r_max))

    def solve(self, t: float, pose: np.ndarray, radii: np.ndarray, u_applied: np.ndarray | None = None,
              free: int | None = None, rates: np.ndarray | None = None, locked: int | None = None) -> ControlOutput:
        """The wheel-rate command (rad/s) at ``t`` (s) from the pose [x, y, psi] (m, m, rad) and the radii
        [R_R, R_L] (m) the controller is given; ``u_applied`` is the command in force (rad/s). ``free`` (0 right,
        1 left): a wheel whose servo applies no torque, turning at the measured ``rates`` [omega_R, omega_L]
        (rad/s): only the other one acts (:meth:`_one_wheel`); ``locked``: a wheel that cannot turn, the other
        one brakes and steers (:meth:`_locked`)."""
        lim = self.limits
        ok = bool(np.all(np.isfinite(pose)))
        measured = rates is not None and bool(np.all(np.isfinite(rates)))
        if locked is not None and measured:
            om = self._locked(np.asarray(pose, dtype=float) if ok else None, radii, locked, rates)
        elif free is not None and measured:
            om = self._one_wheel(np.asarray(pose, dtype=float) if ok else None, radii, free, rates, self.speed(t))
        else:
            V = self.speed(t)
            r = self.yaw_rate(np.asarray(pose, dtype=float), V) if ok else 0.0
            om = np.array(inverse_rates(V, r, float(radii[0]), float(radii[1]), lim.half_track), dtype=float)
        if u_applied is not None and np.all(np.isfinite(u_applied)):
            step = lim.omega_rate_max * lim.sample_time
            om = np.clip(om, np.asarray(u_applied, float) - step, np.asarray(u_applied, float) + step)
        om = np.clip(om, -lim.omega_max, lim.omega_max)
        return ControlOutput(omega=om, status="safe stop")

    def _one_wheel(self, pose: np.ndarray | None, radii: np.ndarray, free: int, rates: np.ndarray,
                   planned: float = np.inf) -> np.ndarray:
        """Steering with one wheel. The free wheel neither drives nor brakes: its ground speed ``v_f = R_f omega_f``
        is what it is. The other wheel's speed is set for the yaw rate towards the path, ``v_R − v_L = 2 b r``
        (within the traction bound without braking), but never so that the robot's speed ``(v_R + v_L)/2`` exceeds
        the ``planned`` one (m/s): a robot faster than the plan is slowed by braking that wheel, within the coasting
        traction bound (``|r| ≤ margin · A / v_f``) and never below ``one_wheel_roll`` × ``v_f``
        (:meth:`one_wheel_floor`), and turns towards it while it slows. The heading such a
        stop turns through grows with ``ln(V_0/V)`` whatever the profile (the braking force on one side is the yaw
        couple), so where the path turns towards the free wheel the robot leaves it on the other side — slowing,
        instead of driving faster to turn with the path (docs/findings.md). A free wheel rolling backwards
        (``v_f < 0``) is met by braking the other wheel to rest: backwards, with the centre of mass ahead of the
        axle, any rolling between 0 and ``v_f`` makes the angular momentum grow (``H' = −m x_G r u``), and following
        ``v_f`` would coast the robot straight on for ever; braked, it pivots about that wheel."""
        b = self.limits.half_track
        v_free = float(radii[free]) * float(rates[free])
        om = np.array(rates, dtype=float)
        if v_free < 0.0:
            om[1 - free] = 0.0
            return om
        V = max(v_free, 0.0)
        r = self.yaw_rate(pose, V, coasting=True) if pose is not None else 0.0
        sign = 1.0 if free == 1 else -1.0  # v_R − v_L = 2 b r
        v_other = v_free + sign * 2.0 * b * r
        if V > 0.0 and v_other > 2.0 * planned - v_free:  # faster than the plan: brake, within the traction bound
            v_other = min(v_other, max(2.0 * planned - v_free, self.one_wheel_floor(V), 0.0))
        om[1 - free] = v_other / float(radii[1 - free])
        return om

    def one_wheel_floor(self, v_free: float) -> float:
        """The least ground speed (m/s) the working wheel brakes to while the free wheel rolls forward at ``v_free``
        (m/s, > 0): the larger of the traction bound and ``one_wheel_roll`` × ``v_free``. The traction bound holds
        the yaw rate ``(v_free − u) / (2 b)`` towards the working wheel within the coasting bound ``A / v_free``
        (the free wheel's speed standing for the robot's, which is lower: measured on the plant, the robot's actual
        ``(u + v_free)/2`` in that bound lifts a wheel for up to 0.36 s, dev draw 28). Rolling forward (``k > 0``)
        while the robot turns towards the working wheel is what sheds the angular momentum braking cannot (module
        docstring): the robot then circles at ``b (1 + k)/(1 − k)`` around a fixed point."""
        b, a = self.limits.half_track, self.max_lateral_coasting
        return max(v_free - 2.0 * b * a / v_free, self.settings.one_wheel_roll * v_free)

    def _locked(self, pose: np.ndarray | None, radii: np.ndarray, locked: int, rates: np.ndarray) -> np.ndarray:
        """Braking and steering with the one wheel that turns, the other locked and skidding. The locked tyre's
        drag ``D`` (its friction, ≈ μ N) slows the robot and yaws it towards the locked side with ``b D``; the other
        wheel's force ``u`` adds ``−u`` to the drag and ``± b u`` to the yaw moment. Its full braking torque stops
        the robot soonest and yaws it least towards the locked side, so that is the law while the robot heads where
        it should: the command ``lock_brake`` below the wheel's measured rate (a planned profile would make the
        wheel push whenever the drag alone brakes harder than the plan). The heading error to the direction
        ``ψ_d = θ(s) − atan(e_c / L)`` (towards the path over the settle length ``L``) shifts it by
        ``lock_heading_gain`` per rad: heading too far away from the locked side, the wheel brakes less, then
        drives (the yaw moment grows towards the locked side). The command never reverses the wheel; at rest it
        is 0 (the servo holds the wheel)."""
        w = 1 - locked
        s = self.settings
        om = np.zeros(2)
        rate = float(rates[w])
        if rate <= 0.0:
            return om
        turn = 0.0
        if pose is not None:
            ec, e_psi, _ = self.errors(pose, float(radii[w]) * rate)
            d_psi = -float(np.arctan(ec / s.settle_length)) - e_psi  # ψ_d − ψ, rad (positive: turn left)
            turn = (1.0 if w == 0 else -1.0) * s.lock_heading_gain * d_psi  # the right wheel's force yaws left
        om[w] = float(np.clip(rate - s.lock_brake + turn, 0.0, rate + s.lock_brake))
        return om
