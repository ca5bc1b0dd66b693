"""The sections of a run config (``robot``, ``plant``, ``model``, ``faults``, ``sensors``,
``estimator``, ``controller``, ``reconfiguration``, ``reference``, ``output``): one pydantic model
each, with the paper's values as defaults. SI units and radians throughout; the only
degree-valued fields end in ``_deg``.

A component's factory receives its own section (``estimator``, ``controller``, …) as its settings. The
estimation and reconfiguration sections are composed of the settings models declared beside their
components (:mod:`ftc_mj.estimation.setup`, :mod:`~ftc_mj.estimation.imm`,
:mod:`~ftc_mj.estimation.rule_statistics`, :mod:`ftc_mj.reconfiguration.policies`,
:mod:`~ftc_mj.reconfiguration.degraded`, :mod:`ftc_mj.control.excitation`); nothing here re-declares them. The
plant's sections (``robot``, ``plant``, ``model``, ``faults``) are declared beside the plant
(:mod:`ftc_mj.plant.settings`, the fault classes' tables in :mod:`ftc_mj.plant.faults`) and composed here.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import (
    Field,
    model_validator,
)

from ..control.excitation import ExcitationSettings
from ..estimation.imm import HypothesisSettings, IMMSettings
from ..estimation.rule_statistics import DecisionSettings
from ..fields import (
    FiniteFloat,
    Flag,
    NonNegFloat,
    Options,
    PathText,
    PosFloat,
    StrictModel,
    component,
    options_of,
    ranged,
    ranged_int,
)
from ..plant.settings import FaultSettings as FaultSettings  # the plant's sections, composed by RunConfig
from ..plant.settings import ModelSettings as ModelSettings
from ..plant.settings import PlantSettings as PlantSettings
from ..plant.settings import RobotSettings as RobotSettings
from ..reconfiguration.degraded import DegradedSettings
from ..reconfiguration.policies import ReconfigurationSettings

DecisionConfig = DecisionSettings
"""The ``[estimator.decision]`` section: :class:`~ftc_mj.estimation.rule_statistics.DecisionSettings`."""
HypothesisConfig = HypothesisSettings
"""One member of ``estimator.imm_bank``: :class:`~ftc_mj.estimation.imm.HypothesisSettings`."""
DegradedConfig = DegradedSettings
"""``[reconfiguration.degraded]``: :class:`~ftc_mj.reconfiguration.degraded.DegradedSettings`."""
ExcitationConfig = ExcitationSettings
"""``[reconfiguration.excitation]``: :class:`~ftc_mj.control.excitation.ExcitationSettings`."""


class EstimatorConfig(IMMSettings):
    """The ``[estimator]`` section: the FDI filter (paper §3) named by ``kind``, with the settings of the filters
    (:class:`~ftc_mj.estimation.setup.FilterSettings`) and of an IMM bank
    (:class:`~ftc_mj.estimation.imm.IMMSettings`), and the fault decision. Defaults are exactly the paper's
    values."""

    kind: component("estimators") = "ukf"
    """A registered estimator (:data:`ftc_mj.registry.estimators`). Built-in: ``ekf``, ``ukf``,
    ``imm-ekf``, ``imm-ukf`` (IMM banks of EKF/UKF members), ``none`` (no filter)."""
    decision: DecisionSettings = Field(default_factory=DecisionSettings)
    options: Options = Field(default_factory=dict, validate_default=True)
    """Settings of a plug-in estimator (its registered settings model); built-in estimators take none."""

    _options = options_of("estimators", "kind")


class PathFollowingConfig(StrictModel):
    """Settings of the path-following NMPC (``controller.kind = "pf-nmpc"``,
    :mod:`ftc_mj.control.pathfollow`). It shares ``nodes``, ``horizon``, ``omega_rate_max``, ``solver``,
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


ScenarioFraction = ranged(0.0, 2.0, lo_open=True)
"""A scenario radius as a fraction of the model radius, in (0, 2]."""


class RobustConfig(StrictModel):
    """Multi-stage robust NMPC (``controller.kind = "robust-nmpc"``; :mod:`~ftc_mj.control.robust`): one
    state trajectory per radius scenario, shared inputs over the robust horizon, all constraints in
    every scenario."""

    scenarios: list[tuple[ScenarioFraction, ScenarioFraction]] = Field(
        default_factory=lambda: [(1.0, 1.0), (0.5, 1.0), (1.0, 0.5), (0.5, 0.5)], min_length=1, max_length=16)
    """Scenario radii ``[R_R, R_L]`` as fractions of the model radii the reconfiguration policy hands over
    (the nominal radii under policy ``none``). Default: no fault, right at 50 %, left at 50 %, both at
    50 % (the 4-model IMM bank, in its order)."""
    weights: list[NonNegFloat] | None = None
    """Scenario weights (one per scenario, not all zero; normalised); unset = uniform."""
    robust_horizon_nodes: ranged_int(1, 200) | None = None
    """Input nodes shared by all scenarios (non-anticipativity); unset = every node inside the first
    control period (5 of the default 50). More shared nodes make the NLP harder
    (docs/config-defaults.md)."""
    objective: Literal["expected", "worst"] = "expected"
    """``expected``: the weighted mean of the scenario costs; ``worst``: their maximum over the
    scenarios of positive weight (an epigraph; needs ``controller.solver = "ipopt"``)."""
    weighting: Literal["fixed", "posterior"] = "fixed"
    """``fixed``: the configured weights (passive FTC). ``posterior``: at every solve the weights are
    the filter's posterior probabilities of the scenario radii (:mod:`~ftc_mj.reconfiguration.scenario_weights`;
    needs an estimator): a hybrid of passive and active FTC."""
    posterior_tolerance: ranged(0.0, 10.0, lo_open=True, unit="m") = 0.25
    """``posterior`` weighting: standard deviation (m) added to the filter's radius σ in every direction
    — how far the true radii may lie from a scenario and still count as that scenario."""
    posterior_floor: ranged(0.0, 1.0, hi_open=True) = 0.01
    """``posterior`` weighting: share of the weight spread uniformly over all scenarios whatever the
    filter says (no scenario is dismissed outright)."""
    prune_below: ranged(0.0, 1.0, hi_open=True) = 0.0
    """A scenario whose (normalised) weight is below this leaves the problem, cost and constraints (the
    one of largest weight never does); 0 = never. The default (floor 0.01, no pruning) was chosen by the
    rule of the development study ``robust_hybrid_dev`` (docs/findings.md)."""

    @model_validator(mode="after")
    def _weights_match(self) -> RobustConfig:
        """One weight per scenario, not all zero."""
        if self.weights is not None:
            if len(self.weights) != len(self.scenarios):
                raise ValueError(f"weights: {len(self.weights)} weights for {len(self.scenarios)} scenarios")
            if sum(self.weights) <= 0:
                raise ValueError("weights: must not all be zero")
        return self


class ControllerConfig(StrictModel):
    """Trajectory-tracking controller (paper §3)."""

    kind: component("controllers") = "nmpc"
    """A registered controller (:data:`ftc_mj.registry.controllers`). Built-in: ``nmpc``, ``lmpc``,
    ``open-loop``, ``pf-nmpc`` (path following on the geometric path, settings in ``path_following``),
    ``robust-nmpc`` (the multi-stage robust NMPC over radius scenarios, settings in ``robust``)."""
    rate: ranged(0.0, 1.0e3, lo_open=True, unit="Hz") = 10.0
    """Control rate (Hz); commands are held (zero-order hold) between solves."""
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
    solver: Literal["ipopt", "rti-daqp", "rti-qpoases", "rti-osqp"] = "rti-daqp"
    """NMPC solver. ``ipopt``: full NLP solve each sample (warm-started). ``rti-<qp>``: real-time
    iteration — one Gauss–Newton SQP step per sample on the state-condensed QP, solved by the named
    CasADi QP plugin (daqp measured fastest, osqp slowest on this dense QP); the first solve, and a
    re-seed after repeated failures, is done by IPOPT."""
    lmpc_qpsol: Literal["daqp", "qpoases", "osqp"] = "daqp"
    """QP solver of the linear MPC (CasADi conic plugin)."""
    cold_time_budget: PosFloat | None = None
    """Wall-time budget (s) of a cold (first or re-seeding) solve; ``None`` = not enforced."""
    max_iter: ranged_int(0, 10_000) = 30
    """Iteration limit of the NLP solver (IPOPT); 0 forces a failure (used in tests). 30 is above what
    every successful solve of the paper's runs needed and bounds the time lost on a failing re-seed
    (docs/config-defaults.md)."""
    time_budget: PosFloat | None = None
    """Wall-time budget of one solve (s); an over-budget solve is counted and falls back to the shifted
    previous plan. ``None`` (default) = not enforced: a wall-clock rule makes results depend on machine
    load, and a run must be a pure function of its config and seed. Solve times are always reported
    (``solve_time_ms``, ``solves_over_period``)."""
    open_loop_omega: tuple[FiniteFloat, FiniteFloat] = (5.0, 5.0)
    """Constant wheel rates (rad/s) of the open-loop controller."""
    open_loop_schedule: Annotated[list[tuple[FiniteFloat, FiniteFloat, FiniteFloat]], Field(max_length=10_000)] = Field(
        default_factory=list)
    """Optional ``[t, omega_R, omega_L]`` breakpoints (piecewise-linear) for the open-loop controller."""
    options: Options = Field(default_factory=dict, validate_default=True)
    """Settings of a plug-in controller (its registered settings model); built-in controllers take none."""

    _options = options_of("controllers", "kind")
    path_following: PathFollowingConfig = Field(default_factory=PathFollowingConfig)
    robust: RobustConfig = Field(default_factory=RobustConfig)
    """Settings of the robust multi-stage NMPC (``kind = "robust-nmpc"``)."""


class ReconfigurationConfig(ReconfigurationSettings):
    """The ``[reconfiguration]`` section: the policy's settings (:class:`~ftc_mj.reconfiguration.policies.
    ReconfigurationSettings`), the excitation and the degraded mode."""

    excitation: ExcitationSettings = Field(default_factory=ExcitationSettings)
    degraded: DegradedSettings = Field(default_factory=DegradedSettings)


class ReferenceConfig(StrictModel):
    """Reference path and its time law."""

    kind: component("references") = "circle"
    """A registered reference path (:data:`ftc_mj.registry.references`). Built-in: ``circle``, ``line``,
    ``figure8``."""
    radius: PosFloat = 50.0
    """Circle radius (m) (figure-eight: lobe radius)."""
    speed: PosFloat = 10.0
    """Speed along the path (m/s)."""
    direction: Literal["ccw", "cw"] = "ccw"
    options: Options = Field(default_factory=dict, validate_default=True)
    """Settings of a plug-in reference (its registered settings model); built-in references take none."""

    _options = options_of("references", "kind")


class OutputConfig(StrictModel):
    dir: PathText = Path("runs/out")
    rrd: Flag = True
    progress: Flag = True

