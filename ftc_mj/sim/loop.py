"""The multi-rate closed loop: the one place that wires plant, sensors, estimator, fault decision,
controller and telemetry together.

Clocks (all integer step counts, so there is no floating-point drift): physics at
``plant.timestep`` (1 kHz), estimator every ``physics_per_estimator`` physics steps (100 Hz),
controller every ``estimator_per_controller`` estimator steps (10 Hz). Commands are held (zero-order
hold) between controller samples. At estimator step ``k`` (time ``t_k``):

1. read the truth and the sensors at ``t_k``;
2. the filter predicts over ``[t_{k-1}, t_k]`` with the wheel rates measured at ``t_{k-1}`` and
   updates with the measurement at ``t_k``; the fault decision runs on its output;
3. on a controller sample, the controller solves from the pose the sensors read at ``t_k`` (the true
   pose, plus ``sensors.pose_sigma`` noise drawn by :class:`~ftc_mj.plant.Sensors`) with the radii chosen by
   the reconfiguration policy (a robust NMPC with ``posterior`` weighting is first handed the filter's
   scenario weights, :mod:`ftc_mj.reconfiguration.scenario_weights`) (optionally dithered while a fault is
   suspected but not isolated), and its command is applied from ``t_k``;
4. one trace row is stored; the plant advances to ``t_{k+1}``.

Telemetry is buffered in preallocated arrays; nothing is logged call by call.
"""

from __future__ import annotations

import os
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..config import RunConfig
from ..control.base import ControlOutput
from ..control.excitation import dither_wheel_rates, yaw_dither
from ..control.reference import build_reference
from ..estimation.base import FilterOutput, Measurement
from ..estimation.decision import FaultDecision
from ..estimation.factory import build_estimator
from ..estimation.pcrb import pcrb_columns
from ..plant import Sensors
from ..reconfiguration.factory import build_policy, build_scenario_weighting
from ..registry import controllers
from ..telemetry import Event, RobotGeometry, Solve
from .cache import controller_for, plant_for
from .columns import BASE_COLUMNS, COVARIANCE_COLUMNS, STATE, WHEEL_CODES
from .metrics import fault_onsets


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


def _log_estimate(c: dict[str, np.ndarray], k: int, out: FilterOutput) -> None:
    """Estimate, σ of each state, off-diagonal covariances and the innovation statistics of row ``k``."""
    P = out.P
    for i, name in enumerate(STATE):
        c[f"{name}_hat"][k] = out.x[i]
        c[f"{name}_std"][k] = np.sqrt(max(P[i, i], 0.0))
    for (i, j), name in COVARIANCE_COLUMNS.items():
        c[name][k] = 0.5 * (P[i, j] + P[j, i])
    c["innovation"][k] = out.speed_innovation
    c["innovation_std"][k] = out.speed_innovation_std
    c["nis"][k] = out.nis
    c["nis_dof"][k] = float(np.size(out.innovation)) if np.isfinite(out.nis) else 0.0


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


def simulate(cfg: RunConfig, progress: Callable[[float], None] | None = None, *,
             strict: bool | None = None) -> SimResult:
    """Run one closed-loop simulation for ``cfg`` and return its buffered telemetry.

    ``progress`` (optional) is called with the fraction done, a few hundred times per run.
    Physics, filter and solver trouble is part of the study and is recorded as events/counters
    (plant flags, filter rejections and resets, solver fallbacks). Any other exception of a
    component (a ``TypeError``, a shape bug) ends the run early with ``error``/``error_where`` set
    (the run's status is ``failed``), or, with ``strict`` (default: :func:`strict_default`), is
    re-raised.
    """
    strict = strict_default() if strict is None else strict
    wall0 = time.perf_counter()
    plant = plant_for(cfg)
    sensors = Sensors(cfg.sensors, cfg.seed)
    reference = build_reference(cfg)
    controller = controller_for(cfg, reference)
    estimator = build_estimator(cfg)
    decision = FaultDecision(cfg) if estimator is not None else None
    feedback = build_policy(cfg, with_estimator=estimator is not None)
    weighting = build_scenario_weighting(cfg)  # robust NMPC re-weighted by the filter (None: as configured)
    exc = cfg.reconfiguration.excitation
    if cfg.plant.start_moving:
        r0 = reference.at(0.0)
        plant.set_motion(float(r0.V), float(r0.psidot))

    n = cfg.n_estimator_steps
    dt = 1.0 / cfg.estimator.rate
    phys_per_est = cfg.physics_per_estimator
    est_per_ctl = cfg.estimator_per_controller
    n_modes = len(getattr(estimator, "hypotheses", None) or ())
    tele_cols = tuple(getattr(controller, "telemetry_columns", ()))
    cols = {c: np.full(n, np.nan) for c in (*BASE_COLUMNS, *tele_cols)}
    for j in range(n_modes):
        cols[f"mode_prob_{j + 1}"] = np.full(n, np.nan)

    solves: list[Solve] = []
    events: list[Event] = []
    onsets = fault_onsets(cfg)
    for wheel, t_on in onsets.items():
        if t_on is not None:
            events.append(Event(t_on, "warn", f"fault injected: {wheel} tyre radius schedule starts"))

    R0 = cfg.model_wheel_radius
    u_prev: np.ndarray | None = None
    out: FilterOutput | None = None
    cmd = ControlOutput(omega=np.zeros(2))
    applied: np.ndarray | None = None  # the command in force on the plant (after any dither)
    model_radii = np.full(2, R0)
    last_resets = 0
    last_ds = None
    detected_before = False
    anomaly_before = False
    suspected = False
    reset_since_solve = False
    flags_seen = 0
    error: str | None = None
    error_where: str | None = None
    report_every = max(1, n // 200)
    rows = 0
    try:
        for k in range(n):
            t = k * dt
            tr = plant.truth()
            rd = sensors.read(tr, t)
            u_meas = np.array([rd.omega_R, rd.omega_L])
            c = cols
            c["t"][k] = t
            c["x"][k], c["y"][k], c["psi"][k] = tr.x, tr.y, tr.psi
            c["v"][k], c["yaw_rate"][k] = tr.v, tr.yaw_rate
            c["R_R"][k], c["R_L"][k] = tr.R_R, tr.R_L
            c["omega_R"][k], c["omega_L"][k] = tr.omega_R, tr.omega_L
            c["omega_R_meas"][k], c["omega_L_meas"][k] = u_meas
            c["v_meas"][k] = rd.speed
            if rd.yaw_rate is not None:
                c["yaw_rate_meas"][k] = rd.yaw_rate
            if rd.position is not None:
                c["x_meas"][k], c["y_meas"][k] = rd.position
            c["roll"][k], c["pitch"][k], c["z"][k] = tr.roll, tr.pitch, tr.z_chassis
            c["slip_R"][k], c["slip_L"][k] = tr.slip_R, tr.slip_L
            c["plant_flags"][k] = tr.flags
            new = tr.flags & ~flags_seen
            if new:
                flags_seen |= new
                events.append(Event(t, "warn", f"plant left the kinematic model's domain: {plant.describe_flags(new)}"))
            c["cross_track_error"][k] = float(reference.cross_track(tr.x, tr.y))

            # ---- estimator (100 Hz)
            if estimator is not None:
                z = Measurement(speed=rd.speed, yaw_rate=rd.yaw_rate, position=rd.position)
                u_pred = u_prev if u_prev is not None else u_meas
                out = estimator.step(u_pred, z)
                assert decision is not None
                ds = decision.update(t, out, u_pred)
                feedback.observe(out)
                last_ds = ds
                suspected = ds.suspected
                _log_estimate(c, k, out)
                c["fault_detected"][k] = float(ds.detected)
                c["fault_suspected"][k] = float(ds.suspected)
                c["declared_wheel"][k] = float(WHEEL_CODES[ds.wheel])
                c["radius_anomaly"][k] = float(ds.anomaly)
                c["radius_split_std"][k] = ds.split_std
                for name, value in ds.statistics.items():
                    c[name][k] = value
                if out.mode_probs is not None:
                    for j in range(n_modes):
                        c[f"mode_prob_{j + 1}"][k] = out.mode_probs[j]
                if ds.detected and not detected_before:
                    events.append(Event(t, "warn", f"fault declared: {ds.wheel} wheel, severity "
                                                   f"R {ds.severity_R:.0%} / L {ds.severity_L:.0%}"))
                detected_before = ds.detected
                if ds.anomaly and not anomaly_before:
                    events.append(Event(t, "warn", "radius anomaly: an estimate lies above nominal "
                                                   "(not a puncture, not declared)"))
                anomaly_before = ds.anomaly
                resets = getattr(estimator, "resets", 0)
                if resets != last_resets:
                    reset_since_solve = True
                    events.append(Event(t, "error", f"filter divergence: reset #{resets}"))
                last_resets = resets
            u_prev = u_meas

            # ---- controller (10 Hz)
            if k % est_per_ctl == 0:
                model_radii = feedback.radii(t, out, last_ds, reset_since_solve, u_meas, (tr.R_R, tr.R_L))
                reset_since_solve = False
                if weighting is not None:
                    controller.set_scenario_weights(weighting.weights(out, model_radii))
                cmd = controller.solve(t, rd.pose, model_radii, applied)
                if exc.enabled and suspected:
                    dither = yaw_dither(t, exc.amplitude, exc.period)
                    cmd.omega = dither_wheel_rates(cmd.omega, dither, model_radii, cfg.model_half_track,
                                                   cfg.robot.omega_max, *step_bound(cfg, applied))
                    c["excitation"][k] = dither
                plant.set_command(float(cmd.omega[0]), float(cmd.omega[1]))
                applied = np.array(cmd.omega, dtype=float)
                for name in tele_cols:
                    c[name][k] = cmd.telemetry.get(name, np.nan)
                c["solve_time_ms"][k] = cmd.solve_time * 1e3
                c["solver_iterations"][k] = cmd.iterations
                c["solver_ok"][k] = float(cmd.success and not cmd.fallback)
                if cmd.predicted is not None:  # a controller that plans (not open loop)
                    solves.append(Solve(t=t, predicted=cmd.predicted, solve_time_ms=cmd.solve_time * 1e3,
                                        iterations=cmd.iterations, status=cmd.status, fallback=cmd.fallback,
                                        success=cmd.success))
                    if cmd.fallback:
                        events.append(Event(t, "error", f"solver fallback: {cmd.status}"))
            c["reconfig_state"][k] = float(feedback.state)
            c["omega_R_cmd"][k], c["omega_L_cmd"][k] = cmd.omega[0], cmd.omega[1]
            c["R_R_model"][k], c["R_L_model"][k] = model_radii
            rows = k + 1

            plant.advance(phys_per_est)
            if progress is not None and k % report_every == 0:
                progress(k / n)
    except Exception as exc:  # noqa: BLE001 - a run records its failure instead of crashing the caller
        if strict:
            raise
        error = f"{type(exc).__name__}: {exc}"
        error_where = _where(exc)
        events.append(Event(rows * dt, "error", f"run failed: {error} ({error_where})"))
        cols = {k2: v[:rows] for k2, v in cols.items()}
    if estimator is not None and rows:
        cols.update(pcrb_columns(cfg, cols))
    if progress is not None:
        progress(1.0)

    counters = {
        "filter_resets": float(getattr(estimator, "resets", 0)),
        "filter_rejections": float(getattr(estimator, "rejections", 0)),
        "solver_failures": float(getattr(controller, "failures", 0)),
        "plant_flags": float(flags_seen),
        "exceptions": float(error is not None),
    }
    ref_path = reference.path_points(720)
    events.extend(feedback.events)
    return SimResult(trace=cols, solves=solves, events=sorted(events, key=lambda e: e.t), counters=counters,
                     decision=last_ds, n_modes=n_modes, reference_path=ref_path,
                     wall_time=time.perf_counter() - wall0, error=error, error_where=error_where,
                     geometry=robot_geometry(plant, cfg))
