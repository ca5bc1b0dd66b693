"""The sections of a run config (``robot``, ``plant``, ``model``, ``faults``, ``sensors``,
``estimator``, ``controller``, ``reconfiguration``, ``reference``, ``output``): one pydantic model
each, with the paper's values as defaults. SI units and radians throughout; the only
degree-valued fields end in ``_deg``.

A component's factory receives its own section (``estimator``, ``controller``, …) as its settings. The
control settings are declared beside their components and only composed here: ``controller`` is the union of
the controller kinds' models discriminated by ``kind`` (:data:`ControllerConfig`), ``reference`` the reference
path's model.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Literal, Union

from pydantic import (
    BeforeValidator,
    Discriminator,
    Field,
    SerializerFunctionWrapHandler,
    Strict,
    Tag,
    TypeAdapter,
    ValidationError,
    field_validator,
    model_serializer,
    model_validator,
)

from .. import resources
from ..control.base import ControllerSettings
from ..control.lmpc import LinearMPCSettings
from ..control.nmpc import NMPCSettings
from ..control.open_loop import OpenLoopSettings
from ..control.pathfollow import PathFollowingNMPCSettings
from ..control.reference import ReferenceSettings
from ..control.robust import RobustNMPCSettings
from ..control.spec import PluginControllerSettings
from ..fields import (
    DEFAULT_MODEL_FILE,
    FLOAT_BOUND,
    OMEGA_MAX,
    AngleDeg,
    FiniteFloat,
    Flag,
    Fraction,
    Length,
    NonNegFloat,
    Options,
    PathText,
    PosFloat,
    Rate,
    StrictModel,
    component,
    options_of,
    ranged,
)


class RobotConfig(StrictModel):
    """Nominal design shared by plant and model unless overridden there."""

    wheel_radius: Length = 2.0
    """Nominal wheel radius R0 (m)."""
    half_track: Length = 1.0
    """Half track b (m): wheel centre to axle midpoint; track width is 2b."""
    omega_max: ranged(0.0, 1.0e4, lo_open=True, unit="rad/s") = OMEGA_MAX
    """Wheel-rate limit (rad/s), symmetric."""


class PlantConfig(StrictModel):
    """Truth plant (MuJoCo). ``None`` means: take the value from ``robot``."""

    model_file: Annotated[str, BeforeValidator(lambda v: str(v) if isinstance(v, Path) else v), Strict()] = (
        DEFAULT_MODEL_FILE)
    """The MJCF robot: ``builtin:<name>`` for a model shipped in the package (the same robot on every
    machine, :mod:`ftc_mj.resources`), else a file path, stored absolute (relative paths are taken from
    the working directory) so that a resolved config re-runs from any directory."""
    variant: Literal["suspended", "rigid"] = "suspended"
    timestep: ranged(1.0e-5, 0.05, unit="s") = 0.001
    """Physics step (s)."""
    wheel_radius: Length | None = None
    half_track: Length | None = None
    chassis_mass: PosFloat | None = None
    """Chassis mass (kg); ``None`` keeps the MJCF value."""
    wheel_mass: PosFloat | None = None
    """Mass of one wheel (kg); ``None`` keeps the MJCF value."""
    tyre_friction: PosFloat | None = None
    """Sliding friction coefficient of the tyres; ``None`` keeps the MJCF value."""
    caster_friction: NonNegFloat = 0.0
    """Sliding friction of the caster(s); 0 = frictionless (the kinematic model's assumption)."""
    actuator_gain: PosFloat | None = None
    """Velocity-actuator gain kv (N m s/rad); ``None`` keeps the MJCF value."""
    payload_mass: ranged(0.0, 1.0e4, unit="kg") = 0.0
    """Mass (kg) of a payload fixed to the chassis (a uniform 0.4 m ball); 0 = none (the MJCF robot as it is).
    It adds to the chassis weight *after* the struts' preload is set, so they sag under it, and it moves the
    centre of mass, hence the load each tyre and the caster carry and the lift-off lateral acceleration."""
    payload_offset: tuple[FiniteFloat, FiniteFloat, FiniteFloat] = (0.0, 0.0, 0.0)
    """Position (m) of the payload's centre in the chassis frame: forward of the axle midpoint, to the left,
    and up from the hub height (the chassis frame's origin; negative = below the axle)."""
    initial_pose: tuple[FiniteFloat, FiniteFloat, FiniteFloat] = (0.0, 0.0, 0.0)
    """Initial (x, y, psi) of the axle midpoint (m, m, rad)."""
    start_moving: Flag = True
    """Start in steady motion at the reference's speed and yaw rate at t = 0 (the paper's runs begin on the
    path at 10 m/s); False = start from rest."""
    reseat_hub: Flag = True
    """Levelling suspension (suspended variant): on every radius change move the hub and its strut's spring
    reference by the radius change, so the tyre stays on the ground with the same load and the chassis level.
    ``False``: passive struts (a shrunken tyre hangs on its spring and the chassis rolls)."""
    kind: Literal["mujoco", "kinematic"] = "mujoco"
    """``mujoco``: the physical truth plant; ``kinematic``: the ideal kinematic model integrated exactly (RK4)."""
    wheel_load_fraction: Fraction = 0.7
    """Share of the chassis weight carried by the two wheel slides (suspended variant); the caster takes the rest.
    The builder sets the slide spring preload and the chassis centre of mass (x) from it."""
    slip_limit: PosFloat = 0.3
    """Longitudinal tyre slip speed (m/s) above which the plant raises the ``SLIP`` flag."""
    tilt_limit_deg: AngleDeg = 10.0
    """Roll or pitch (deg) above which the plant raises the ``LARGE_ROLL`` flag."""
    tipped_limit_deg: AngleDeg = 60.0
    """Roll or pitch (deg) above which the plant raises the ``TIPPED`` flag."""

    @model_serializer(mode="wrap")
    def _omit_no_payload(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        """The fields, without ``payload_mass``/``payload_offset`` when there is no payload: a run without one
        keeps the identity (run id, study key) it had before the payload existed."""
        data = handler(self)
        if not data.get("payload_mass"):
            data.pop("payload_mass", None)
            data.pop("payload_offset", None)
        return data

    @field_validator("model_file")
    @classmethod
    def _model_exists(cls, v: str) -> str:
        """A ``builtin:<name>`` model shipped in the package, else an existing file, stored absolute."""
        if not v.strip() or "\0" in v:
            raise ValueError("must be a non-empty path without NUL bytes (or builtin:<name>)")
        if resources.is_builtin_model(v):
            resources.model_path(v)  # ValueError naming the built-in models
            return v
        p = Path(v)
        try:
            p = p.absolute()
            found = p.is_file()
        except OSError as err:  # e.g. a name too long for the file system
            raise ValueError(f"cannot use {str(v)[:80]}: {err.strerror}") from None
        if not found:
            raise ValueError(f"model file not found: {v}")
        return str(p)


class ModelConfig(StrictModel):
    """What the filters and controllers assume. ``None`` means: take the value from ``robot``."""

    half_track: Length | None = None
    wheel_radius: Length | None = None


Breakpoints = Annotated[list[tuple[FiniteFloat, FiniteFloat]], Field(max_length=10_000)]


def _check_schedule(v: Breakpoints) -> Breakpoints:
    """``v`` if its times (s) are finite, non-negative and non-decreasing with at most two breakpoints at
    one time (a step), and its radii (m) finite and positive; else ``ValueError`` saying which."""
    last = -math.inf
    for t, r in v:
        if not (math.isfinite(t) and math.isfinite(r)):
            raise ValueError("breakpoints must be finite")
        if t < 0:
            raise ValueError(f"breakpoint time {t} is negative")
        if r <= 0:
            raise ValueError(f"radius {r} must be > 0")
        if t < last:
            raise ValueError(f"breakpoint times must be non-decreasing ({t} after {last})")
        last = t
    times = [t for t, _ in v]
    for i in range(len(times) - 2):
        if times[i] == times[i + 1] == times[i + 2]:
            raise ValueError(f"more than two breakpoints at t={times[i]}")
    return v


FaultTime = ranged(0.0, FLOAT_BOUND, unit="s")
"""A fault's onset (s): any time from 0; one after the end of a run never happens in it."""


class ActuatorFaultConfig(StrictModel):
    """One fault of a wheel's velocity servo (``[[faults.actuator]]``), permanent from ``onset``.

    ``loss``: loss of effectiveness, the servo's gain and its torque limit both scaled by
    ``effectiveness``; ``lock``: the wheel is held at zero rate (a seized bearing or gearbox);
    ``unresponsive``: the servo applies no torque and the wheel turns freely. The physics of each:
    :mod:`ftc_mj.plant.actuator_faults`.
    """

    wheel: Literal["right", "left"]
    kind: Literal["loss", "lock", "unresponsive"]
    onset: FaultTime
    effectiveness: ranged(0.0, 1.0, hi_open=True) | None = None
    """``loss`` only: the fraction of the servo's gain and torque limit that remains, in [0, 1)."""

    @model_validator(mode="after")
    def _effectiveness_for_loss(self) -> ActuatorFaultConfig:
        """``effectiveness`` is given for a ``loss`` and for nothing else."""
        if self.kind == "loss" and self.effectiveness is None:
            raise ValueError("effectiveness: a 'loss' needs the remaining fraction in [0, 1)")
        if self.kind != "loss" and self.effectiveness is not None:
            raise ValueError(f"effectiveness: only a 'loss' has one, not a {self.kind!r}")
        return self


class SensorFaultConfig(StrictModel):
    """One fault of a sensor (``[[faults.sensor]]``) from ``onset`` for ``duration`` seconds.

    ``bias``: a constant offset ``size`` (m/s for the speed sensor, rad/s for the gyro); ``drift``: an
    offset growing at ``size`` per second (m/s², rad/s²) from 0 at the onset; ``dropout``: the samples
    are missing (NaN in the reading; the filters update with the channels present). The physics of each:
    :mod:`ftc_mj.plant.sensor_faults`.
    """

    sensor: Literal["speed", "yaw_rate"]
    kind: Literal["bias", "drift", "dropout"]
    onset: FaultTime
    size: FiniteFloat | None = None
    """``bias``: the offset (m/s or rad/s); ``drift``: its growth rate (m/s² or rad/s²); not for ``dropout``."""
    duration: ranged(0.0, 1.0e9, lo_open=True, unit="s") = 1.0e9
    """How long the fault lasts (s); the default outlasts any run (at most 3600 s)."""

    @model_validator(mode="after")
    def _size_for_offsets(self) -> SensorFaultConfig:
        """``size`` is given for a ``bias`` or ``drift`` and not for a ``dropout``."""
        if self.kind != "dropout" and self.size is None:
            raise ValueError(f"size: a {self.kind!r} needs its size (m/s or rad/s; per second for a drift)")
        if self.kind == "dropout" and self.size is not None:
            raise ValueError("size: a 'dropout' has no size (its samples are missing)")
        return self


class FaultConfig(StrictModel):
    """The injected faults: tyre punctures, servo faults and sensor faults.

    ``right``/``left``: piecewise-linear wheel-radius schedules, lists of ``[t, radius]`` breakpoints.
    Before the first breakpoint the radius is the nominal one; after the last it is held. A step is
    two breakpoints at the same time. Empty = no fault on that wheel. ``actuator``/``sensor``: lists of
    :class:`ActuatorFaultConfig` / :class:`SensorFaultConfig` tables. Empty lists are left out of the
    resolved config, so a run without such faults has the identity (run id, study key) it had before
    they existed.
    """

    right: Breakpoints = Field(default_factory=list)
    left: Breakpoints = Field(default_factory=list)
    actuator: Annotated[list[ActuatorFaultConfig], Field(max_length=100)] = Field(default_factory=list)
    sensor: Annotated[list[SensorFaultConfig], Field(max_length=100)] = Field(default_factory=list)

    @field_validator("right", "left")
    @classmethod
    def _valid_schedule(cls, v: Breakpoints) -> Breakpoints:
        """Each wheel's schedule checked by :func:`_check_schedule`."""
        return _check_schedule(v)

    @model_serializer(mode="wrap")
    def _omit_empty(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        """The fields, without ``actuator``/``sensor`` when they are empty."""
        data = handler(self)
        for name in ("actuator", "sensor"):
            if not data.get(name):
                data.pop(name, None)
        return data




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


CONTROLLER_KINDS: dict[str, type[ControllerSettings]] = {
    "nmpc": NMPCSettings, "lmpc": LinearMPCSettings, "pf-nmpc": PathFollowingNMPCSettings,
    "robust-nmpc": RobustNMPCSettings, "open-loop": OpenLoopSettings}
"""The built-in controller kinds and their settings models (each declared beside its controller)."""


def _controller_tag(value: Any) -> str:
    """The union member of a ``[controller]`` table: its ``kind``'s model (``nmpc`` when not given), a plug-in's
    for any other name (checked against the registry there). Tags are not identifiers, so error messages name
    the field as the user wrote it (``controller.nodes``)."""
    kind = value.get("kind", "nmpc") if isinstance(value, dict) else getattr(value, "kind", None)
    return f"kind={kind}" if isinstance(kind, str) and kind in CONTROLLER_KINDS else "kind=plug-in"


def _is_default(model: type[ControllerSettings], key: str, value: Any) -> bool:
    """Whether ``value`` is ``model``'s default of its setting ``key`` (as validated by the field)."""
    f = model.model_fields[key]
    field_type = Annotated[(f.annotation, *f.metadata)] if f.metadata else f.annotation
    try:
        given = TypeAdapter(field_type).validate_python(value)
    except ValidationError:
        return False
    return bool(given == f.get_default(call_default_factory=True))


def _other_kinds_keys(value: Any) -> Any:
    """A ``[controller]`` table of a built-in kind holding a key of another kind only: a one-line error naming the
    key and the kinds that have it (``controller.nodes: not a setting of controller 'open-loop' …``). Such a key
    at that kind's default is dropped: a resolved config written when the section was one flat table (every
    kind's settings, the others' at their defaults) still reads as the run it was."""
    if not isinstance(value, dict):
        return value
    kind = value.get("kind", "nmpc")
    model = CONTROLLER_KINDS.get(kind) if isinstance(kind, str) else None
    out = dict(value)
    for key in value if model is not None else ():
        owners = [m for m in CONTROLLER_KINDS.values() if key in m.model_fields]
        if key in model.model_fields or not owners:
            continue
        if not _is_default(owners[0], key, value[key]):
            names = ", ".join(k for k, m in CONTROLLER_KINDS.items() if m in owners)
            raise ValueError(f"{key}: not a setting of controller {kind!r} (a setting of {names})")
        del out[key]
    return out


ControllerConfig = Annotated[
    Union[tuple(Annotated[m, Tag(f"kind={k}")] for k, m in  # noqa: UP007 - built from the table of kinds
                [*CONTROLLER_KINDS.items(), ("plug-in", PluginControllerSettings)])],
    Discriminator(_controller_tag), BeforeValidator(_other_kinds_keys)]
"""The trajectory-tracking controller (paper §3), discriminated by ``kind``: the built-in kinds' models
(:data:`CONTROLLER_KINDS`) or a plug-in's (its ``options``)."""


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


ReferenceConfig = ReferenceSettings
"""The reference path and its time law (:class:`~ftc_mj.control.reference.ReferenceSettings`)."""


class OutputConfig(StrictModel):
    dir: PathText = Path("runs/out")
    rrd: Flag = True
    progress: Flag = True

