"""The settings every MPC shares, the numbers of the tracking problem built from them, and the bound and
penalty of its first input.

:class:`MPCSettings` declares the MPCs' common settings once (the ``[controller]`` fields of ``lmpc``,
``nmpc``, ``pf-nmpc`` and ``robust-nmpc``); :class:`ProblemSpec` holds the numbers of one problem and has no
defaults of its own: :func:`tracking_problem` builds it from the settings and the run context. The problem
itself (cost, constraints, the LGL transcription) is described in :mod:`ftc_mj.control.transcription`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import Field

from ..context import RunContext
from ..fields import Flag, NonNegFloat, Options, PosFloat, component, options_of, ranged, ranged_int
from .base import ControllerSettings


class MPCSettings(ControllerSettings):
    """Settings every MPC shares: the LGL grid, the tracking weights, the input-rate bound and the budgets."""

    nodes: ranged_int(4, 200) = 50
    """LGL nodes N."""
    horizon: ranged(0.0, 60.0, lo_open=True, unit="s") = 5.0
    """Prediction horizon (s)."""
    q_pose: NonNegFloat = 10.0
    q_speed: NonNegFloat = 1.0
    q_yaw_rate: NonNegFloat = 1.0
    rate_penalty: NonNegFloat = 0.0
    """Weight on the squared wheel acceleration (rad/s^2)^2 in the cost; 0 = the paper's cost."""
    omega_rate_max: PosFloat = 20.0
    """Input-rate bound |d omega / dt| (rad/s^2)."""
    rate_bound_from_applied: Flag = True
    """Bound the first input of every NMPC/LMPC plan relative to the command in force on the plant:
    ``|U(t0) − u_applied| ≤ omega_rate_max / rate`` per wheel (and, with ``rate_penalty``, penalise that
    step like the in-plan rates), so consecutive commands differ by at most that much (with the
    excitation dither on, the dithered command is clipped to the same step). ``False`` reproduces the
    earlier formulation, where the rate bound held only inside each plan and the command could jump
    between the wheel-rate limits from one sample to the next."""
    rate_penalty_first_step: Flag = False
    """With ``rate_penalty > 0`` and ``rate_bound_from_applied``: the rate penalty also covers the step
    from the command in force, weighted as that step spread over one controller period,
    ``rate_penalty T_s ‖(U(t0) − u_applied)/T_s‖²`` (the in-plan term is ``rate_penalty ∫ ‖dU/dt‖² dt``).
    ``False`` (default) keeps the bound and penalises the rates inside the plan only. The step penalty
    pulls ``U(t0)`` towards the command in force, i.e. it gives the command inertia (phase lag in the
    loop): on the MuJoCo robot, at this weight, it destabilises the rate-penalised loop even without a
    fault (measured in docs/findings.md), so it is off unless asked for."""
    max_lateral_accel: PosFloat | None = None
    """Bound (m/s²) on the lateral acceleration ``V ψ̇`` the NMPC may plan at every node; ``None`` =
    the paper's problem (no bound). The MuJoCo robot (2 m wheels, 1 m half track, centre of mass 1.09 m
    high) starts lifting its inner wheel at 3.9 m/s² in a quasi-steady turn (derived from the MJCF,
    :mod:`ftc_mj.plant.limits`; measured 4.1–4.2 m/s²), less in transients; the 50 m circle at 10 m/s needs 2.
    The model's ``V ψ̇`` of the commanded rates is 1.375 times the robot's at 10 m/s (servo compliance)."""
    max_longitudinal_accel: PosFloat | None = None
    """Bound (m/s²) on the longitudinal acceleration ``dV/dt`` the NMPC/LMPC may plan at every node (linear
    in the wheel accelerations for given radii); ``None`` = no bound. With ``max_lateral_accel`` it bounds
    what tips this tall robot over in roll and pitch; both off by default (trade-offs in docs/findings.md)."""
    time_budget: PosFloat | None = None
    """Wall-time budget of one solve (s); an over-budget solve is counted and falls back to the shifted
    previous plan. ``None`` (default) = not enforced: a wall-clock rule makes results depend on machine
    load, and a run must be a pure function of its config and seed. Solve times are always reported
    (``solve_time_ms``, ``solves_over_period``)."""


class PluginControllerSettings(MPCSettings):
    """Settings of a plug-in controller (a kind a plug-in module registered): the MPC settings the loop reads
    of a ``rate_bounded`` controller and the plug-in's own ``options``, checked against the settings model it
    was registered with."""

    kind: component("controllers")
    """A registered controller (:data:`ftc_mj.registry.controllers`)."""
    options: Options = Field(default_factory=dict, validate_default=True)
    """Settings of the plug-in controller (its registered settings model)."""

    _options = options_of("controllers", "kind")


@dataclass(frozen=True)
class ProblemSpec:
    """Numbers that define the tracking problem (units in the field comments); built by
    :func:`tracking_problem` from :class:`MPCSettings` (whose docstrings explain each) and the run context."""

    nodes: int
    horizon: float  # s
    half_track: float  # m
    omega_max: float  # rad/s
    omega_rate_max: float  # rad/s^2
    q_pose: float
    q_speed: float
    q_yaw_rate: float
    rate_penalty: float
    max_lateral_accel: float | None  # m/s^2; None = no bound (the paper's problem)
    max_longitudinal_accel: float | None  # m/s^2; None = no bound
    sample_time: float  # s, controller period T_s (the command is held that long)
    rate_bound_from_applied: bool  # |U(t0) - u_prev| <= omega_rate_max T_s; False = free first input
    rate_penalty_first_step: bool  # rate_penalty also covers U(t0) - u_prev (with the bound on)


def tracking_problem(settings: MPCSettings, context: RunContext) -> ProblemSpec:
    """The MPC problem numbers from the MPC settings (weights, nodes, horizon, rate bounds) and the run context
    (the model's half track (m), the robot's ``omega_max`` (rad/s), the controller period (s))."""
    c = settings
    return ProblemSpec(
        nodes=c.nodes, horizon=c.horizon, half_track=context.half_track, omega_max=context.omega_max,
        omega_rate_max=c.omega_rate_max, q_pose=c.q_pose, q_speed=c.q_speed, q_yaw_rate=c.q_yaw_rate,
        rate_penalty=c.rate_penalty, max_lateral_accel=c.max_lateral_accel,
        max_longitudinal_accel=c.max_longitudinal_accel, sample_time=context.controller_dt,
        rate_bound_from_applied=c.rate_bound_from_applied, rate_penalty_first_step=c.rate_penalty_first_step,
    )


def first_input_bounds(spec: ProblemSpec, u_prev: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Bounds ``lo ≤ U(t0) ≤ hi`` (rad/s, each (2,) [omega_R, omega_L]) on the plan's first input.

    ``u_prev`` (rad/s) is the input in force before ``t0``; the bound is
    ``|U(t0) − u_prev| ≤ omega_rate_max T_s`` intersected with ``|U(t0)| ≤ omega_max``, with ``u_prev``
    first clipped to the input bounds so that the interval is never empty. ``None``: no first-step
    bound (only ``|U(t0)| ≤ omega_max``).
    """
    om = spec.omega_max
    if u_prev is None:
        return np.full(2, -om), np.full(2, om)
    u = np.asarray(u_prev, dtype=float).ravel()
    if u.shape != (2,) or not np.all(np.isfinite(u)):
        raise ValueError(f"u_applied must be two finite wheel rates (rad/s), got {u_prev!r}")
    u = np.clip(u, -om, om)
    step = spec.omega_rate_max * spec.sample_time
    return np.maximum(u - step, -om), np.minimum(u + step, om)



def first_step_penalty(spec: ProblemSpec, u_prev: np.ndarray | None) -> float:
    """Weight ``c`` of the first-step penalty ``c ‖U(t0) − u_prev‖²`` (rad/s)⁻² per unit cost:
    ``rate_penalty T_s ‖(U(t0) − u_prev)/T_s‖² = (rate_penalty / T_s) ‖U(t0) − u_prev‖²``; 0 without
    ``u_prev``, without the rate penalty or with ``rate_penalty_first_step`` off."""
    return 0.0 if u_prev is None or not spec.rate_penalty_first_step else spec.rate_penalty / spec.sample_time

