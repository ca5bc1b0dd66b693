"""The multi-rate closed loop: the one place that wires plant, sensors, estimator, fault decision,
reconfiguration policy and controller together (:func:`wire`, from the packages' factories).

Clocks (all integer step counts, so there is no floating-point drift): physics at
``plant.timestep`` (1 kHz), estimator every ``physics_per_estimator`` physics steps (100 Hz),
controller every ``estimator_per_controller`` estimator steps (10 Hz). Commands are held (zero-order
hold) between controller samples. Estimator step ``k`` (time ``t_k``, :meth:`ClosedLoop.step`) is a
fixed sequence of named steps:

1. ``sense``: read the truth and the sensors at ``t_k``;
2. ``estimate``: the filter predicts over ``[t_{k-1}, t_k]`` with the wheel rates measured at
   ``t_{k-1}`` and updates with the measurement at ``t_k``; ``decide``: the fault decision runs on its
   output and the policy observes it; ``record_estimate``; ``diagnose``: the diagnoser
   (:mod:`ftc_mj.estimation.diagnosis`) reads the same measurements and the command in force and declares
   which component failed, how and how much;
3. on a controller sample, ``reconfigure``: the policy chooses the radii (a robust NMPC with
   ``posterior`` weighting is first handed the filter's scenario weights,
   :mod:`ftc_mj.reconfiguration.scenario_weights`);
   ``control``: the controller solves from its pose at ``t_k`` (:meth:`ClosedLoop.controller_pose`: with
   ``sensors.pose_source = "truth"`` the true pose plus ``sensors.pose_sigma`` noise drawn by
   :class:`~ftc_mj.plant.Sensors`; with ``"sensor"`` the pose sensor's, through the filter), optionally
   dithered while a fault is suspected but not isolated; ``apply``: its command is held on the plant from ``t_k``;
4. ``record``: the row is complete; the plant advances to ``t_{k+1}``.

The trace is buffered in preallocated arrays (:class:`~ftc_mj.sim.trace.TraceWriter`); nothing is
logged call by call.
"""

from __future__ import annotations

import os
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..config import RunConfig
from ..control.base import ControlOutput
from ..control.excitation import dither_wheel_rates, yaw_dither
from ..errors import BadInput
from ..estimation.base import FilterOutput, Measurement
from ..estimation.decision import DecisionState, FaultDecision
from ..estimation.diagnosis import Diagnoser, DiagnosisInput, DiagnosisStep
from ..estimation.pcrb import pcrb_columns
from ..metrics.record import RunRecord
from ..model.diagnosis import in_force
from ..plant import SensorReading, Sensors, Truth
from ..plant.faults import SENSOR_COLUMNS, fault_class, fault_list
from ..reconfiguration.accommodation import ACCOMMODATION_COLUMNS
from ..reconfiguration.degraded import DegradedMode
from ..reconfiguration.scenario_weights import ScenarioWeighting
from ..registry import controllers
from ..telemetry import Event, RobotGeometry, Solve
from ..wiring.control import build_reference
from ..wiring.decision import build_fault_decision
from ..wiring.diagnosis import build_diagnoser
from ..wiring.estimation import build_estimator
from ..wiring.reconfiguration import (
    build_accommodation,
    build_degraded_mode,
    build_diagnosis_source,
    build_policy,
    build_scenario_weighting,
)
from .cache import begin_run, controller_for, plant_for, robot_limits
from .guards import BuildFailed, check_command, check_estimate
from .record import build_record
from .trace import TraceWriter


@dataclass
class SimResult:
    """Everything a run produced, in memory."""

    trace: dict[str, np.ndarray]
    solves: list[Solve] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)
    counters: dict[str, float] = field(default_factory=dict)
    decision: object | None = None
    """The last :class:`~ftc_mj.estimation.DecisionState` (None without an estimator)."""
    n_modes: int = 0
    reference_path: np.ndarray | None = None
    wall_time: float = 0.0
    error: str | None = None
    """``"<ExceptionType>: <message>"`` of the exception that ended the run early, else ``None``."""
    error_where: str | None = None
    """``file:line in function`` where that exception was raised."""
    geometry: RobotGeometry | None = None
    record: RunRecord | None = None
    """The run's resolved record (:mod:`.record`), which its metrics and scores read."""
    diagnoses: list[Any] = field(default_factory=list)
    """The diagnoser's declarations (:class:`~ftc_mj.model.diagnosis.Diagnosis`), oldest first."""


@dataclass(frozen=True)
class Sample:
    """What estimator step ``k`` knows before its command (:meth:`ClosedLoop.measure`)."""

    t: float
    """Time (s) of the step."""
    truth: Truth
    reading: SensorReading
    radii: np.ndarray | None
    """The radii [R_R, R_L] (m) the policy gives the controller on a controller sample; ``None`` between samples."""


STRICT_ENV = "FTC_MJ_STRICT"
"""Environment variable: ``1`` makes :func:`simulate` re-raise a component's exception instead of
recording it (the test suite sets it)."""


def strict_default() -> bool:
    """Strict mode from the environment (:data:`STRICT_ENV` = ``1``/``true``/``yes``)."""
    return os.environ.get(STRICT_ENV, "").strip().lower() in ("1", "true", "yes")


def _where(exc: BaseException) -> str:
    """``file:line in function`` of the innermost frame of ``exc``'s traceback."""
    frames = traceback.extract_tb(exc.__traceback__)
    if not frames:
        return "?"
    f = frames[-1]
    path = f.filename.replace(os.sep, "/")
    path = path[path.rfind("ftc_mj/"):] if "ftc_mj/" in path else path
    return f"{path}:{f.lineno} in {f.name}"


def robot_geometry(plant: object, cfg: RunConfig) -> RobotGeometry:
    """Sizes (m) to draw the robot, read by name from the MuJoCo model (defaults for the kinematic plant)."""
    m = getattr(plant, "model", None)
    if m is None:
        return RobotGeometry(half_track=cfg.plant_half_track, nominal_radius=cfg.plant_wheel_radius)
    box = m.geom("chassis_box")
    z_body = float(m.body("chassis").pos[2])
    return RobotGeometry(
        half_track=cfg.plant_half_track,
        wheel_width=2.0 * float(m.geom("wheel_right_visual").size[1]),
        chassis_half_sizes=tuple(float(v) for v in box.size[:3]),
        nominal_radius=cfg.plant_wheel_radius,
        chassis_offset_x=float(box.pos[0]),
        chassis_height=z_body + float(box.pos[2]),
    )


def step_bound(cfg: RunConfig, applied: np.ndarray | None) -> tuple[np.ndarray | None, float]:
    """``(previous, max_step)`` for :func:`~ftc_mj.control.excitation.dither_wheel_rates`: the command in
    force and the MPC's bound ``omega_rate_max / rate`` (rad/s) on the next step, or no bound (a controller
    not registered ``rate_bounded``, e.g. the open loop; ``controller.rate_bound_from_applied`` off; no
    command yet)."""
    c = cfg.controller
    bounded = controllers.get(c.kind).meta.get("rate_bounded", False)
    if applied is None or not bounded or not c.rate_bound_from_applied:
        return None, np.inf
    return applied, c.omega_rate_max / c.rate


@dataclass
class Components:
    """The parts of one run, each built by its package's factory from the run config."""

    plant: Any
    sensors: Sensors
    reference: Any
    controller: Any
    """``None``: an agent commands the wheels (:class:`ftc_mj.envs.DiffDriveEnv`)."""
    estimator: Any
    """``None``: the run has no filter (and then no fault decision)."""
    decision: FaultDecision | None
    policy: Any
    """The reconfiguration policy: which radii the controller is given."""
    weighting: ScenarioWeighting | None
    """A robust NMPC's scenario weights from the filter (``None``: as configured)."""
    degraded: DegradedMode | None = None
    """The degraded robust mode between the policy and a controller that takes radius intervals (``None``: off)."""
    record: RunRecord | None = None
    """The run's resolved record (:func:`.record.build_record`), built once here."""
    accommodation: Any = None
    """The accommodation of every diagnosed mode and its safe stop (``None``: the policy's radii only)."""
    diagnoses: Any = None
    """Where the accommodation's declarations come from (``diagnoses(t)``; ``None``: none)."""
    diagnoser: Diagnoser | None = None
    """The diagnoser (``None``: ``diagnosis.kind = "none"``)."""


def wire(cfg: RunConfig, *, with_controller: bool = True, plants: dict[str, Any] | None = None) -> Components:
    """Build (or take from the per-process :mod:`.cache`, reset) every component of the run ``cfg``; with
    ``plant.start_moving`` the plant starts at the reference's speed (m/s) and yaw rate (rad/s) at t = 0.
    ``with_controller=False``: no controller (and no scenario weighting for one): an agent commands;
    ``plants``: the caller's own plant store instead of the per-process cache (:func:`.cache.plant_for`).
    The run's record (:func:`.record.build_record`) is built here, once, from the reference and the filter."""
    begin_run()
    plant = plant_for(cfg, plants)
    sensors = Sensors(cfg.sensors, cfg.seed, cfg.faults)
    reference = build_reference(cfg)
    controller = controller_for(cfg, reference) if with_controller else None
    estimator = build_estimator(cfg)
    record = build_record(cfg, reference=reference, estimator=estimator)
    decision = build_fault_decision(cfg, setup=record.setup) if estimator is not None else None
    policy = build_policy(cfg, with_estimator=estimator is not None)
    weighting = build_scenario_weighting(cfg) if with_controller else None
    degraded = build_degraded_mode(cfg) if estimator is not None else None
    accommodation = build_accommodation(cfg, robot_limits(cfg), reference) if with_controller else None
    diagnoses = build_diagnosis_source(cfg) if accommodation is not None else None
    if cfg.plant.start_moving:
        r0 = reference.at(0.0)
        plant.set_motion(float(r0.V), float(r0.psidot))
    return Components(plant, sensors, reference, controller, estimator, decision, policy, weighting, degraded, record,
                      accommodation, diagnoses, build_diagnoser(cfg, record.setup))


def present(value: float | None) -> float | None:
    """A sensor sample, or ``None`` (not available this step) for a missing one (NaN)."""
    return None if value is None or value != value else value


def fault_columns(parts: Components) -> tuple[str, ...]:
    """The ``fault_*`` truth columns of a run (the plant faults' effects', e.g. the servo's, and
    :data:`~ftc_mj.plant.faults.sensor.SENSOR_COLUMNS` of each faulty sensor); none without."""
    cols: tuple[str, ...] = parts.plant.plant_faults.columns
    for s in parts.sensors.faults.sensors:
        cols += SENSOR_COLUMNS[s]
    return cols


def fault_events(cfg: RunConfig) -> list[Event]:
    """An event at the onset of every servo and sensor fault (class, target, size: :func:`fault_list`), and
    at the end of a sensor fault that ends within the run (the punctures' events are the schedules')."""
    events = []
    for spec in fault_list(cfg.faults, cfg.plant_wheel_radius):
        if not fault_class(spec.fault_class).radius_fault:
            events.append(Event(spec.onset, "warn", f"fault injected: {spec.describe()}"))
    for f in cfg.faults.sensor:
        if f.onset + f.duration < cfg.duration:
            events.append(Event(f.onset + f.duration, "info", f"fault cleared: {f.sensor} {f.kind}"))
    return events


class ClosedLoop:
    """One run in progress: its components, its trace and events, and what one estimator step hands
    the next (the wheel rates measured, the last decision, the command in force, …).

    :meth:`step` is one estimator step ``k``, a fixed sequence of named steps: :meth:`sense` (truth and
    sensors), :meth:`estimate`, :meth:`decide`, :meth:`record_estimate`, and on a controller sample
    :meth:`reconfigure`, :meth:`control`, :meth:`apply`; then :meth:`record` and the plant's advance.
    :meth:`measure` is the part before the command, :meth:`finish` the part after it: an agent that
    commands the wheels itself (:class:`ftc_mj.envs.DiffDriveEnv`) runs them with its own :meth:`apply`
    between, instead of :meth:`control`.
    """

    def __init__(self, cfg: RunConfig, *, with_controller: bool = True, plants: dict[str, Any] | None = None
                 ) -> None:
        self.cfg = cfg
        self.parts = wire(cfg, with_controller=with_controller, plants=plants)
        assert self.parts.record is not None
        self.run_record: RunRecord = self.parts.record
        self.n = cfg.n_estimator_steps
        self.dt = 1.0 / cfg.estimator.rate
        self.phys_per_est = cfg.physics_per_estimator
        self.est_per_ctl = cfg.estimator_per_controller
        estimator = self.parts.estimator
        self.n_modes = len(getattr(estimator, "hypotheses", None) or ())
        self.fault_columns = fault_columns(self.parts)
        self.sensor_faults = bool(self.parts.sensors.faults)
        self.pose_gate = estimator is not None and cfg.sensors.position_sigma is not None
        """The run's filter gates pose fixes: the ``pose_rejected`` column and the ``filter_pose_rejections`` count."""
        self.trace = TraceWriter(self.n, tuple(getattr(self.parts.controller, "telemetry_columns", ())),
                                 self.n_modes, self.fault_columns, self.parts.reference.cross_track,
                                 pose_gate=self.pose_gate)
        if self.parts.accommodation is not None:
            self.trace.columns.update({c: np.full(self.n, np.nan) for c in ACCOMMODATION_COLUMNS})
        self.solves: list[Solve] = []
        self.events: list[Event] = [Event(t_on, "warn", f"fault injected: {wheel} tyre radius schedule starts")
                                    for wheel, t_on in self.run_record.onsets.items() if t_on is not None]
        self.events += fault_events(cfg)
        self.u_prev: np.ndarray | None = None
        self.u_now: np.ndarray | None = None  # the wheel rates (rad/s) measured at the current step
        self.last_fix = np.array(cfg.plant.initial_pose, dtype=float)  # the pose sensor's latest fix (m, m, rad)
        # an oracle sees the true pose unless told to estimate it as a method does (oracle_pose = "sensors")
        self.pose_from_sensor = cfg.sensors.pose_source == "sensor" and (not cfg.oracle or cfg.oracle_pose == "sensors")
        self.out: FilterOutput | None = None
        self.z: Measurement | None = None  # the measurement of the latest estimator step
        self.u_pred: np.ndarray | None = None  # the wheel rates (rad/s) the latest estimator step predicted with
        self.cmd = ControlOutput(omega=np.zeros(2))
        self.applied: np.ndarray | None = None  # the command in force on the plant (after any dither)
        self.model_radii = np.full(2, cfg.model_wheel_radius)
        self.last_resets = 0
        self.last_ds: DecisionState | None = None
        self.last_diagnosis: DiagnosisStep | None = None
        self.detected_before = False
        self.anomaly_before = False
        self.suspected = False
        self.reset_since_solve = False
        self.flags_seen = 0
        self.rows = 0
        self.error: str | None = None
        self.error_where: str | None = None
        self._columns: tuple[int, dict[str, np.ndarray]] | None = None  # (rows, trace) of :meth:`columns`

    def step(self, k: int) -> None:
        """Estimator step ``k`` (time ``k * dt``, s), then the plant's advance to the next one."""
        s = self.measure(k)
        if s.radii is not None:
            self.apply(k, s.t, self.control(k, s.t, s.reading, s.radii))
        self.finish(k)

    def measure(self, k: int) -> Sample:
        """The part of step ``k`` before its command: :meth:`sense`, and with a filter :meth:`estimate`,
        :meth:`decide`, :meth:`record_estimate`; on a controller sample :meth:`reconfigure`. A caller that
        commands the plant itself (:mod:`ftc_mj.envs`) calls this, then :meth:`apply` on a controller sample
        and :meth:`finish`, instead of :meth:`step`."""
        t = k * self.dt
        truth, reading, u_meas = self.sense(k, t)
        self.u_now = u_meas
        if reading.pose_fix is not None:
            self.last_fix = reading.pose_fix
        if self.parts.estimator is not None:
            out, u_pred = self.estimate(reading, u_meas)
            ds = self.decide(t, out, u_pred)
            self.record_estimate(k, t, out, ds)
        if self.parts.diagnoser is not None:
            self.diagnose(k, t, reading, u_meas)
        self.u_prev = u_meas
        radii = self.reconfigure(t, u_meas, truth) if k % self.est_per_ctl == 0 else None
        return Sample(t, truth, reading, radii)

    def finish(self, k: int) -> None:
        """The end of step ``k``: :meth:`record` its row, advance the plant to the next step."""
        self.record(k)
        self.parts.plant.advance(self.phys_per_est)

    def sense(self, k: int, t: float) -> tuple[Truth, SensorReading, np.ndarray]:
        """Read the truth and the sensors at ``t`` (s) into row ``k``; the measured wheel rates (rad/s)."""
        plant = self.parts.plant
        tr = plant.truth()
        rd = self.parts.sensors.read(tr, t)
        u_meas = np.array([rd.omega_R, rd.omega_L])
        self.trace.truth(k, t, tr, rd, u_meas)
        if self.fault_columns:
            self.trace.fault_truth(k, {**(plant.fault_truth() if plant.plant_faults else {}),
                                       **self.parts.sensors.faults.truth(t)})
        new = tr.flags & ~self.flags_seen
        if new:
            self.flags_seen |= new
            self.events.append(Event(t, "warn", f"plant left the kinematic model's domain: "
                                                f"{plant.describe_flags(new)}"))
        return tr, rd, u_meas  # the cross-track error: from the trace's x, y when read (TraceWriter.columns)

    def estimate(self, rd: SensorReading, u_meas: np.ndarray) -> tuple[FilterOutput, np.ndarray]:
        """One filter step: predict with the wheel rates measured at the previous step (at the first step,
        this one's) and update with the readings (a sample a faulty sensor did not deliver, NaN, is handed
        over as absent: the filter updates with the channels present, or only predicts); returns the output
        and the wheel rates (rad/s) used."""
        heading = None if rd.pose_fix is None else float(rd.pose_fix[2])  # the fix's heading, fused with x, y
        if self.sensor_faults:
            z = Measurement(speed=present(rd.speed), yaw_rate=present(rd.yaw_rate), position=rd.position,
                            heading=heading)
        else:
            z = Measurement(speed=rd.speed, yaw_rate=rd.yaw_rate, position=rd.position, heading=heading)
        u_pred = self.u_prev if self.u_prev is not None else u_meas
        if self.parts.accommodation is not None:  # diagnosed sensor offsets removed, excluded channels absent
            z = self.parts.accommodation.correct(self.rows * self.dt, z)
        self.z, self.u_pred = z, u_pred
        self.out = self.parts.estimator.step(u_pred, z)
        check_estimate(self.out, self.rows * self.dt, self.cfg.estimator.kind, self.parts.estimator)
        return self.out, u_pred

    def decide(self, t: float, out: FilterOutput, u_pred: np.ndarray) -> DecisionState:
        """The fault decision on the filter's output at ``t`` (s); the policy observes the output."""
        assert self.parts.decision is not None
        ds = self.parts.decision.update(t, out, u_pred, self.z)
        self.parts.policy.observe(out)
        if self.parts.degraded is not None:  # its drag evidence: the rates measured at t against the command held
            self.parts.degraded.observe(out, self.u_now, self.applied)
        self.last_ds = ds
        self.suspected = ds.suspected
        return ds

    def record_estimate(self, k: int, t: float, out: FilterOutput, ds: DecisionState) -> None:
        """Row ``k``'s estimate and decision, and the events they start: a declaration, a radius anomaly,
        a filter reset."""
        self.trace.estimate(k, out)
        if self.pose_gate and self.z is not None and self.z.position is not None:
            self.trace.pose_gate(k, out.pose_rejected)
        self.trace.decision(k, ds, out.mode_probs)
        if ds.detected and not self.detected_before:
            self.events.append(Event(t, "warn", f"fault declared: {ds.wheel} wheel, severity "
                                                f"R {ds.severity_R:.0%} / L {ds.severity_L:.0%}"))
        self.detected_before = ds.detected
        if ds.anomaly and not self.anomaly_before:
            self.events.append(Event(t, "warn", "radius anomaly: an estimate lies above nominal "
                                                "(not a puncture, not declared)"))
        self.anomaly_before = ds.anomaly
        resets = getattr(self.parts.estimator, "resets", 0)
        if resets != self.last_resets:
            self.reset_since_solve = True
            self.events.append(Event(t, "error", f"filter divergence: reset #{resets}"))
        self.last_resets = resets

    def diagnose(self, k: int, t: float, rd: SensorReading, u_meas: np.ndarray) -> DiagnosisStep:
        """The diagnoser's step at ``t`` (s) on the readings (a sample a faulty sensor did not deliver is
        absent), the pose (``pose_source = "truth"``: the one the controller is handed, σ ``sensors.pose_sigma``;
        ``"sensor"``: the pose sensor's fixes, σ ``sensors.position_sigma``), the encoders, the command in
        force and the filter's radii; row ``k``'s diagnosis columns and an event per declaration."""
        assert self.parts.diagnoser is not None
        radii = None if self.out is None else self.out.x[3:5]
        if self.pose_from_sensor:  # the information rule: the pose sensor's fixes (None between them)
            pose, sigma = rd.pose_fix, self.cfg.sensors.position_sigma
        else:
            pose, sigma = rd.pose, self.cfg.sensors.pose_sigma
        z = DiagnosisInput(t=t, omega=u_meas, command=self.applied, speed=present(rd.speed),
                           yaw_rate=present(rd.yaw_rate), pose=pose, pose_sigma=sigma, radii=radii,
                           filter_input=None if self.out is None else (self.u_pred, self.z))
        step = self.parts.diagnoser.step(z)
        self.trace.diagnosis(k, step)
        for d in step.new:
            vector = "" if d.offset is None else (f", offset ({d.offset[0]:.3g}, {d.offset[1]:.3g}) ± "
                                                  f"({d.offset_sigma[0]:.2g}, {d.offset_sigma[1]:.2g}) m")
            self.events.append(Event(t, "warn", f"diagnosis: {d.component} {d.target} {d.mode}, size {d.size:.3g} "
                                                f"± {d.sigma:.2g}{vector}, onset {d.onset:.2f} s (statistic "
                                                f"{d.statistic:.3g} > threshold {d.threshold:.3g})"))
        self.last_diagnosis = step
        return step

    def reconfigure(self, t: float, u_meas: np.ndarray, tr: Truth) -> np.ndarray:
        """The radii (m) the policy gives the controller at ``t`` (s); a robust NMPC weighted by the filter
        gets its scenario weights; with the degraded mode, the radii pass its no-slip hand-over and the
        controller gets the radius interval (or ``None``)."""
        acc = self.parts.accommodation  # the decision with the declared tyres isolated (Accommodation.isolation)
        ds = self.last_ds if acc is None else acc.isolation(self.last_ds)
        self.model_radii = self.parts.policy.radii(t, self.out, ds, self.reset_since_solve, u_meas, (tr.R_R, tr.R_L))
        self.reset_since_solve = False
        if self.parts.degraded is not None:
            self.model_radii, interval = self.parts.degraded.hand_over(t, self.model_radii, self.out, ds,
                                                                       int(self.parts.policy.state))
            if self.parts.controller is not None:
                self.parts.controller.set_radius_interval(interval)
        if self.parts.weighting is not None:
            self.parts.controller.set_scenario_weights(self.parts.weighting.weights(self.out, self.model_radii))
        source = self.parts.diagnoses
        if acc is None:
            return self.model_radii
        if source is not None:  # an oracle run: the truth
            current = source.diagnoses(t)
        else:  # the run's diagnoser: its declarations in force
            current = in_force(self.last_diagnosis.declared if self.last_diagnosis is not None else ())
        if acc.update(t, current):
            acc.hand_actuator(t, self.parts.controller)
        self.model_radii = acc.radii(self.model_radii, self.cfg.model_wheel_radius)
        return self.model_radii

    def control(self, k: int, t: float, rd: SensorReading, radii: np.ndarray) -> ControlOutput:
        """The controller's command from the pose the sensors read, with ``radii`` (m); while a fault is
        suspected but not isolated (and the excitation is on), a yaw-rate dither is added."""
        cfg = self.cfg
        exc = cfg.reconfiguration.excitation
        acc = self.parts.accommodation
        pose = self.controller_pose(rd)
        pose = pose if acc is None else acc.controller_pose(pose, self.out)
        if acc is not None and acc.stopping:
            cmd = acc.command(t, pose, radii, self.applied, self.u_prev)
        else:
            cmd = self.parts.controller.solve(t, pose, radii, self.applied)
        check_command(cmd.omega, t, cfg.controller.kind, self.parts.controller)
        if exc.enabled and self.suspected and not (acc is not None and acc.stopping):
            dither = yaw_dither(t, exc.amplitude, exc.period)
            cmd.omega = dither_wheel_rates(cmd.omega, dither, radii, cfg.model_half_track,
                                           cfg.robot.omega_max, *step_bound(cfg, self.applied))
            self.trace.excitation(k, dither)
        return cmd

    def controller_pose(self, rd: SensorReading) -> np.ndarray:
        """The pose ``[x, y, psi]`` (m, m, rad) the controller is given: ``pose_source = "truth"`` or an oracle run
        (``oracle = true`` with ``oracle_pose = "truth"``): the reading's (true pose + ``pose_sigma`` noise);
        ``"sensor"``: the filter's pose estimate, which has just taken in this step's fix if one came and carries the
        last ones forward with the measured wheel rates between fixes and through a dropout (the information a real
        robot has, fused once) — without a filter, the last fix held."""
        if not self.pose_from_sensor:
            return rd.pose
        if self.out is not None:
            return np.array(self.out.x[:3], dtype=float)
        return self.last_fix.copy()

    def apply(self, k: int, t: float, cmd: ControlOutput) -> None:
        """Hold ``cmd`` on the plant from ``t`` (s); record the solve (and a fallback event)."""
        self.cmd = cmd
        self.parts.plant.set_command(float(cmd.omega[0]), float(cmd.omega[1]))
        self.applied = np.array(cmd.omega, dtype=float)
        self.trace.solve(k, cmd)
        if cmd.predicted is not None:  # a controller that plans (not open loop)
            self.solves.append(Solve(t=t, predicted=cmd.predicted, solve_time_ms=cmd.solve_time * 1e3,
                                     iterations=cmd.iterations, status=cmd.status, fallback=cmd.fallback,
                                     success=cmd.success))
            if cmd.fallback:
                self.events.append(Event(t, "error", f"solver fallback: {cmd.status}"))

    def record(self, k: int) -> None:
        """Row ``k``'s policy state, command in force and model radii; the row is complete."""
        self.trace.held(k, float(self.parts.policy.state), self.cmd.omega, self.model_radii)
        acc = self.parts.accommodation
        if acc is not None:
            for name, value in zip(ACCOMMODATION_COLUMNS, (float(acc.state), *acc.effectiveness), strict=True):
                self.trace.write(k, name, value)
        self.rows = k + 1

    def fail(self, exc: Exception) -> None:
        """End the run at the first unfinished row: the error, where it was raised, an event."""
        self.error = f"{type(exc).__name__}: {exc}"
        self.error_where = getattr(exc, "where", None) or _where(exc)
        self.events.append(Event(self.rows * self.dt, "error", f"run failed: {self.error} ({self.error_where})"))

    def columns(self) -> dict[str, np.ndarray]:
        """The trace (cut after the last complete row of a run that ended early) with the posterior
        Cramér–Rao bound columns of a run with a filter, from the record's filter setup: computed once for
        the rows so far (asked again with no new row, e.g. by an episode's score and its metrics, the same
        columns are returned)."""
        if self._columns is not None and self._columns[0] == self.rows:
            return self._columns[1]
        cols = self.trace.first_rows(self.rows) if self.rows < self.n else self.trace.columns
        if self.parts.estimator is not None and self.rows:
            cols.update(pcrb_columns(self.run_record.setup, cols))
        self._columns = (self.rows, cols)
        return cols

    def result(self, wall0: float) -> SimResult:
        """The run so far as a :class:`SimResult` (its events in time order, the policy's and the degraded
        mode's included);
        ``wall0`` is the :func:`time.perf_counter` (s) at its start."""
        events = self.events + list(self.parts.policy.events)
        if self.parts.degraded is not None:
            events += self.parts.degraded.events
        if self.parts.accommodation is not None:
            events += self.parts.accommodation.events
        events = sorted(events, key=lambda e: e.t)
        return SimResult(trace=self.columns(), solves=self.solves, events=events, counters=self.counters(),
                         decision=self.last_ds, n_modes=self.n_modes,
                         reference_path=self.parts.reference.path_points(720),
                         wall_time=time.perf_counter() - wall0, error=self.error, error_where=self.error_where,
                         geometry=robot_geometry(self.parts.plant, self.cfg), record=self.run_record,
                         diagnoses=list(self.last_diagnosis.declared) if self.last_diagnosis else [])

    def counters(self) -> dict[str, float]:
        """Filter resets and rejections (with a pose sensor also the pose fixes its gate rejected), solver
        failures, the plant's flags seen, exceptions."""
        p = self.parts
        counts = {
            "filter_resets": float(getattr(p.estimator, "resets", 0)),
            "filter_rejections": float(getattr(p.estimator, "rejections", 0)),
            "solver_failures": float(getattr(p.controller, "failures", 0)),
            "plant_flags": float(self.flags_seen),
            "exceptions": float(self.error is not None),
        }
        if self.pose_gate:
            counts["filter_pose_rejections"] = float(getattr(p.estimator, "pose_rejections", 0))
        return counts


def simulate(cfg: RunConfig, progress: Callable[[float], None] | None = None, *,
             strict: bool | None = None) -> SimResult:
    """Run one closed-loop simulation for ``cfg`` and return its buffered telemetry.

    ``progress`` (optional) is called with the fraction done, a few hundred times per run.
    Physics, filter and solver trouble is part of the study and is recorded as events/counters
    (plant flags, filter rejections and resets, solver fallbacks). Any other exception of a
    component (a ``TypeError``, a shape bug) ends the run early with ``error``/``error_where`` set
    (the run's status is ``failed``), or, with ``strict`` (default: :func:`strict_default`), is
    re-raised. A component whose constructor raises is :class:`~ftc_mj.sim.guards.BuildFailed` (one line
    saying what and where; the run has not started).
    """
    strict = strict_default() if strict is None else strict
    wall0 = time.perf_counter()
    try:
        loop = ClosedLoop(cfg)
    except BadInput:
        raise
    except Exception as exc:  # a component's constructor (a plug-in's): one line, not its traceback
        if strict:
            raise
        first = str(exc).splitlines()[0] if str(exc) else ""
        raise BuildFailed(f"the run's components could not be built: {type(exc).__name__}: {first[:200]} "
                          f"({_where(exc)})") from None
    report_every = max(1, loop.n // 200)
    try:
        for k in range(loop.n):
            loop.step(k)
            if progress is not None and k % report_every == 0:
                progress(k / loop.n)
    except Exception as exc:  # noqa: BLE001 - a run records its failure instead of crashing the caller
        if strict:
            raise
        loop.fail(exc)
    res = loop.result(wall0)
    if progress is not None:
        progress(1.0)
    return res
