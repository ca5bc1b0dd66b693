"""Per-process cache of the expensive, reusable parts of a run: the compiled MuJoCo plant, the
built MPC solvers and the robot's limits the path-following NMPC is given.

Studies, the paper matrix and benchmarks run many simulations in one worker process; CasADi solvers
cost 0.1–3 s to build or load (and do not pickle), so they are built once per worker and per structure,
then ``reset()`` before each run. A reset part behaves exactly like a new one (tests compare traces of a
fresh and a reused build), so caching never changes results.

The cache holds what a next run reuses and nothing else: one part per *slot* (a plant per plant kind, a
controller per controller section and nominal model: a method), kept with the identity it was built for.
A run of the same identity resets it; another identity replaces it, so a bench worker, which never sees
a draw twice, holds one plant and one controller per method, not one per draw. A controller registered
``retargetable`` (the MPCs: the reference — and for the path-following NMPC its desired speed and the robot's
limits — enters their problem as parameters) is keyed without its reference (and limits) and given the run's
after its reset (:func:`~ftc_mj.wiring.control.retarget_controller`), so every draw of a method reuses it; the
IPOPT solvers themselves are kept per process by :func:`~ftc_mj.control.solver_cache.ipopt_solver`.

Above :data:`MEMORY_BUDGET_MIB` of resident memory a controller build first drops the other methods' controllers
and the solvers the run has not asked for (:func:`make_room`), so a process holds about one method's parts at a time.
"""

from __future__ import annotations

import ctypes
import dataclasses
import functools
import gc
import json
import os
from collections.abc import Callable
from typing import Any

from ..config import RunConfig
from ..control import solver_cache
from ..control.blas import single_thread_blas
from ..control.pathfollow_spec import RobotLimits
from ..identity import run_identity
from ..plant import build_model
from ..plant.limits import lateral_accel_limits, servo_limits
from ..plant.settings import PlantSettings
from ..registry import controllers
from ..resources import model_digest
from ..wiring.control import build_controller, retarget_controller
from ..wiring.plant import build_plant

_MAX_LIMITS = 16
MEMORY_BUDGET_MIB = 350
"""Resident memory (MiB) above which a controller build first drops every other kept controller and every solver
this run has not asked for (:func:`make_room`). A bench worker holds about 360 MiB after its first run, so there
every build of another method's controller drops the last method's parts: the six built-in methods on ftc-v2 dev
draws 0-7, 2 workers, peaked at 581 and 583 MiB per worker, against 599 and 618 MiB with a budget of 450 MiB and
739 and 773 MiB without one. A process that has run one draw of ``paper`` holds about 320 MiB, under it."""
_plants: dict[str, tuple[str, Any]] = {}
_controllers: dict[str, tuple[str, Any]] = {}
_limits: dict[str, RobotLimits] = {}
_asked_at_start = [0]
""":func:`~ftc_mj.control.solver_cache.asked_count` when the current run began (:func:`begin_run`)."""
stats = {"plant_builds": 0, "plant_hits": 0, "controller_builds": 0, "controller_hits": 0}


def begin_run() -> None:
    """A run of this process starts (what it asks of the solver cache from now on is this run's). Above
    :data:`MEMORY_BUDGET_MIB` the free pages the last run left in the malloc arenas go back to the system first
    (``malloc_trim``, about 2 ms; no garbage collection, which costs 70 ms): a bench worker's resident set crept
    with the draws otherwise (one worker, ``pathfollow`` then ``hybrid`` on 30 test draws each: peak 628 MiB and
    ``hybrid`` at 580 MiB, against 572 and 510 MiB with it; 0.015 s of system time a run for the pages touched
    again). BLAS is limited to one thread (:func:`~ftc_mj.control.blas.single_thread_blas`, once per process)."""
    single_thread_blas()
    _asked_at_start[0] = solver_cache.asked_count()
    if _over_budget():
        release_memory(collect=False)


def make_room(keep: str) -> None:
    """Before a controller is built: when the process holds more than :data:`MEMORY_BUDGET_MIB`, drop every kept
    controller but the one in slot ``keep`` and every kept solver this run has not asked for, and hand the freed
    memory back to the system (:func:`release_memory`). A bench worker runs one method's draws, then the next
    method's: it held every method's controllers and solvers at once (690 MiB for the six built-in methods, where
    the largest alone, the path-following NMPC with its three path kinds' solvers, settles at 550 MiB). A study
    whose consecutive runs alternate between controllers builds each again (its solver from the disk cache,
    0.1-1 s) instead; a study's seeds are its innermost loop, so that happens once per combination of its axes.
    Nothing a run computes depends on it: a part built again or a solver loaded again is the same."""
    if not _over_budget():
        return
    for slot in [s for s in _controllers if s != keep]:
        del _controllers[slot]
    solver_cache.forget_solvers(not_asked_since=_asked_at_start[0])
    release_memory()


def _over_budget() -> bool:
    """The process holds more than :data:`MEMORY_BUDGET_MIB` (never where its resident set cannot be read)."""
    rss = resident_mib()
    return rss is not None and rss > MEMORY_BUDGET_MIB


def resident_mib() -> float | None:
    """This process's resident set (MiB) from ``/proc/self/statm``; ``None`` where there is none."""
    try:
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    except (OSError, ValueError, IndexError, AttributeError):
        return None


def release_memory(collect: bool = True) -> None:
    """Collect the garbage (``collect``) and return the free pages of every malloc arena to the system (glibc's
    ``malloc_trim``; elsewhere only the collection). Freed CasADi solvers leave most of their pages in the
    arenas otherwise: measured 494 → 465 MiB without it, → 302 MiB with it."""
    if collect:
        gc.collect()
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


@functools.cache
def _malloc_trim() -> Any:
    """glibc's ``malloc_trim`` among the process's own symbols, or ``None`` (another C library, Windows)."""
    try:
        return getattr(ctypes.CDLL(None), "malloc_trim", None)
    except (OSError, TypeError):
        return None


def _key(cfg: RunConfig, sections: tuple[str, ...], extra: tuple[Any, ...] = ()) -> str:
    """The identity (:func:`~ftc_mj.identity.run_identity`: the model by its contents) of ``sections``."""
    d = run_identity(cfg)
    return json.dumps([{s: d.get(s) for s in sections}, list(extra)], sort_keys=True, default=str)


def _reuse(store: dict[str, tuple[str, Any]], slot: str, key: str, kind: str, build: Callable[[], Any]) -> Any:
    """The part in ``store``'s ``slot`` reset if it was built for ``key``, or else a new one from ``build()``
    in its place (the old one is dropped first); counted in :data:`stats` as a ``<kind>_hits`` or a
    ``<kind>_builds``."""
    kept = store.get(slot)
    if kept is not None and kept[0] == key:
        kept[1].reset()
        stats[f"{kind}_hits"] += 1
        return kept[1]
    store.pop(slot, None)
    del kept
    part = build()
    store[slot] = (key, part)
    stats[f"{kind}_builds"] += 1
    return part


def plant_for(cfg: RunConfig, store: dict[str, Any] | None = None) -> Any:
    """A plant for ``cfg``, reset to t = 0 (built on first use for this plant/robot/fault setup), from the
    per-process cache or from the caller's own ``store``: an owner that steps its plant while other runs
    of the process step theirs (two Gymnasium environments) keeps its plants apart."""
    return _reuse(_plants if store is None else store, cfg.plant.kind, _key(cfg, ("plant", "robot", "faults")),
                  "plant", lambda: build_plant(cfg))


def nominal_plant(cfg: RunConfig) -> PlantSettings:
    """The robot a method may know (docs/benchmark.md, "Information rule"): the MJCF (``plant.model_file``,
    ``variant``, the design's ``wheel_load_fraction``) with the model's geometry (``model.wheel_radius``,
    ``model.half_track``) and nothing else of the ``[plant]`` section — never the tyre friction, servo gain,
    masses or payload of the plant that runs, nor which simulator it is."""
    p = cfg.plant
    return PlantSettings(model_file=p.model_file, variant=p.variant, wheel_load_fraction=p.wheel_load_fraction,
                         wheel_radius=cfg.model_wheel_radius, half_track=cfg.model_half_track)


def robot_limits(cfg: RunConfig) -> RobotLimits:
    """The robot's numbers for the path-following NMPC (:func:`~ftc_mj.plant.limits.lateral_accel_limits`): its
    lift-off lateral acceleration, the braking trade-off, the servos' yaw compliance and the accelerations one
    servo's torque limit allows (:func:`~ftc_mj.plant.limits.servo_limits`; none on the kinematic plant), derived
    from the nominal robot (:func:`nominal_plant`) — or, in an ``oracle`` run, from the plant that runs (the MJCF
    with the config's edits; yaw compliance 0 on the kinematic plant, which follows the commanded rates exactly).
    Cached per robot."""
    plant = cfg.plant if cfg.oracle else nominal_plant(cfg)
    ident = {**plant.model_dump(mode="json", exclude={"model_file"}), "model": model_digest(plant.model_file)}
    key = json.dumps([ident, cfg.robot.model_dump(mode="json")], sort_keys=True, default=str)
    if key not in _limits:
        model = build_model(plant, cfg.robot)
        lim, servo = lateral_accel_limits(model), servo_limits(model)
        if len(_limits) >= _MAX_LIMITS:  # five floats each: a bounded memo, not a part
            _limits.pop(next(iter(_limits)))
        _limits[key] = RobotLimits(lim.liftoff, lim.yaw_compliance, lim.braking_trade, servo.lateral,
                                   servo.longitudinal)
    lim = _limits[key]
    return lim if plant.kind == "mujoco" else dataclasses.replace(lim, yaw_compliance=0.0, servo_lateral_accel=None,
                                                                    servo_longitudinal_accel=None)


def controller_for(cfg: RunConfig, reference: Any) -> Any:
    """A controller for ``cfg``, reset: one registered ``reusable`` (MPCs) is cached per method (its
    controller and model sections) and built again only when its identity changes — with the reference and the
    robot's limits unless it is registered ``retargetable`` (then it is given them after its reset); any other
    controller is built anew."""
    meta = controllers.get(cfg.controller.kind).meta
    limits = robot_limits(cfg) if meta.get("robot_limits", False) else None
    if not meta.get("reusable", False):
        return build_controller(cfg, reference, limits)
    retarget = meta.get("retargetable", False)
    sections = ("controller", "robot", "model") if retarget else ("controller", "reference", "robot", "model")
    key = _key(cfg, sections, (tuple(cfg.plant.initial_pose),) if retarget else (tuple(cfg.plant.initial_pose), limits))
    slot = _key(cfg, ("controller", "model"))
    kept = _controllers.get(slot)
    if kept is None or kept[0] != key:
        make_room(slot)
    ctl = _reuse(_controllers, slot, key, "controller", lambda: build_controller(cfg, reference, limits))
    if retarget:
        retarget_controller(ctl, cfg, reference, limits)
    return ctl


def clear() -> None:
    """Drop every cached part (the solvers :func:`~ftc_mj.control.solver_cache.ipopt_solver` keeps stay:
    a controller built again reuses its solver)."""
    _plants.clear()
    _controllers.clear()
    _limits.clear()
