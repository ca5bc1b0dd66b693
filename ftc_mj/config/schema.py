"""The run config, :class:`RunConfig`: every section, the checks across sections (rates, the robust
NMPC's solver), the resolved values (plant and model geometry, step ratios), and the small
:class:`~ftc_mj.context.RunContext` built from it.

A run is a pure function of the resolved config (including ``seed``).
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field, SerializerFunctionWrapHandler, Strict, model_serializer, model_validator

from .. import registry
from ..context import RunContext
from ..control.nmpc import NMPCSettings
from ..control.reference import ReferenceSettings
from ..estimation.diagnosis import ResidualDiagnoserSettings
from ..estimation.ukf import UKFSettings
from ..fields import Flag, SafeName, StrictModel, ranged, ranged_int
from ..model.sensors import SensorSettings
from ..plant.faults import SERVO_CLASSES, PlantFault, fault_class
from .sections import (
    ControllerConfig,
    DiagnosisConfig,
    EstimatorConfig,
    FaultSettings,
    ModelSettings,
    OutputConfig,
    PlantSettings,
    ReconfigurationConfig,
    RobotSettings,
)


class RunConfig(StrictModel):
    """A complete run. The keys scripts rely on keep their names: ``duration``, ``seed``, ``feedback``,
    ``sensors.*``, ``estimator.kind``, ``controller.kind``."""

    name: SafeName = "run"
    """Names the run's output folder: one plain file-name component (:data:`NAME_RE`)."""
    plugins: Annotated[list[Annotated[str, Strict()]], Field(max_length=50)] = Field(default_factory=list)
    """Modules to import before the rest is validated (``["my_pkg.filters"]``): importing them registers
    the components they define (:func:`ftc_mj.registry.load_plugins`), in every process that validates
    the config — Dask workers included."""
    description: Annotated[str, Strict(), Field(max_length=2000)] = ""
    duration: ranged(0.0, 3600.0, lo_open=True, unit="s") = 40.0
    """Simulated time (s); an hour is 360 000 trace rows (about 130 MB in memory)."""
    seed: ranged_int(0, 2**63 - 1) = 0
    robot: RobotSettings = Field(default_factory=RobotSettings)
    plant: PlantSettings = Field(default_factory=PlantSettings)
    model: ModelSettings = Field(default_factory=ModelSettings)
    faults: FaultSettings = Field(default_factory=FaultSettings)
    sensors: SensorSettings = Field(default_factory=SensorSettings)
    estimator: EstimatorConfig = Field(default_factory=UKFSettings)
    diagnosis: DiagnosisConfig = Field(default_factory=ResidualDiagnoserSettings)
    controller: ControllerConfig = Field(default_factory=NMPCSettings)
    reconfiguration: ReconfigurationConfig = Field(default_factory=ReconfigurationConfig)
    reference: ReferenceSettings = Field(default_factory=ReferenceSettings)
    output: OutputConfig = Field(default_factory=OutputConfig)
    oracle: Flag = False
    """The run is told the truth: the drawn plant's limits (:func:`~ftc_mj.sim.cache.robot_limits`), the
    ``truth`` policy and, with ``reconfiguration.accommodation.mode = "all"``, the configured faults as its
    diagnoses (:mod:`ftc_mj.reconfiguration.oracle`). Set only by the benchmark's ``oracle`` row and by studies
    that compare against an oracle; without it nothing a method's components receive depends on the drawn
    plant (docs/benchmark.md, "Information rule")."""
    oracle_pose: Literal["truth", "sensors"] = "truth"
    """Where an oracle run's controller takes its pose from: ``truth`` (default: the true pose, the benchmark's
    ``oracle`` row) or ``sensors`` (as a method's does, by ``sensors.pose_source``: with the pose sensor, the
    filter's estimate). With ``sensors`` the oracle is still told the faults, the radii and the drawn plant's
    limits but estimates its pose like the method: the gap between a method and it leaves the pose estimate out."""

    @model_serializer(mode="wrap")
    def _omit_no_oracle(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        """The fields, without ``oracle`` when it is off and ``oracle_pose`` at its default: a run that is not an
        oracle, or the benchmark's oracle row, keeps the identity (run id, study key) it had before the flags
        existed."""
        data = handler(self)
        if not data.get("oracle"):
            data.pop("oracle", None)
        if data.get("oracle_pose") == "truth":
            data.pop("oracle_pose", None)
        return data

    @model_validator(mode="before")
    @classmethod
    def _plugins_first(cls, data: Any) -> Any:
        """Import the ``plugins`` modules before any component name is checked."""
        registry.load_plugins_of(data)
        return data

    @model_validator(mode="before")
    @classmethod
    def _feedback_alias(cls, data: Any) -> Any:
        """``feedback = true|false`` (the paper's switch) is an alias: false = policy ``none``; true =
        policy ``direct`` unless a feeding policy is given. A contradiction is an error."""
        if not isinstance(data, dict) or "feedback" not in data:
            return data
        data = dict(data)
        fb = data.pop("feedback")
        if not isinstance(fb, bool):
            raise ValueError("feedback: must be true or false (alias of reconfiguration.policy)")
        rc = data.get("reconfiguration")
        rc = dict(rc) if isinstance(rc, dict) else {}
        given = rc.get("policy")
        if given is None:
            rc["policy"] = "direct" if fb else "none"
        elif fb and given == "none":
            raise ValueError("feedback: true contradicts reconfiguration.policy = 'none'")
        elif not fb and given != "none":
            raise ValueError(f"feedback: false contradicts reconfiguration.policy = {given!r}")
        data["reconfiguration"] = rc
        return data

    @property
    def feedback(self) -> bool:
        """The controller's model is handed estimated (or true) radii: the policy is not ``none``."""
        return self.reconfiguration.policy != "none"

    @model_validator(mode="after")
    def _rates(self) -> RunConfig:
        """The estimator and controller periods are whole multiples of the physics step (s), and the
        control period a whole multiple of the estimator period: the loop counts steps, not seconds."""
        dt = self.plant.timestep
        for label, rate in (("estimator.rate", self.estimator.rate), ("controller.rate", self.controller.rate)):
            ratio = 1.0 / (rate * dt)
            if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
                raise ValueError(f"{label}: 1/rate must be a whole multiple of plant.timestep ({dt} s)")
        r_est = 1.0 / (self.estimator.rate * dt)
        r_ctl = 1.0 / (self.controller.rate * dt)
        if abs(r_ctl / r_est - round(r_ctl / r_est)) > 1e-9:
            raise ValueError("controller.rate: the control period must be a multiple of the estimator period")
        return self

    @model_validator(mode="after")
    def _accommodation_source(self) -> RunConfig:
        """Accommodating every mode needs declarations to accommodate: the run's diagnoser's, or in an oracle run
        the truth's."""
        if (self.reconfiguration.accommodation.mode == "all" and not self.oracle
                and self.diagnosis.kind == "none"):
            raise ValueError("reconfiguration.accommodation.mode: 'all' needs a diagnosis source: a diagnoser "
                             "(diagnosis.kind) or, in an oracle run, the truth (oracle = true)")
        return self

    @model_validator(mode="after")
    def _oracle(self) -> RunConfig:
        """Only an oracle run (``oracle = true``) is told the true radii (policy ``truth``) and chooses its pose's
        source (``oracle_pose``)."""
        if self.reconfiguration.policy == "truth" and not self.oracle:
            raise ValueError("oracle: reconfiguration.policy = 'truth' tells the run the true radii; set oracle = true")
        if self.oracle_pose != "truth" and not self.oracle:
            raise ValueError("oracle_pose: where an oracle takes its pose from; set oracle = true")
        return self

    @model_validator(mode="after")
    def _robust(self) -> RunConfig:
        """The robust NMPC's setting that depends on another section: ``posterior`` weights need a filter (its
        checks within the section are its model's, :class:`~ftc_mj.control.robust.RobustNMPCSettings`)."""
        c = self.controller
        if c.kind == "robust-nmpc" and c.robust.weighting == "posterior" and self.estimator.kind == "none":
            raise ValueError("controller.robust.weighting: 'posterior' needs an estimator (estimator.kind is 'none')")
        return self

    @model_validator(mode="after")
    def _faults_fit_plant(self) -> RunConfig:
        """A gyro fault needs a gyro (``sensors.yaw_rate_sigma``), a pose fault the pose sensor
        (``sensors.position_sigma``); a plant fault needs a plant its class acts on
        (the kinematic plant has no servo, so of the actuator faults it takes only ``lock``: its wheel rates are
        the commands)."""
        for i, f in enumerate(self.faults.sensor):
            if f.sensor == "yaw_rate" and self.sensors.yaw_rate_sigma is None:
                raise ValueError(f"faults.sensor[{i}].sensor: 'yaw_rate' needs a gyro (set sensors.yaw_rate_sigma)")
            if f.sensor == "pose" and self.sensors.position_sigma is None:
                raise ValueError(f"faults.sensor[{i}].sensor: 'pose' needs the pose sensor "
                                 "(set sensors.position_sigma)")
        for i, f in enumerate(self.faults.actuator):
            if self.plant.kind not in SERVO_CLASSES[f.kind].plants:
                raise ValueError(f"faults.actuator[{i}].kind: {f.kind!r} needs a servo (plant.kind = 'mujoco'); "
                                 "the kinematic plant takes 'lock' only")
        for i, p in enumerate(self.faults.plugin):
            cls = fault_class(p.fault_class)
            if issubclass(cls, PlantFault) and self.plant.kind not in cls.plants:
                raise ValueError(f"faults.plugin[{i}].fault_class: {p.fault_class!r} acts on the "
                                 f"{' or '.join(cls.plants)} plant, not on plant.kind = {self.plant.kind!r}")
            if p.target == "yaw_rate" and self.sensors.yaw_rate_sigma is None:
                raise ValueError(f"faults.plugin[{i}].target: 'yaw_rate' needs a gyro (set sensors.yaw_rate_sigma)")
        return self

    # ---------------------------------------------------------------- resolved values
    @property
    def plant_wheel_radius(self) -> float:
        """The truth plant's nominal wheel radius (m): ``plant.wheel_radius``, else ``robot.wheel_radius``."""
        return self.plant.wheel_radius or self.robot.wheel_radius

    @property
    def plant_half_track(self) -> float:
        """The truth plant's half track (m): ``plant.half_track``, else ``robot.half_track``."""
        return self.plant.half_track or self.robot.half_track

    @property
    def model_wheel_radius(self) -> float:
        """The wheel radius the filters and controllers assume when healthy (m): ``model.wheel_radius``,
        else ``robot.wheel_radius``."""
        return self.model.wheel_radius or self.robot.wheel_radius

    @property
    def model_half_track(self) -> float:
        """The half track the filters and controllers assume (m): ``model.half_track``, else
        ``robot.half_track``."""
        return self.model.half_track or self.robot.half_track

    @property
    def physics_per_estimator(self) -> int:
        """Physics steps per estimator step (a whole number, checked by validation)."""
        return round(1.0 / (self.estimator.rate * self.plant.timestep))

    @property
    def estimator_per_controller(self) -> int:
        """Estimator steps per controller sample (a whole number, checked by validation)."""
        return round(self.estimator.rate / self.controller.rate)

    @property
    def n_estimator_steps(self) -> int:
        """Estimator steps in the run: ``duration × estimator.rate``, rounded (the trace's rows)."""
        return int(round(self.duration * self.estimator.rate))


def run_context(cfg: RunConfig) -> RunContext:
    """The small run context every component may read beside its own settings (rates, the model's
    nominal geometry, the seed, the sensors' settings); factories build components from it."""
    return RunContext(
        seed=int(cfg.seed), duration=float(cfg.duration), physics_dt=float(cfg.plant.timestep),
        estimator_dt=1.0 / cfg.estimator.rate, controller_dt=1.0 / cfg.controller.rate,
        nominal_radii=(cfg.model_wheel_radius, cfg.model_wheel_radius), half_track=cfg.model_half_track,
        omega_max=float(cfg.robot.omega_max), initial_pose=tuple(float(v) for v in cfg.plant.initial_pose),
        sensors=cfg.sensors, estimator_rate=cfg.estimator.rate, controller_rate=cfg.controller.rate,
        min_radius=cfg.estimator.min_radius)

