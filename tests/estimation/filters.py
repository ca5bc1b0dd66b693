"""Filters of a run config for the estimation tests: the package's compiled filter or the numpy
reference (:mod:`tests.support.numpy_filters`) of the same kind, built from the same resolved setup."""

from __future__ import annotations

from typing import Any

from ftc_mj.config import RunConfig
from ftc_mj.estimation import EKF, IMM, UKF
from ftc_mj.estimation.factory import setup_from_config
from tests.support.numpy_filters import NumpyEKF, NumpyIMM, NumpyUKF

Filter = EKF | UKF | IMM
KINDS = ("ekf", "ukf", "imm-ekf", "imm-ukf")


def make_filter(kind: str, cfg: RunConfig, *, reference: bool = False, **imm: Any) -> Filter:
    """The filter ``kind`` (``ekf``, ``ukf``, ``imm-ekf``, ``imm-ukf``) of ``cfg``; ``reference``: the
    numpy reference instead of the compiled one; ``imm``: IMM overrides (``hypotheses``, ``transition``,
    ``variant``)."""
    setup = setup_from_config(cfg)
    if kind in ("ekf", "ukf"):
        cls = {"ekf": (EKF, NumpyEKF), "ukf": (UKF, NumpyUKF)}[kind][reference]
        return cls(setup)
    member = kind.removeprefix("imm-")
    return (NumpyIMM if reference else IMM)(setup, cfg.estimator, member, **imm)


def decision_cfg(rule: str, gyro: float | None, **decision: float) -> RunConfig:
    """A run config with the decision ``rule`` (statistics on), a gyro of σ ``gyro`` (rad/s; ``None``:
    speed only) and further ``[estimator.decision]`` settings."""
    return RunConfig.model_validate({"sensors": {"yaw_rate_sigma": gyro},
                                     "estimator": {"decision": {"rule": rule, "statistics": True, **decision}}})
