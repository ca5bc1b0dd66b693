"""The resolved parameters of one filter: :class:`FilterSetup` (model, rate, noise, health rules).

A filter is built from these, and these from the filter's own settings (:class:`FilterSettings`, declared
here once: the ``[estimator]`` section composes it), the sensors' noise
(:class:`~ftc_mj.model.sensors.SensorSettings`) and the model geometry — by :meth:`FilterSetup.from_sections`,
from the run context by :meth:`FilterSetup.from_context`, from plain tables by :func:`setup_from_settings`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydantic import model_validator

from ..context import RunContext
from ..fields import Fraction, NonNegFloat, PosFloat, Rate, StrictModel
from ..model.kinematics import KinematicModel
from ..model.sensors import SensorSettings
from ..validation import section


class FilterSettings(StrictModel):
    """The settings every Kalman filter has (EKF, UKF, and each member of an IMM bank; SI units): the filter
    model's. A filter kind's model adds its own (the UKF's sigma points, :class:`~.ukf.SigmaPointSettings`).
    The defaults are exactly the paper's values."""

    rate: Rate = 100.0
    """Filter rate (Hz); dt = 1/rate."""
    p0_sigma: tuple[PosFloat, PosFloat, PosFloat, PosFloat, PosFloat] = (0.5, 0.5, math.radians(1.0), 0.5, 0.5)
    """Initial standard deviations of [x, y, psi, R_R, R_L] (m, m, rad, m, m)."""
    q_diffusion: tuple[NonNegFloat, NonNegFloat, NonNegFloat, NonNegFloat, NonNegFloat] = (0.25, 0.25, 1e-4, 0.04, 0.04)
    """Process noise as a diffusion per second of [x, y, psi, R_R, R_L] (m²/s, m²/s, rad²/s, m²/s, m²/s):
    ``Q = diag(q_diffusion · dt)`` per filter step, so the filter's model does not change with
    ``rate``. The default is the paper's ``Q = diag((q · dt)²)``, ``q = (5, 5, 0.1, 2, 2)``, at its
    100 Hz (``q² / 100``), bit for bit."""
    initial_radii: tuple[PosFloat, PosFloat] | None = None
    """Initial radius estimates (m); ``None`` = the model's nominal radius."""
    min_radius: PosFloat = 0.05
    """Floor (m) for radius estimates handed on (and for the ramp hypothesis)."""
    nis_gate: PosFloat = 1.0e4
    """An innovation with NIS above this is rejected as an outlier (not used to update)."""
    divergence_nis: PosFloat = 50.0
    """NIS above this for ``divergence_dwell`` seconds counts as divergence (reset)."""
    divergence_dwell: PosFloat = 1.0
    """Time (s) the NIS must stay above ``divergence_nis`` before the filter is reset."""
    reset_inflation: PosFloat = 10.0
    """Covariance inflation factor on a divergence reset."""
    pose_gate: Fraction | None = 1.0e-4
    """Probability that the χ² gate on pose fixes rejects a right fix's position (false rejection per fix): a
    fix whose x, y lie beyond the χ² quantile (2 dof) of the filter's prediction is not used (its heading is).
    ``None`` = no gate."""
    pose_gate_reacquire: PosFloat = 2.0
    """Longest time (s) the gate rejects pose fixes in a row: the first fix after it is fused whatever its NIS,
    so that a lasting offset cannot lock the filter out of its pose sensor (docs/benchmark.md, "Information
    rule")."""

    @model_validator(mode="before")
    @classmethod
    def _no_q_rate(cls, data: Any) -> Any:
        """``q_rate`` (``Q = diag((q_rate · dt)²)``, which retuned the filter with its rate) was replaced
        by the rate-invariant ``q_diffusion``: say how to convert instead of "unknown key"."""
        if isinstance(data, dict) and "q_rate" in data:
            raise ValueError("q_rate: replaced by q_diffusion (per second, rate-invariant): "
                             "q_diffusion = q_rate² / rate, e.g. (0.25, 0.25, 1e-4, 0.04, 0.04) at 100 Hz")
        return data


@dataclass(frozen=True)
class FilterSetup:
    """Resolved parameters (SI units) of one filter."""

    model: KinematicModel
    dt: float
    """Filter step (s)."""
    x0: np.ndarray
    """Initial state [x, y, psi, R_R, R_L] (m, m, rad, m, m)."""
    P0: np.ndarray
    """Initial 5x5 covariance (units of the state, squared)."""
    Q: np.ndarray
    """Process noise per step, 5x5 (units of the state, squared): :func:`process_noise` of the
    settings' diffusion per second."""
    nominal_radius: float
    """Model's nominal wheel radius R0 (m)."""
    speed_sigma: float
    """Speed noise σ (m/s)."""
    yaw_rate_sigma: float | None
    """Yaw-rate noise σ (rad/s); ``None`` = no gyro."""
    position_sigma: float | None
    """Position-fix noise σ (m); ``None`` = no fixes."""
    heading_sigma: float | None
    """Heading noise σ of a pose fix (rad); ``None`` = no pose sensor."""
    kappa: float | None
    """Julier sigma-point parameter κ of a filter with sigma points (UKF members); ``None`` for one without."""
    nis_gate: float
    """NIS above which an update is rejected."""
    divergence_nis: float
    """NIS level that counts towards divergence."""
    divergence_steps: int
    """Steps above ``divergence_nis`` that trigger a reset."""
    reset_inflation: float
    """Covariance after a reset, as a multiple of ``P0``."""
    min_radius: float
    """Smallest radius a reset or a ramp keeps (m)."""
    pose_gate_quantile: float = math.inf
    """χ² quantile (2 dof) of the gate on a fix's x, y (+inf: no gate)."""
    pose_gate_steps: int = 200
    """Filter steps a streak of rejected pose fixes lasts at most (then the next fix is fused ungated)."""

    @classmethod
    def from_sections(cls, est: FilterSettings, sen: SensorSettings, *, wheel_radius: float,
                      half_track: float, initial_pose: Sequence[float]) -> FilterSetup:
        """The filter of the validated ``[estimator]`` and ``[sensors]`` sections, a model of nominal
        wheel radius ``R0`` and half track ``b`` (m), starting at ``initial_pose`` (m, m, rad)."""
        dt = 1.0 / est.rate
        R0 = float(wheel_radius)
        radii = est.initial_radii if est.initial_radii is not None else (R0, R0)
        x0 = np.array([*initial_pose, radii[0], radii[1]], dtype=float)
        return cls(
            model=KinematicModel(b=float(half_track), dt=dt),
            dt=dt,
            x0=x0,
            P0=np.diag(np.square(np.asarray(est.p0_sigma, float))),
            Q=process_noise(est.q_diffusion, dt),
            nominal_radius=R0,
            divergence_steps=max(1, int(round(est.divergence_dwell * est.rate))),
            **{name: getattr(sen, name) for name in _SENSOR_FIELDS},
            heading_sigma=None if sen.position_sigma is None else sen.fix_heading_sigma,
            pose_gate_quantile=gate_quantile(est.pose_gate),
            pose_gate_steps=max(1, int(round(est.pose_gate_reacquire * est.rate))),
            kappa=getattr(est, "kappa", None),  # the sigma-point filters' setting only
            **{name: getattr(est, name) for name in _ESTIMATOR_FIELDS},
        )


    @classmethod
    def from_context(cls, settings: FilterSettings, context: RunContext) -> FilterSetup:
        """A filter's resolved parameters from its settings and the run context (the sensors' noise, the
        model's nominal wheel radius and half track (m), the initial pose)."""
        return cls.from_sections(settings, context.sensors, wheel_radius=context.nominal_radii[0],
                                 half_track=context.half_track, initial_pose=context.initial_pose)


Table = Mapping[str, Any] | None
"""A settings model's plain table (``None`` = its defaults)."""


def setup_from_settings(settings: FilterSettings | Table = None, sensors: SensorSettings | Table = None, *,
                        model: type[FilterSettings] = FilterSettings, wheel_radius: float = 2.0,
                        half_track: float = 1.0, initial_pose: Sequence[float] = (0.0, 0.0, 0.0)
                        ) -> tuple[Any, FilterSetup]:
    """The validated filter settings (a ``model``) and the filter's resolved parameters, from the settings
    (objects or plain tables, one-line errors naming ``estimator.<field>`` / ``sensors.<field>``; ``None`` =
    the paper's values: its ``Q`` and ``P0``, speed σ 0.5 m/s, no gyro, no position fix), the model's nominal
    wheel radius and half track (m) and the initial pose (m, m, rad)."""
    est = section(model, settings, "estimator")
    sen = section(SensorSettings, sensors, "sensors")
    return est, FilterSetup.from_sections(est, sen, wheel_radius=wheel_radius, half_track=half_track,
                                          initial_pose=initial_pose)


def gate_quantile(probability: float | None) -> float:
    """The χ² quantile (upper tail ``probability``, 2 degrees of freedom): the NIS above which a right fix's
    position is rejected with that probability (+inf for ``None``). Computed once per filter, not per step.

    χ²₂ is the exponential distribution of mean 2 (``P(X > x) = exp(−x/2)``), so the quantile is
    ``−2 ln probability`` in closed form: no SciPy import (``scipy.stats`` costs a run ≈ 0.3–0.5 s of start-up).
    It equals ``scipy.stats.chi2.isf(probability, 2)`` bitwise at the default 1e-4 and within 1e-14 relative
    elsewhere (tests/estimation/test_setup_quantile.py)."""
    if probability is None:
        return math.inf
    return -2.0 * math.log(probability)


def process_noise(diffusion: Sequence[float], dt: float) -> np.ndarray:
    """Per-step process-noise covariance ``diag(diffusion · dt)`` of a diffusion per second (units²/s)
    over a step ``dt`` (s). Computed as ``(√(diffusion/dt) · dt)²`` — the same number — so that the
    default diffusion at 100 Hz reproduces the former ``diag((q · dt)²)`` bit for bit."""
    return np.diag(np.square(np.sqrt(np.asarray(diffusion, float) / dt) * dt))


_SENSOR_FIELDS = ("speed_sigma", "yaw_rate_sigma", "position_sigma")
"""Fields of :class:`FilterSetup` taken as they are from the sensors' settings."""
_ESTIMATOR_FIELDS = ("nis_gate", "divergence_nis", "reset_inflation", "min_radius")
"""Fields of :class:`FilterSetup` taken as they are from the ``[estimator]`` settings."""
