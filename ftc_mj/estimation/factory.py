"""Build the configured estimator (``estimator.kind``) from a :class:`RunConfig`."""

from __future__ import annotations

from ..config import RunConfig
from .base import Estimator
from .ekf import EKF
from .imm import IMM
from .ukf import UKF


def build_estimator(cfg: RunConfig) -> Estimator | None:
    """``ekf`` → :class:`EKF`, ``ukf`` → :class:`UKF`, ``imm-ekf``/``imm-ukf`` → :class:`IMM` with EKF/UKF
    members (bank size ``estimator.imm_models``, variant ``estimator.imm_variant``); ``none`` → ``None``
    (the simulation loop runs without a filter)."""
    kind = cfg.estimator.kind
    if kind == "ekf":
        return EKF(cfg)
    if kind == "ukf":
        return UKF(cfg)
    if kind == "imm-ekf":
        return IMM(cfg, member="ekf")
    if kind == "imm-ukf":
        return IMM(cfg, member="ukf")
    if kind == "none":
        return None
    raise ValueError(f"unknown estimator kind {kind!r}")
