"""Filters of a run config for the estimation tests: the package's compiled filter or the numpy
reference (:mod:`tests.support.numpy_filters`) of the same kind, built from the same resolved setup."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import TypeAdapter

from ftc_mj.config import EstimatorConfig, RunConfig
from ftc_mj.estimation import EKF, IMM, UKF
from ftc_mj.model.kinematics import KinematicModel
from ftc_mj.wiring.estimation import setup_from_config
from tests.support.numpy_filters import NumpyEKF, NumpyIMM, NumpyUKF

Filter = EKF | UKF | IMM
KINDS = ("ekf", "ukf", "imm-ekf", "imm-ukf")


def of_kind(cfg: RunConfig, kind: str) -> RunConfig:
    """``cfg`` with its ``[estimator]`` section read as ``kind``'s (validated through the section's union:
    the other kind's settings at their defaults are dropped, the new kind's own take their defaults)."""
    if cfg.estimator.kind == kind:
        return cfg
    data = {**cfg.estimator.model_dump(), "kind": kind}
    return cfg.model_copy(update={"estimator": TypeAdapter(EstimatorConfig).validate_python(data)})


def make_filter(kind: str, cfg: RunConfig, *, reference: bool = False, **imm: Any) -> Filter:
    """The filter ``kind`` (``ekf``, ``ukf``, ``imm-ekf``, ``imm-ukf``) of ``cfg`` (its ``[estimator]`` section
    read as ``kind``'s, :func:`of_kind`); ``reference``: the numpy reference instead of the compiled one;
    ``imm``: IMM overrides (``hypotheses``, ``transition``, ``variant``)."""
    cfg = of_kind(cfg, kind)
    setup = setup_from_config(cfg)
    if kind in ("ekf", "ukf"):
        cls = {"ekf": (EKF, NumpyEKF), "ukf": (UKF, NumpyUKF)}[kind][reference]
        return cls(setup)
    member = kind.removeprefix("imm-")
    return (NumpyIMM if reference else IMM)(setup, cfg.estimator, member, **imm)


def decision_cfg(rule: str, gyro: float | None, **decision: float | str) -> RunConfig:
    """A run config with the decision ``rule`` (statistics on), a gyro of σ ``gyro`` (rad/s; ``None``:
    speed only) and further ``[estimator.decision]`` settings."""
    return RunConfig.model_validate({"sensors": {"yaw_rate_sigma": gyro},
                                     "estimator": {"decision": {"rule": rule, "statistics": True, **decision}}})


def excited_data(n: int, seed: int = 0, yaw_sigma: float | None = None,
                 fault: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Wheel rates (n, 2), noisy speed (n,), noisy yaw rate (n,) from the kinematic model; R_L 2→1 m
    linearly over steps 100..200 (``fault``; else the radii stay at 2 m)."""
    rng = np.random.default_rng(seed)
    m = KinematicModel(b=1.0, dt=0.01)
    t = np.arange(n) * 0.01
    u = np.stack([5.1 + 0.8 * np.sin(0.7 * t), 4.9 + 0.8 * np.cos(0.5 * t)], axis=1)
    x = np.array([0.0, 0.0, 0.0, 2.0, 2.0])
    zs = np.empty(n)
    zy = np.empty(n)
    for k in range(n):
        x = m.step(x, u[k])
        x[4] = float(np.interp(k, [100, 200], [2.0, 1.0])) if fault else 2.0
        zs[k] = float(m.speed(x, u[k])) + 0.5 * rng.normal()
        zy[k] = float(m.yaw_rate(x, u[k])) + (yaw_sigma or 0.0) * rng.normal()
    return u, zs, zy
