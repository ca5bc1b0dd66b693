"""The sections of a run config (``robot``, ``plant``, ``model``, ``faults``, ``sensors``,
``estimator``, ``controller``, ``reconfiguration``, ``reference``, ``output``): one pydantic model
each, with the paper's values as defaults. SI units and radians throughout; the only
degree-valued fields end in ``_deg``.

A component's factory receives its own section (``estimator``, ``controller``, …) as its settings. The
plant's sections (``robot``, ``plant``, ``model``, ``faults``) are declared beside the plant
(:mod:`ftc_mj.plant.settings`, the fault classes' tables in :mod:`ftc_mj.plant.faults`) and composed here.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    Field,
    Strict,
    model_validator,
)

from ..fields import (
    FiniteFloat,
    Flag,
    Fraction,
    NonNegFloat,
    Options,
    PathText,
    PosFloat,
    Rate,
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


class DecisionConfig(StrictModel):
    """Fault-decision rule on top of the estimator."""

    rule: component("decision_rules") = "auto"
    """A registered decision rule (:data:`ftc_mj.registry.decision_rules`). Built-in: ``sigma``: a radius
    departs from nominal by ``k_sigma`` standard deviations and by at least ``min_drop`` for ``dwell``
    seconds; ``mode``: the probability of a fault class of an IMM bank's declared hypotheses above
    ``mode_threshold`` for ``dwell`` seconds; ``auto``: ``mode`` for an estimator that declares
    hypotheses (IMMs), else ``sigma``; ``cusum`` / ``glr``: a CUSUM / Willsky–Jones GLR on the whitened
    innovations crosses the threshold set for a mean time between false alarms ``arl0``
    (:mod:`ftc_mj.estimation.change`)."""
    k_sigma: PosFloat = 3.0
    min_drop: NonNegFloat = 0.1
    """Minimum radius departure (m) for the sigma rule (guards against tiny-σ false alarms)."""
    dwell: NonNegFloat = 0.5
    """Time (s) the condition must hold before a fault is declared. It trades false alarms and false
    isolations against the delay of a reconfiguration. Chosen by the rule of the built-in study
    ``tune_dwell`` on the development seeds 0–9: the smallest dwell without a false alarm or false
    isolation in any run (the measurements: docs/studies.md)."""
    mode_threshold: Fraction = 0.9
    max_split_sigma: PosFloat = 0.15
    """Sigma rule: a wheel is isolated only when the σ (m) of the radius split along the direction
    the speed cannot observe is at most this; otherwise the declared wheel is ``'unknown'``."""
    arl0: PosFloat = 100.0
    """``cusum``/``glr`` rules: target mean time (s) between false alarms; sets their thresholds."""
    cusum_shift: PosFloat = 1.0
    """CUSUM design shift (σ of the whitened innovation) the test is tuned to detect fastest."""
    glr_window: PosFloat = 0.5
    """GLR: onsets considered (s back from the current step); the filter absorbs a radius jump well within
    it, after which a jump leaves no trace in the innovations."""
    change_holdoff: NonNegFloat = 2.0
    """``cusum``/``glr``: time (s) after a declared change during which further threshold crossings only
    re-anchor the residual generator and add no wheel: on the physical plant a puncture is followed by a
    transient the constant-radius model cannot explain (the tyre settling, wheel slip, the controller's
    reaction), which the detectors would otherwise read as further changes."""
    isolation_llr: PosFloat = 4.6
    """``cusum``/``glr``: a wheel is isolated when its hypothesis leads the runner-up by this log-likelihood
    ratio (nats; 4.6 ≈ 99:1 odds); otherwise the declared wheel is ``'unknown'``."""
    statistics: Flag = False
    """Compute every rule's decision statistic each step and log it in the trace (``*_stat`` columns), so
    that thresholds can be swept afterwards without re-running (``ftc-mj fdi-curves``); it costs CPU time
    at every filter step (measured in docs/fdi.md). The ``cusum`` and ``glr`` rules compute their own
    statistic regardless."""
    options: Options = Field(default_factory=dict, validate_default=True)
    """Settings of a plug-in rule (its registered settings model); built-in rules take none."""

    _options = options_of("decision_rules", "rule")


class HypothesisConfig(StrictModel):
    """One member of a custom IMM bank (``estimator.imm_bank``): what it assumes about the wheel radii."""

    name: Annotated[str, Strict(), Field(min_length=1, max_length=60)]
    """Shown in events and figures, e.g. ``"left 30 %"``."""
    frac_R: ranged(0.0, 1.0, lo_open=True) = 1.0
    """Right radius as a fraction of nominal (1 = healthy; a puncture makes a radius smaller)."""
    frac_L: ranged(0.0, 1.0, lo_open=True) = 1.0
    """Left radius as a fraction of nominal."""
    ramp: Flag = False
    """The left radius deflates linearly at ``estimator.ramp_rate`` from the bank's estimate (a ramp
    hypothesis; ``frac_L`` is then not used) instead of a step to ``frac_L``."""


class EstimatorConfig(StrictModel):
    """The FDI filter (paper §3). Defaults are exactly the paper's values."""

    kind: component("estimators") = "ukf"
    """A registered estimator (:data:`ftc_mj.registry.estimators`). Built-in: ``ekf``, ``ukf``,
    ``imm-ekf``, ``imm-ukf`` (IMM banks of EKF/UKF members), ``none`` (no filter)."""
    rate: Rate = 100.0
    """Filter rate (Hz); dt = 1/rate."""
    imm_models: Literal[4, 5] = 4
    """The paper's IMM bank: 4 models (no fault, 50 % right, 50 % left, both 50 %) or 5 (plus a left
    ramp). Not used with ``imm_bank``."""
    imm_bank: Annotated[list[HypothesisConfig], Field(min_length=2, max_length=12)] | None = None
    """A custom IMM bank: its members' hypotheses, in order (``None`` = the paper's bank of
    ``imm_models`` members). The decision layer reads the hypotheses, whatever their number and order."""
    p_stay: Fraction | None = None
    """Diagonal of a custom bank's transition matrix (the rest shared equally); ``None`` =
    ``p_stay_4`` for banks of up to 4 members, else ``p_stay_5``."""
    imm_variant: Literal["hypothesis", "paper"] = "hypothesis"
    kappa: ranged(-5.0, 1.0e3, lo_open=True) = 0.001
    """Julier sigma-point parameter."""
    p0_sigma: tuple[PosFloat, PosFloat, PosFloat, PosFloat, PosFloat] = (0.5, 0.5, math.radians(1.0), 0.5, 0.5)
    """Initial standard deviations of [x, y, psi, R_R, R_L] (m, m, rad, m, m)."""
    q_diffusion: tuple[NonNegFloat, NonNegFloat, NonNegFloat, NonNegFloat, NonNegFloat] = (0.25, 0.25, 1e-4, 0.04, 0.04)
    """Process noise as a diffusion per second of [x, y, psi, R_R, R_L] (m²/s, m²/s, rad²/s, m²/s, m²/s):
    ``Q = diag(q_diffusion · dt)`` per filter step, so the filter's model does not change with
    ``rate``. The default is the paper's ``Q = diag((q · dt)²)``, ``q = (5, 5, 0.1, 2, 2)``, at its
    100 Hz (``q² / 100``), bit for bit."""
    initial_radii: tuple[PosFloat, PosFloat] | None = None
    """Initial radius estimates (m); ``None`` = the model's nominal radius."""
    p_stay_4: Fraction = 0.97
    p_stay_5: Fraction = 0.96
    ramp_rate: PosFloat = 0.1
    """Deflation rate (m/s) hypothesised by the 5th (linear puncture) IMM model."""
    min_radius: PosFloat = 0.05
    """Floor (m) for radius estimates handed on (and for the ramp hypothesis)."""
    hypothesis_sigma: PosFloat = 0.05
    """IMM ``hypothesis`` variant: std (m) of a member's hypothesised radius, re-imposed at every
    prediction (tolerance for small modelling errors such as tyre compression)."""
    nis_gate: PosFloat = 1.0e4
    """An innovation with NIS above this is rejected as an outlier (not used to update)."""
    divergence_nis: PosFloat = 50.0
    """NIS above this for ``divergence_dwell`` seconds counts as divergence (reset)."""
    divergence_dwell: PosFloat = 1.0
    reset_inflation: PosFloat = 10.0
    """Covariance inflation factor on a divergence reset."""
    decision: DecisionConfig = Field(default_factory=DecisionConfig)
    options: Options = Field(default_factory=dict, validate_default=True)
    """Settings of a plug-in estimator (its registered settings model); built-in estimators take none."""

    _options = options_of("estimators", "kind")

    @model_validator(mode="before")
    @classmethod
    def _no_q_rate(cls, data: Any) -> Any:
        """``q_rate`` (``Q = diag((q_rate · dt)²)``, which retuned the filter with its rate) was replaced
        by the rate-invariant ``q_diffusion``: say how to convert instead of "unknown key"."""
        if isinstance(data, dict) and "q_rate" in data:
            raise ValueError("q_rate: replaced by q_diffusion (per second, rate-invariant): "
                             "q_diffusion = q_rate² / rate, e.g. (0.25, 0.25, 1e-4, 0.04, 0.04) at 100 Hz")
        return data

    @model_validator(mode="after")
    def _bank(self) -> EstimatorConfig:
        """A custom bank replaces ``imm_models`` (not both) and its hypotheses have distinct names."""
        if self.imm_bank is not None:
            if "imm_models" in self.model_fields_set:
                raise ValueError("imm_models: give either imm_models (the paper's banks) or imm_bank, not both")
            names = [h.name for h in self.imm_bank]
            if len(set(names)) != len(names):
                raise ValueError("imm_bank: hypothesis names must differ")
        return self

    @property
    def bank_size(self) -> int:
        """Members of the IMM bank (``imm_bank`` if given, else ``imm_models``)."""
        return len(self.imm_bank) if self.imm_bank is not None else self.imm_models


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


class ExcitationConfig(StrictModel):
    """Yaw-rate dither while a fault is suspected but not isolated (off by default).

    With speed-only sensing the split between the radii is seen only through turning
    (``ω_R − ω_L``). The dither adds ``δψ̇ = amplitude · sin(2π t / period)`` to the commanded yaw
    rate at constant model speed (:mod:`~ftc_mj.control.excitation`); at 10 m/s every 0.1 rad/s of
    amplitude is 1 m/s² of extra lateral acceleration (the robot starts lifting a wheel at 3.9 m/s² in a
    quasi-steady turn, :mod:`ftc_mj.plant.limits`; the circle itself needs 2)."""

    enabled: Flag = False
    amplitude: ranged(0.0, 1.0, lo_open=True, unit="rad/s") = 0.05
    """Yaw-rate dither amplitude (rad/s)."""
    period: PosFloat = 2.0
    """Dither period (s)."""


class DegradedConfig(StrictModel):
    """The degraded mode and the no-slip test of the identification (:mod:`~ftc_mj.reconfiguration.degraded`):
    from the first alarm until the fault is isolated and identified, the model radius of each suspect wheel
    follows its estimate down (an upper bound of the true radius while the tyre is dragged), a controller that
    takes radius intervals (``pf-nmpc``) bounds the robot's lateral acceleration over each suspect wheel's
    interval, and a wheel whose estimate moves faster than a tyre's radius can (a skid) is not identified."""

    mode: Literal["auto", "on", "off"] = "auto"
    """``auto`` (default): on with the ``safe`` policy, a controller registered to take radius intervals
    (``pf-nmpc``), a sensor that tells the wheels apart (a yaw-rate gyro or position fixes) and a plant whose
    tyres can slide (MuJoCo; on the kinematic plant the estimate is no upper bound and following it made
    scenarios 2 and 3 worse, docs/config-defaults.md), else off;
    ``on``: with any policy but ``none`` and ``truth`` (and such a controller); ``off``: never. From the first
    alarm the model radius of a suspect wheel follows its estimate down; with it the pf-nmpc's lift-off after
    a puncture fell from 0.25–1.05 s to 0.03–0.11 s on the development seeds 0–5 (docs/findings.md)."""
    min_radius: PosFloat = 0.05
    """Smallest radius (m) a fault can leave: the floor of a suspect wheel's interval and model radius (the tyre
    down to its rim; scenario 4 deflates to 0.1 m)."""
    depth: NonNegFloat = 0.0
    """How far (m) below the estimate a suspect wheel's interval reaches: the lateral bound holds for every
    radius in ``[max(min_radius, estimate − depth), estimate]``. 0 (default): the point the model uses. On the
    development seeds 0–5 a depth of 0.2 m and 0.5 m lengthened the lift-off (scenario 3: 0.05–0.11 s at 0,
    0.17–0.36 s at 0.2, 0.31–0.53 s at 0.5): the rows brake the robot, which drags the punctured tyre harder."""
    skid_window: ranged(0.02, 10.0, unit="s") = 0.5
    """Window (s) of the no-slip test: the mean estimate of its second half is compared with that of its first."""
    max_radius_rate: NonNegFloat = 0.2
    """Fastest change (m/s) of a rolling tyre's radius the no-slip test accepts (a deflation; scenario 4's is
    0.1 m/s). A skid moved the estimate at 0.4–1.2 m/s in the measured case (docs/findings.md)."""
    skid_k_sigma: NonNegFloat = 2.0
    """Allowance of the no-slip test for the estimate's own scatter, in standard deviations of the radius."""


class ReconfigurationConfig(StrictModel):
    """How the estimated radii reach the controller's model (:mod:`ftc_mj.reconfiguration.policies`)."""

    policy: component("policies") = "safe"
    """A registered reconfiguration policy (:data:`ftc_mj.registry.policies`). Built-in: ``none``:
    nominal radii (the paper's "feedback off"). ``direct``: the latest estimate at every solve (the
    paper's "feedback on"). ``safe``: hand radii over only after the fault decision has
    declared and isolated a fault and the estimate is identified (σ of each radius and of the
    unobservable split below ``max_sigma``, innovations consistent); clamped to
    [``min_radius``, nominal], rate-limited to ``max_rate``; reverts to the last trusted values on
    filter divergence and to nominal when the decision is withdrawn. ``truth``: the true radii
    (an oracle upper bound for comparisons; not realisable)."""
    max_sigma: PosFloat = 0.1
    """Largest standard deviation (m) of each radius and of the radius split accepted for hand-over."""
    min_radius: PosFloat = 0.05
    """Lower clamp (m) of a handed-over radius (upper clamp: the nominal radius)."""
    max_rate: PosFloat = 5.0
    """Largest change of a handed-over radius (m/s): a 50 % step (1 m) is handed over in 0.2 s."""
    max_growth_rate: NonNegFloat = 0.05
    """Largest *increase* (m/s) of a handed-over radius while the fault stays declared. A punctured tyre
    does not re-inflate: an estimate that grows quickly is the filter leaving the kinematic model's
    domain (a lifted or skidding wheel), not the tyre; this rate still lets the model radius recover
    from a transient undershoot (0.2 m in 4 s). Reverts (filter trouble, withdrawn decision) are not
    limited by it. Chosen by the rule of the built-in study ``tune_growth`` on the development seeds
    0–9 (docs/studies.md)."""
    condition_on_healthy: Literal["auto"] | Flag = "auto"
    """With one wheel isolated, hand over the filter's estimate of its radius *conditioned on the other wheel's
    radius being nominal* (``R_iso + P_io / P_oo (R_nom − R_other)``, the Gaussian posterior given what the
    decision asserts) instead of the raw estimate. The filter's two radii errors are strongly correlated (ρ ≈
    0.995 with a yaw-rate gyro: a common scale error, while the ratio is well identified); pairing the raw
    estimate of one wheel with the nominal other turns that scale error into a ratio, i.e. yaw-rate, error of
    the controller's model. ``auto`` (default): on with a controller registered to take radius intervals
    (``pf-nmpc``), off with the others (the time-parametrised NMPC tipped over with it in scenarios 3 and 4,
    docs/config-defaults.md); ``true``: on; ``false``: the raw estimate."""
    nis_window: PosFloat = 1.0
    """Window (s) of the innovation-consistency check (mean NIS)."""
    max_nis_ratio: PosFloat = 5.0
    """Mean NIS per measurement over ``nis_window`` above which the filter is taken as inconsistent:
    no new hand-over, and a revert to the last trusted radii (a consistent filter gives ≈ 1)."""
    spike_nis_ratio: PosFloat = 12.0
    """A NIS per measurement above this at any step since the last solve *holds* the radii in use
    (a sudden jump of the estimate is not handed over; P(χ²₁ > 12) ≈ 5e-4)."""
    trust_lag: NonNegFloat = 1.0
    """On a revert, the last trusted radii are those handed over at least this long (s) before the
    filter reported trouble (its estimate may already have been drifting)."""
    excitation: ExcitationConfig = Field(default_factory=ExcitationConfig)
    degraded: DegradedConfig = Field(default_factory=DegradedConfig)
    options: Options = Field(default_factory=dict, validate_default=True)
    """Settings of a plug-in policy (its registered settings model); built-in policies take none."""

    _options = options_of("policies", "policy")


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

