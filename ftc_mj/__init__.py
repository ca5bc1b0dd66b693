"""ftc-mj: active fault-tolerant control of a MuJoCo differential-drive robot.

The public API (:mod:`ftc_mj.api`, :mod:`ftc_mj.registry`)::

    import ftc_mj

    cfg = ftc_mj.load_config("scenario2", {"sensors.yaw_rate_sigma": 0.01})
    run = ftc_mj.run(cfg, "runs/out")          # run.trace (polars), run.metrics, run.events, run.path
    ftc_mj.load_run(run.path); ftc_mj.run_study("observability", workers=2); ftc_mj.load_study(dir)
    ftc_mj.register_estimator("my-filter", MyFilter)   # MyFilter(settings, context); estimator.kind = "my-filter"

Layers, lowest first (a package imports only its own layer's and lower ones; ``tests/test_architecture.py``)::

    base modules (errors, fields, validation, registry, resources, io, context, markdown)
    model (kinematics, sensor model; one definition)
    plant (MuJoCo truth, faults, sensors), estimation (EKF, UKF, IMM, fault decision), control (NMPC, LMPC, …)
    telemetry (what a run records) -> reconfiguration (policies) -> config -> wiring (components from the config)
    identity, metrics -> rundir -> rerun (.rrd) -> sim (the multi-rate loop, a run)
    study (dask sweeps) -> paper (matrix, claims), benchmark -> reports (docs/ pages) -> api, envs -> cli

Names are imported on first use, so ``import ftc_mj`` stays light.
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

_API = ("Run", "Study", "load_config", "load_run", "load_study", "plan_study", "run", "run_study")
_COMPONENTS = {"Event": "ftc_mj.telemetry", "FilterOutput": "ftc_mj.estimation.base",
               "Measurement": "ftc_mj.estimation.base", "Hypothesis": "ftc_mj.estimation.base",
               "ControlOutput": "ftc_mj.control.base", "ReconfigurationPolicy": "ftc_mj.reconfiguration.policies",
               "DecisionState": "ftc_mj.estimation.decision", "BadInput": "ftc_mj.errors",
               "RunConfig": "ftc_mj.config", "RunContext": "ftc_mj.context"}
_REGISTER = {"register_estimator": "estimators", "register_decision_rule": "decision_rules",
             "register_controller": "controllers", "register_policy": "policies",
             "register_reference": "references", "register_fault_class": "fault_classes",
             "register_diagnoser": "diagnosers"}

__all__ = [*_API, *_COMPONENTS, *_REGISTER, "components", "__version__"]


def components() -> dict[str, tuple[str, ...]]:
    """The registered names of every kind of component (``{"estimators": ("ekf", …), …}``)."""
    from .registry import REGISTRIES

    return {kind: reg.names() for kind, reg in REGISTRIES.items()}


def __getattr__(name: str) -> Any:
    if name in _API:
        return getattr(importlib.import_module("ftc_mj.api"), name)
    if name in _COMPONENTS:
        return getattr(importlib.import_module(_COMPONENTS[name]), name)
    if name in _REGISTER:
        from . import registry

        return getattr(registry, _REGISTER[name]).register
    raise AttributeError(f"module 'ftc_mj' has no attribute {name!r}")
