"""The versioned benchmark definition (``ftc_mj/data/benchmarks/<version>.toml``): the distributions
every draw comes from, as a strict pydantic model read with a one-line error naming the field.

Ranges are ``[low, high]`` (uniform unless a field says otherwise), probabilities are tables of
``name = p`` summing to 1. SI units; radii and servo gains of faults as fractions of the nominal.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

from pydantic import Field, ValidationError, model_validator

from ..config import one_line, read_toml
from ..errors import BadInput
from ..fields import StrictModel
from ..resources import resource_path
from ..study.spec import HELD_OUT_START

FAULT_CLASSES = ("none", "puncture_step", "puncture_ramp", "actuator_loss", "wheel_lock", "actuator_unresponsive",
                 "speed_bias", "speed_drift", "speed_dropout", "gyro_bias", "gyro_drift", "gyro_dropout")
"""Every fault class a draw can name (``none``: a fault-free draw)."""
PATH_KINDS = ("circle", "figure8", "line")
"""The reference paths a draw can name (``reference.kind``)."""
SPLITS = ("dev", "test")
"""The splits: ``dev`` (development: tune and explore there) and ``test`` (sealed: judged, never tuned on)."""

Prob = Annotated[float, Field(ge=0.0, le=1.0, allow_inf_nan=False)]
Finite = Annotated[float, Field(allow_inf_nan=False)]


class Range(StrictModel):
    """A closed interval ``[low, high]`` (written as a two-element list)."""

    low: Finite
    high: Finite

    @model_validator(mode="before")
    @classmethod
    def _from_list(cls, v: object) -> object:
        """``[low, high]`` as written in the file."""
        if isinstance(v, (list, tuple)):
            if len(v) != 2:
                raise ValueError("expected [low, high]")
            return {"low": v[0], "high": v[1]}
        return v

    @model_validator(mode="after")
    def _ordered(self) -> Range:
        if self.low > self.high:
            raise ValueError(f"low {self.low} above high {self.high}")
        return self


def _check_probabilities(table: dict[str, float], names: tuple[str, ...]) -> dict[str, float]:
    """``table`` if its keys are among ``names`` and its values sum to 1 (within 1e-9)."""
    for k in table:
        if k not in names:
            raise ValueError(f"unknown name {k!r} (expected one of {', '.join(names)})")
    if not math.isclose(sum(table.values()), 1.0, abs_tol=1e-9):
        raise ValueError(f"probabilities sum to {sum(table.values()):.6g}, not 1")
    return table


class FaultDistribution(StrictModel):
    """The faults: the first fault's class, a second fault's probability, onsets and sizes."""

    classes: dict[str, Prob]
    double: Prob
    onset: Range
    second_delay: Range
    puncture_fraction: Range
    ramp_final_fraction: Range
    ramp_rate: Range
    effectiveness: Range
    speed_bias: Range
    speed_drift: Range
    gyro_bias: Range
    gyro_drift: Range
    dropout_duration: Range

    @model_validator(mode="after")
    def _classes(self) -> FaultDistribution:
        _check_probabilities(self.classes, FAULT_CLASSES)
        if self.puncture_fraction.low <= 0 or self.ramp_final_fraction.low <= 0:
            raise ValueError("puncture_fraction: remaining radius fractions must be > 0")
        return self


class PlantDistribution(StrictModel):
    tyre_friction: Range
    actuator_gain: Range
    payload_mass: Range
    payload_offset_x: Range
    payload_offset_y: Range
    payload_offset_z: Range


class PathDistribution(StrictModel):
    kinds: dict[str, Prob]
    circle_radius: Annotated[list[Annotated[float, Field(gt=0)]], Field(min_length=1)]
    figure8_radius: Annotated[list[Annotated[float, Field(gt=0)]], Field(min_length=1)]
    speed: Range
    max_lateral_accel: Annotated[float, Field(gt=0)]
    direction_ccw: Prob

    @model_validator(mode="after")
    def _kinds(self) -> PathDistribution:
        _check_probabilities(self.kinds, PATH_KINDS)
        return self


class SensorDistribution(StrictModel):
    speed_sigma: Range
    gyro: Prob
    gyro_sigma: Range
    pose_sigma: Range


class SeedRanges(StrictModel):
    """Half-open ``[low, high)`` ranges of each split's run seeds."""

    dev: Range
    test: Range

    @model_validator(mode="after")
    def _policy(self) -> SeedRanges:
        """The project's seed policy: development seeds in 0–999, held-out (test) seeds from 1000."""
        if self.dev.low < 0 or self.dev.high > HELD_OUT_START:
            raise ValueError(f"dev: development seeds lie in [0, {HELD_OUT_START})")
        if self.test.low < HELD_OUT_START:
            raise ValueError(f"test: held-out seeds start at {HELD_OUT_START}")
        return self


class BenchmarkDefinition(StrictModel):
    """One version of the benchmark (the file's sections)."""

    version: Annotated[str, Field(pattern=r"^[a-z0-9][a-z0-9.-]{0,40}$")]
    duration: Annotated[float, Field(gt=0, le=3600)]
    splits: dict[str, Annotated[int, Field(ge=0)]]
    seeds: SeedRanges
    fault: FaultDistribution
    plant: PlantDistribution
    path: PathDistribution
    sensors: SensorDistribution

    @model_validator(mode="after")
    def _splits(self) -> BenchmarkDefinition:
        if sorted(self.splits) != sorted(SPLITS):
            raise ValueError(f"splits: expected entropies for {', '.join(SPLITS)}")
        if self.splits["dev"] == self.splits["test"]:
            raise ValueError("splits: dev and test need different entropies (disjoint seed streams)")
        return self


def definition_path(version: str) -> Path:
    """The shipped file of ``version`` (:class:`BadInput` naming ``--version`` if there is none)."""
    folder = resource_path("benchmarks")
    known = sorted(p.stem for p in folder.glob("*.toml"))
    if version not in known:
        raise BadInput(f"benchmark version: no such version {version!r} (shipped: {', '.join(known)})")
    return folder / f"{version}.toml"


_CACHE: dict[str, BenchmarkDefinition] = {}


def parse_definition(data: dict[str, object], where: str) -> BenchmarkDefinition:
    """Validate a definition's data; :class:`BadInput` ``<where>: <field>: why``."""
    try:
        return BenchmarkDefinition.model_validate(data)
    except ValidationError as err:
        raise BadInput(f"{where}: {one_line(err)}") from None


def load_definition(version: str = "ftc-v1") -> BenchmarkDefinition:
    """The definition of ``version`` (read once per process)."""
    if version not in _CACHE:
        path = definition_path(version)
        d = parse_definition(read_toml(path, "benchmark"), f"benchmark {path.name}")
        if d.version != version:
            raise BadInput(f"benchmark {path.name}: version: {d.version!r} does not match the file name")
        _CACHE[version] = d
    return _CACHE[version]
