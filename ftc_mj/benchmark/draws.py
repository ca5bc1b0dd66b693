"""Draws of the benchmark: each a pure function of (version, split, index) — the same draw on every
machine and in every process.

The random stream of draw ``index`` of ``split`` is numpy's PCG64 seeded by
``SeedSequence(entropy=<the split's entropy in the definition>, spawn_key=(<version tag>, index))``: the
splits' streams are disjoint (different entropies), a draw never depends on another, and its values
are drawn in one fixed order (:func:`draw`). The run's sensor-noise seed is part of the draw: dev
seeds lie in 0–999, test seeds from 1000 on (the project's seed policy, ``[seeds]`` of the definition).
The ``private`` split's stream is seeded by a keyed hash of the version and index instead
(:func:`~ftc_mj.benchmark.private.private_entropy`; its seeds in the test range): a pure function of
(version, index, key), reproducible only with the key.

A draw becomes a scenario (:meth:`Draw.scenario`) in the scenario-file format: the tyre faults as radius
schedules (``[faults] right/left``), the actuator and sensor faults as ``[[faults.actuator]]`` /
``[[faults.sensor]]`` tables, ``[plant]`` friction, servo gain and payload, ``[reference]`` path and
speed, ``[sensors]`` noise, ``duration`` and ``seed``.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from ..config import RobotSettings
from ..errors import BadInput
from ..plant.faults import drawn_classes
from .definition import CURRENT_VERSION, PATH_KINDS, PRIVATE, RUN_SPLITS, BenchmarkDefinition, Range, load_definition
from .private import private_entropy

MAX_INDEX = 10**9
"""Largest draw index (a draw's index is part of its random stream's key)."""


@dataclass(frozen=True)
class FaultDraw:
    """One drawn fault: its class's drawn name (:attr:`~ftc_mj.plant.faults.base.FaultClass.drawn_as`), target
    (``right``/``left`` wheel, ``speed``/``yaw_rate`` sensor), onset (s) and size — the remaining radius
    or servo fraction of a puncture or loss, the bias (m/s, rad/s) or drift rate (m/s², rad/s²) of a sensor
    fault, 0 for a lock or an unresponsive servo, a plug-in class's size — plus a ramp's rate (m/s) and a
    dropout's duration (s)."""

    fault_class: str
    target: str
    onset: float
    size: float
    rate: float = 0.0
    duration: float = 0.0


@dataclass(frozen=True)
class Draw:
    """One draw: every factor (SI units) and the run seed."""

    version: str
    split: str
    index: int
    seed: int
    duration: float
    faults: tuple[FaultDraw, ...]
    tyre_friction: float
    actuator_gain: float
    payload_mass: float
    payload_offset: tuple[float, float, float]
    path: str
    path_radius: float
    direction: str
    speed: float
    speed_sigma: float
    gyro_sigma: float | None
    pose_sigma: float
    pose_fix_sigma: float | None = None
    """The pose sensor's σ (m; its heading's: that per metre, rad); ``None``: no pose sensor, the controller gets the
    true pose + ``pose_sigma`` noise (``ftc-v1``)."""
    pose_fix_rate: float | None = None
    """The pose sensor's fix rate (Hz)."""
    nominal_radius: float = field(default_factory=lambda: float(RobotSettings().wheel_radius))
    plugins: tuple[str, ...] = ()
    """The definition's plug-in modules (its runs name them in ``plugins``)."""

    @property
    def name(self) -> str:
        """The run name: ``<version>-<split>-<index, 6 digits>``."""
        return f"{self.version}-{self.split}-{self.index:06d}"

    @property
    def fault_class(self) -> str:
        """The first fault's class (``none`` without a fault)."""
        return self.faults[0].fault_class if self.faults else "none"

    def factors(self) -> dict[str, Any]:
        """Every drawn factor, flat (one row of ``draws.parquet``); absent values are ``None``."""
        out: dict[str, Any] = {"version": self.version, "split": self.split, "index": self.index, "name": self.name,
                               "seed": self.seed, "duration": self.duration, "fault_class": self.fault_class,
                               "n_faults": len(self.faults)}
        for i in range(2):
            f = asdict(self.faults[i]) if i < len(self.faults) else dict.fromkeys(
                ("fault_class", "target", "onset", "size", "rate", "duration"))
            for k, v in f.items():
                out[f"fault{i + 1}_{k}"] = v
        out.update(tyre_friction=self.tyre_friction, actuator_gain=self.actuator_gain, payload_mass=self.payload_mass,
                   payload_offset_x=self.payload_offset[0], payload_offset_y=self.payload_offset[1],
                   payload_offset_z=self.payload_offset[2], path=self.path, path_radius=self.path_radius,
                   direction=self.direction, speed=self.speed, speed_sigma=self.speed_sigma,
                   gyro=self.gyro_sigma is not None, gyro_sigma=self.gyro_sigma, pose_sigma=self.pose_sigma)
        if self.pose_fix_sigma is not None:
            out.update(pose_fix_sigma=self.pose_fix_sigma, pose_fix_rate=self.pose_fix_rate)
        return out

    def scenario(self, *, with_faults: bool = True) -> dict[str, Any]:
        """The draw in the scenario-file format (:func:`ftc_mj.config.validate_config` takes it as it is);
        ``with_faults=False`` drops every fault (the healthy robot on the same path and conditions)."""
        ref: dict[str, Any] = {"kind": self.path, "speed": self.speed, "direction": self.direction}
        if self.path != "line":
            ref["radius"] = self.path_radius
        sensors: dict[str, Any] = {"speed_sigma": self.speed_sigma, "pose_sigma": self.pose_sigma}
        if self.gyro_sigma is not None:
            sensors["yaw_rate_sigma"] = self.gyro_sigma
        if self.pose_fix_sigma is not None:  # the information rule: the controller's pose from the pose sensor
            sensors.update(position_sigma=self.pose_fix_sigma, position_rate=self.pose_fix_rate, pose_source="sensor")
        plant: dict[str, Any] = {"tyre_friction": self.tyre_friction, "actuator_gain": self.actuator_gain}
        if self.payload_mass > 0:
            plant.update(payload_mass=self.payload_mass, payload_offset=list(self.payload_offset))
        out: dict[str, Any] = {"name": self.name, "description": f"benchmark {self.version}, {self.split} draw "
                               f"{self.index}", "duration": self.duration, "seed": self.seed, "plant": plant,
                               "sensors": sensors, "reference": ref}
        if self.plugins:
            out["plugins"] = list(self.plugins)
        out["faults"] = fault_tables(self.faults, self.nominal_radius) if with_faults else {"right": [], "left": []}
        return out


def fault_tables(faults: tuple[FaultDraw, ...], R0: float) -> dict[str, Any]:
    """The ``[faults]`` section of drawn faults (each added by its class,
    :meth:`~ftc_mj.plant.faults.base.FaultClass.add_to`): radius schedules (``[t, r]`` breakpoints, m) for
    the punctures, ``actuator``, ``sensor`` and ``plugin`` tables for the rest (only when there are any)."""
    out: dict[str, Any] = {"right": [], "left": []}
    classes = drawn_classes()
    for f in faults:
        classes[f.fault_class].add_to(out, f.fault_class, f.target, f.onset,
                                      {"size": f.size, "rate": f.rate, "duration": f.duration}, R0)
    return out


# ---------------------------------------------------------------------------- drawing
def version_tag(version: str) -> int:
    """A 32-bit number naming the version in the draws' random streams (SHA-256 of the name)."""
    return int.from_bytes(hashlib.sha256(version.encode()).digest()[:4], "big")


def generator(d: BenchmarkDefinition, split: str, index: int, key: bytes | None = None) -> np.random.Generator:
    """The random stream of draw ``index`` of ``split`` (module docstring; ``key`` only for ``private``)."""
    if split == PRIVATE:
        if key is None:
            raise BadInput("--split private: needs a key: set FTC_MJ_PRIVATE_KEY or give --key-file")
        return np.random.Generator(np.random.PCG64(np.random.SeedSequence(private_entropy(key, d.version, index))))
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(
        entropy=d.splits[split], spawn_key=(version_tag(d.version), index))))


def uniform(rng: np.random.Generator, r: Range) -> float:
    """A uniform value in ``r`` (``low`` if the range is a point)."""
    return float(rng.uniform(r.low, r.high)) if r.high > r.low else float(r.low)


def choose(rng: np.random.Generator, table: dict[str, float], names: tuple[str, ...]) -> str:
    """A name drawn with the table's probabilities (names in the definition's order: stable streams)."""
    keys = [n for n in names if table.get(n, 0.0) > 0.0]
    p = np.array([table[k] for k in keys])
    return keys[int(rng.choice(len(keys), p=p / p.sum()))]


def draw_fault(rng: np.random.Generator, d: BenchmarkDefinition, kind: str, onset: float,
               exclude: str | None = None) -> FaultDraw:
    """A fault drawn as ``kind`` at ``onset`` (s) on a target of its class other than ``exclude``, with its
    size drawn by its class (:meth:`~ftc_mj.plant.faults.base.FaultClass.draw`) from the definition's ranges."""
    cls = drawn_classes()[kind]
    targets = [t for t in cls.targets if t != exclude]
    target = targets[int(rng.integers(len(targets)))]
    sign = 1.0 if rng.random() < 0.5 else -1.0
    ranges = d.fault.ranges
    drawn = cls.draw(kind, lambda name: uniform(rng, ranges[name]), sign)
    return FaultDraw(kind, target, onset, drawn["size"], rate=drawn.get("rate", 0.0),
                     duration=drawn.get("duration", 0.0))


def draw_faults(rng: np.random.Generator, d: BenchmarkDefinition) -> tuple[FaultDraw, ...]:
    """No fault, one, or (with probability ``fault.double``) two on different targets, the second later; the
    classes chosen in the order the definition lists them."""
    order = tuple(d.fault.classes)
    first_cls = choose(rng, d.fault.classes, order)
    if first_cls == "none":
        return ()
    first = draw_fault(rng, d, first_cls, round(uniform(rng, d.fault.onset), 2))
    if rng.random() >= d.fault.double:
        return (first,)
    classes = drawn_classes()
    others = {c: p for c, p in d.fault.classes.items()
              if c != "none" and any(t != first.target for t in classes[c].targets)}
    second_cls = choose(rng, others, order)
    onset = round(first.onset + uniform(rng, d.fault.second_delay), 2)
    return (first, draw_fault(rng, d, second_cls, onset, exclude=first.target))


def draw_path(rng: np.random.Generator, d: BenchmarkDefinition) -> tuple[str, float, str, float]:
    """Path kind, radius (m; ``inf`` for a line), direction and speed (m/s, uniform in ``path.speed`` up to
    ``sqrt(max_lateral_accel · radius)``)."""
    p = d.path
    kind = choose(rng, p.kinds, PATH_KINDS)
    radii = {"circle": p.circle_radius, "figure8": p.figure8_radius}.get(kind)
    radius = float(radii[int(rng.integers(len(radii)))]) if radii else math.inf
    direction = "ccw" if rng.random() < p.direction_ccw else "cw"
    cap = math.sqrt(p.max_lateral_accel * radius)
    speed = round(uniform(rng, Range(low=p.speed.low, high=min(p.speed.high, max(cap, p.speed.low)))), 3)
    return kind, radius, direction, speed


def draw(split: str, index: int, version: str = CURRENT_VERSION, key: bytes | None = None) -> Draw:
    """Draw ``index`` of ``split`` of benchmark ``version`` (a pure function; module docstring); the
    ``private`` split needs its ``key``."""
    if split not in RUN_SPLITS:
        raise BadInput(f"--split: expected {', '.join(RUN_SPLITS)}, got {split!r}")
    if not (isinstance(index, int) and 0 <= index < MAX_INDEX):
        raise BadInput(f"index: must be an integer in [0, {MAX_INDEX}), got {index!r}")
    d = load_definition(version)
    rng = generator(d, split, index, key)
    seeds = getattr(d.seeds, "test" if split == PRIVATE else split)
    seed = int(rng.integers(int(seeds.low), int(seeds.high)))
    faults = draw_faults(rng, d)
    kind, radius, direction, speed = draw_path(rng, d)
    gyro_fault = any(f.target == "yaw_rate" for f in faults)
    gyro = gyro_fault or rng.random() < d.sensors.gyro
    s = d.sensors
    gsig = float(math.exp(rng.uniform(math.log(s.gyro_sigma.low), math.log(s.gyro_sigma.high))))
    pl = d.plant
    payload = (uniform(rng, pl.payload_offset_x), uniform(rng, pl.payload_offset_y), uniform(rng, pl.payload_offset_z))
    out = Draw(
        version=d.version, split=split, index=index, seed=seed, duration=d.duration, faults=faults,
        tyre_friction=round(uniform(rng, pl.tyre_friction), 4), actuator_gain=round(uniform(rng, pl.actuator_gain), 1),
        payload_mass=round(uniform(rng, pl.payload_mass), 2), payload_offset=tuple(round(v, 3) for v in payload),
        path=kind, path_radius=radius, direction=direction, speed=speed,
        speed_sigma=round(uniform(rng, s.speed_sigma), 4), gyro_sigma=round(gsig, 5) if gyro else None,
        pose_sigma=round(uniform(rng, s.pose_sigma), 4), plugins=tuple(d.plugins))
    if s.pose_fix_sigma is None or s.pose_fix_rate is None:
        return out
    # drawn last: a version without the pose sensor keeps its streams
    sigma = round(uniform(rng, s.pose_fix_sigma), 4)
    return replace(out, pose_fix_sigma=sigma, pose_fix_rate=round(uniform(rng, s.pose_fix_rate), 2))
