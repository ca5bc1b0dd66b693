"""The information rule (docs/benchmark.md): a benchmark method's components receive the nominal robot, the
path and the sensors — nothing of the drawn plant. Every built-in method is built on two draws that differ only
in the plant (tyre friction, payload, servo gain, simulator kind), and every number its components were given is
compared bitwise (issue 40, acceptance 3)."""

from __future__ import annotations

import dataclasses
import hashlib
from typing import Any

import numpy as np
import pytest
from pydantic import BaseModel

from ftc_mj.benchmark.draws import draw
from ftc_mj.benchmark.methods import BUILTIN, load_method
from ftc_mj.sim import cache
from ftc_mj.sim.loop import wire

METHOD_PARTS = ("reference", "controller", "estimator", "decision", "policy", "weighting", "degraded")
"""The parts of a run a method consists of (the plant and the truth's record are the draw's)."""


def fingerprint(o: Any, depth: int = 0, seen: set[int] | None = None) -> Any:
    """Everything ``o`` holds, as plain data: floats by their bits, arrays by their bytes, settings models by their
    dump, the package's objects by their attributes (CasADi and MuJoCo objects by their type only)."""
    seen = set() if seen is None else seen
    if o is None or isinstance(o, (bool, int, str)):
        return o
    if isinstance(o, float):
        return float(o).hex()
    if isinstance(o, np.generic):
        return fingerprint(o.item(), depth, seen)
    if isinstance(o, np.ndarray):
        return ("ndarray", str(o.dtype), o.shape, hashlib.sha256(np.ascontiguousarray(o).tobytes()).hexdigest())
    if depth > 10 or id(o) in seen:
        return f"<{type(o).__name__}>"
    seen.add(id(o))
    if isinstance(o, BaseModel):
        return fingerprint(o.model_dump(), depth + 1, seen)
    if isinstance(o, dict):
        return {str(k): fingerprint(v, depth + 1, seen) for k, v in o.items()}
    if isinstance(o, (list, tuple, set, frozenset)):
        items = sorted(o, key=repr) if isinstance(o, (set, frozenset)) else o
        return [fingerprint(v, depth + 1, seen) for v in items]
    if dataclasses.is_dataclass(o):
        return {f.name: fingerprint(getattr(o, f.name), depth + 1, seen) for f in dataclasses.fields(o)}
    if type(o).__module__.startswith("ftc_mj"):
        attrs = dict(getattr(o, "__dict__", {}))
        for slot in getattr(type(o), "__slots__", ()):
            if hasattr(o, slot):
                attrs[slot] = getattr(o, slot)
        return {type(o).__name__: {k: fingerprint(v, depth + 1, seen) for k, v in sorted(attrs.items())}}
    return f"<{type(o).__name__}>"


def differences(a: Any, b: Any, path: str = "") -> list[str]:
    """Where two fingerprints differ (dotted paths)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = [f"{path}.{k}" for k in set(a) ^ set(b)]
        for k in set(a) & set(b):
            out += differences(a[k], b[k], f"{path}.{k}")
        return out
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True)) for d in differences(x, y, f"{path}[{i}]")]
    return [] if a == b else [path or "."]


def _two_plants() -> tuple[dict[str, Any], dict[str, Any]]:
    """An ftc-v2 dev draw's scenario with a gyro (so the degraded mode is in play) and its twin on another plant."""
    base = draw("dev", 0, "ftc-v2").scenario(with_faults=False)
    base["sensors"] = {**base["sensors"], "yaw_rate_sigma": 0.01}
    base["duration"] = 2.0
    base["plant"] = {"tyre_friction": 0.71, "actuator_gain": 6500.0, "payload_mass": 0.0}
    twin = {**base, "plant": {"tyre_friction": 1.18, "actuator_gain": 13500.0, "payload_mass": 55.0,
                              "payload_offset": [0.8, 0.2, -1.0], "kind": "kinematic"}}
    return base, twin


@pytest.mark.parametrize("name", sorted(BUILTIN))
def test_every_builtin_method_receives_the_same_numbers_on_any_plant(name: str, monkeypatch) -> None:  # noqa: ANN001
    """Each part built from scratch on each plant. The IPOPT solver the first build loaded is kept for the second
    (no memory budget: above it the build would load it from disk again, 1-2 s for a robust NMPC's): a solver is
    kept by its problem's key, the digest of its NLP, so a plant-dependent problem would get a solver of its own,
    and the fingerprints hold CasADi objects by their type only."""
    monkeypatch.setattr(cache, "MEMORY_BUDGET_MIB", 10**6)
    method = load_method(name)
    prints = []
    for scenario in _two_plants():
        cfg = method.apply(scenario)
        cache.clear()  # each build from scratch: a cached part cannot hide a difference
        parts = wire(cfg)
        prints.append({p: fingerprint(getattr(parts, p)) for p in METHOD_PARTS})
        prints[-1]["limits"] = fingerprint(cache.robot_limits(cfg))
    diff = differences(*prints)
    assert not diff, f"{name}: the components depend on the drawn plant at {diff[:8]}"
    assert prints[0]["controller"] != "<NoneType>"


def test_ftc_v2_draws_the_pose_sensor_and_pose_faults_and_scores_their_information() -> None:
    """Every ftc-v2 draw carries the pose sensor as the controller's pose source (σ and rate in the definition's
    ranges; ftc-v1 draws none); a drawn pose jump becomes a valid run config, and the scorer's information of it
    is that of the displaced fixes: ½ (size/σ)² per fix, ``position_rate / estimator.rate`` fixes per row."""
    from ftc_mj.benchmark.score import KL_PROFILE_S, fault_truth, sensor_kl

    assert draw("dev", 0, "ftc-v1").pose_fix_sigma is None
    assert "pose_source" not in draw("dev", 0, "ftc-v1").scenario()["sensors"]
    for i in range(20):
        d = draw("dev", i, "ftc-v2")
        assert 0.01 <= d.pose_fix_sigma <= 0.05 and 5.0 <= d.pose_fix_rate <= 10.0
        assert d.scenario()["sensors"]["pose_source"] == "sensor"
    jump = next(d for d in (draw("dev", i, "ftc-v2") for i in range(200)) if d.fault_class == "pose_jump")
    assert jump.faults[0].target == "pose"
    cfg = load_method("safe").apply(jump.scenario())
    assert cfg.faults.sensor[0].sensor == "pose" and cfg.faults.sensor[0].duration == jump.faults[0].duration
    t = np.arange(0.0, cfg.duration, 1.0 / cfg.estimator.rate)
    f = fault_truth(cfg)[0]
    K = sensor_kl(cfg, {"t": t}, f)
    rows = np.count_nonzero((t >= f["onset"] - 1e-9) & (t < f["onset"] + KL_PROFILE_S))
    per_row = 0.5 * cfg.sensors.position_rate / cfg.estimator.rate * (f["size"] / cfg.sensors.position_sigma) ** 2
    assert K.size == rows and K[-1] == pytest.approx(rows * per_row, rel=1e-12)
