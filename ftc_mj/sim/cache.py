"""Per-process cache of the expensive, reusable parts of a run: the compiled MuJoCo plant, the
built MPC solvers and the robot's limits the path-following NMPC is given.

Studies and the paper matrix run many simulations in one worker process; CasADi solvers cost
0.1–0.3 s to build (and do not pickle), so they are built once per worker and per structure, then
``reset()`` before each run. A reset part behaves exactly like a new one (tests compare traces of a
fresh and a reused build), so caching never changes results.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from typing import Any

from ..config import RunConfig
from ..control.pathfollow_spec import RobotLimits
from ..identity import run_identity
from ..plant import build_model
from ..plant.limits import lateral_accel_limits
from ..registry import controllers
from ..wiring.control import build_controller
from ..wiring.plant import build_plant

_MAX_ENTRIES = 16
_plants: dict[str, Any] = {}
_controllers: dict[str, Any] = {}
_limits: dict[str, RobotLimits] = {}
stats = {"plant_builds": 0, "plant_hits": 0, "controller_builds": 0, "controller_hits": 0}


def _key(cfg: RunConfig, sections: tuple[str, ...], extra: tuple[Any, ...] = ()) -> str:
    """The identity (:func:`~ftc_mj.identity.run_identity`: the model by its contents) of ``sections``."""
    d = run_identity(cfg)
    return json.dumps([{s: d.get(s) for s in sections}, list(extra)], sort_keys=True, default=str)


def _remember(store: dict[str, Any], key: str, value: Any) -> None:
    if len(store) >= _MAX_ENTRIES:
        store.pop(next(iter(store)))
    store[key] = value


def _reuse(store: dict[str, Any], key: str, kind: str, build: Callable[[], Any]) -> Any:
    """The part cached in ``store`` under ``key``, reset, or else a new one from ``build()``, cached;
    counted in :data:`stats` as a ``<kind>_hits`` or a ``<kind>_builds``."""
    part = store.get(key)
    if part is None:
        part = build()
        _remember(store, key, part)
        stats[f"{kind}_builds"] += 1
    else:
        part.reset()
        stats[f"{kind}_hits"] += 1
    return part


def plant_for(cfg: RunConfig, store: dict[str, Any] | None = None) -> Any:
    """A plant for ``cfg``, reset to t = 0 (built on first use for this plant/robot/fault setup), from the
    per-process cache or from the caller's own ``store``: an owner that steps its plant while other runs
    of the process step theirs (two Gymnasium environments) keeps its plants apart."""
    return _reuse(_plants if store is None else store, _key(cfg, ("plant", "robot", "faults")), "plant",
                  lambda: build_plant(cfg))


def robot_limits(cfg: RunConfig) -> RobotLimits:
    """The robot's numbers for the path-following NMPC, derived from the MJCF with the config's edits
    (:func:`~ftc_mj.plant.limits.lateral_accel_limits`): its lift-off lateral acceleration, the braking
    trade-off and the servos' yaw compliance — 0 on the kinematic plant, which follows the commanded rates
    exactly (cached per plant setup)."""
    key = _key(cfg, ("plant", "robot"))
    if key not in _limits:
        lim = lateral_accel_limits(build_model(cfg.plant, cfg.robot))
        _remember(_limits, key, RobotLimits(lim.liftoff, lim.yaw_compliance, lim.braking_trade))
    lim = _limits[key]
    return lim if cfg.plant.kind == "mujoco" else dataclasses.replace(lim, yaw_compliance=0.0)


def controller_for(cfg: RunConfig, reference: Any) -> Any:
    """A controller for ``cfg``, reset: one registered ``reusable`` (MPCs) is cached per structure,
    any other is built anew."""
    meta = controllers.get(cfg.controller.kind).meta
    limits = robot_limits(cfg) if meta.get("robot_limits", False) else None
    if not meta.get("reusable", False):
        return build_controller(cfg, reference, limits)
    key = _key(cfg, ("controller", "reference", "robot", "model"), (tuple(cfg.plant.initial_pose), limits))
    return _reuse(_controllers, key, "controller", lambda: build_controller(cfg, reference, limits))


def clear() -> None:
    """Drop every cached part."""
    _plants.clear()
    _controllers.clear()
    _limits.clear()
