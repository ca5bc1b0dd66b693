"""The versioned benchmark definition (``ftc_mj/data/benchmarks/<version>.toml``): the distributions
every draw comes from, as a strict pydantic model read with a one-line error naming the field.

Ranges are ``[low, high]`` (uniform unless a field says otherwise), probabilities are tables of
``name = p`` summing to 1. SI units; radii and servo gains of faults as fractions of the nominal.

The faults a draw can name are the registered fault classes' drawn names
(:attr:`~ftc_mj.plant.faults.base.FaultClass.drawn_as`); the file keeps their distributions — the
probabilities (in the file's order, the order the draws choose in) and the ranges each class reads — so a
version's draws never change when a class is added. A file may name ``plugins``: modules registering
further fault classes (imported first, here and in every run of the bench).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Literal

from pydantic import ConfigDict, Field, ValidationError, model_validator

from .. import registry
from ..config import existing_file, one_line, read_toml
from ..errors import BadInput
from ..fields import StrictModel
from ..plant.faults import drawn_classes
from ..resources import resource_path
from ..study.spec import HELD_OUT_START

PATH_KINDS = ("circle", "figure8", "line")
"""The reference paths a draw can name (``reference.kind``)."""
CURRENT_VERSION = "ftc-v2"
"""The benchmark version a command, a draw or an episode uses when none is named: the published version whose
judge cannot be fooled (``ftc-v1`` stays shipped, with its pinned draws and its near-path rule)."""
SPLITS = ("dev", "test")
"""The splits whose entropy the definition holds: ``dev`` (development: tune and explore there) and ``test``
(public, judged, never tuned on)."""
PRIVATE = "private"
"""The split whose draws derive from a key given at run time (:mod:`ftc_mj.benchmark.private`): nothing in the
repository or in the outputs lets anyone reproduce them. Its run seeds lie in the test split's range."""
RUN_SPLITS = (*SPLITS, PRIVATE)
"""Every split a bench can run."""

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
    """The faults: the first fault's class (``none``: a fault-free draw; else a fault class's drawn name),
    a second fault's probability, the onsets, and the ranges (``[low, high]``) the classes draw their sizes
    from, each under the name its class reads (``puncture_fraction``, ``speed_bias`` …)."""

    model_config = ConfigDict(extra="allow", validate_assignment=True)
    __pydantic_extra__: dict[str, Range] = Field(init=False)  # type: ignore[assignment]

    classes: dict[str, Prob]
    double: Prob
    onset: Range
    second_delay: Range

    @property
    def ranges(self) -> dict[str, Range]:
        """The classes' ranges by name."""
        return dict(self.__pydantic_extra__ or {})

    @model_validator(mode="after")
    def _classes(self) -> FaultDistribution:
        """Registered drawn names summing to 1, each class's ranges present and inside its parameters' ranges,
        no range that no class reads."""
        drawn = drawn_classes()
        _check_probabilities(self.classes, ("none", *drawn))
        ranges, used = self.ranges, set()
        for kind in self.classes:
            for name in drawn[kind].drawn_as[kind] if kind != "none" else ():
                if name not in ranges:
                    raise ValueError(f"{name}: {kind} draws from this range; it is missing")
                drawn[kind].check_range(name, ranges[name].low, ranges[name].high)
                used.add(name)
        for name in ranges:
            if name not in used:
                raise ValueError(f"{name}: unknown key (no fault class in classes draws from it)")
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
    pose_fix_sigma: Range | None = None
    """The pose sensor's σ (m on x and y; its heading's σ is that per metre, rad), uniform: with it every draw has
    a pose sensor and its controller takes the pose from it (``sensors.pose_source = "sensor"``); without it
    (``ftc-v1``) the controller gets the true pose + ``pose_sigma`` noise."""
    pose_fix_rate: Range | None = None
    """The pose sensor's fix rate (Hz), uniform; given with ``pose_fix_sigma``."""

    @model_validator(mode="after")
    def _pose_sensor(self) -> SensorDistribution:
        if (self.pose_fix_sigma is None) != (self.pose_fix_rate is None):
            raise ValueError("pose_fix_rate: the pose sensor needs both pose_fix_sigma and pose_fix_rate")
        if self.pose_fix_sigma is not None and (self.pose_fix_sigma.low <= 0 or self.pose_fix_rate.low <= 0):
            raise ValueError("pose_fix_sigma: the pose sensor's σ and rate must be positive")
        return self


RULES = ("near-path", "progress")
"""The success rules a version can name (``[judge] rule``)."""


class JudgeRule(StrictModel):
    """How a run of the version is judged (``[judge]``; a property of the version, so a published version keeps its
    rule). ``near-path`` (``ftc-v1``, the default): completed, never tipped, within 0.5 m of the path from 5 s after
    the last onset. ``progress`` (``ftc-v2``): every draw labelled ``trackable`` or ``stop-only`` by the physics of
    :mod:`~ftc_mj.benchmark.attainability`; a trackable draw also needs progress along the path, a stop-only draw a
    safe stop (:mod:`~ftc_mj.benchmark.score`)."""

    rule: Literal["near-path", "progress"] = "near-path"
    progress_fraction: Annotated[float, Field(gt=0.0, le=1.0)] = 0.8
    """Least progress along the path, as a fraction of the distance the attainable speed covers in the window."""
    trackable_speed_fraction: Annotated[float, Field(gt=0.0, le=1.0)] = 0.25
    """A draw is trackable when the damaged robot can make at least this fraction of the desired speed."""
    stop_within: Annotated[float, Field(gt=0.0, le=60.0)] = 5.0
    """s after the disabling fault's onset from which a stop-only run must stay at rest."""
    stop_speed: Annotated[float, Field(gt=0.0, le=5.0)] = 0.1
    """m/s: at rest below this speed."""
    corridor: Annotated[float, Field(gt=0.0, le=50.0)] = 2.0
    """m: a stop-only run stays this close to the path from the disabling onset on."""


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
    plugins: Annotated[list[str], Field(max_length=50)] = Field(default_factory=list)
    """Modules registering the plug-in fault classes the draws name (imported before the rest is read, and
    named in every drawn run's ``plugins``, so every method and every worker meets the same classes)."""
    duration: Annotated[float, Field(gt=0, le=3600)]
    leaderboard_draws: Annotated[int, Field(ge=1, le=2000)] | None = None
    """The draw count of the version's leaderboard (test and private splits), fixed in advance from a power
    analysis (:func:`~ftc_mj.benchmark.stats.draws_for_power`), never from the results; a report of another
    count says it is not the leaderboard's. ``ftc-v1``: 200, fixed before this rule and kept (published); its
    power for a 5-point paired success difference after Holm over its 12 verdicts is 2–67 % at the
    discordances its questions showed (docs/benchmark.md, "Draw count and power")."""
    splits: dict[str, Annotated[int, Field(ge=0)]]
    seeds: SeedRanges
    fault: FaultDistribution
    plant: PlantDistribution
    path: PathDistribution
    sensors: SensorDistribution
    judge: JudgeRule = Field(default_factory=JudgeRule)
    """The success rule of the version (``ftc-v1``: ``near-path``, the rule it was published with)."""

    @model_validator(mode="before")
    @classmethod
    def _plugins_first(cls, data: object) -> object:
        """Import the ``plugins`` modules before the fault classes are checked."""
        registry.load_plugins_of(data)
        return data

    @model_validator(mode="after")
    def _pose_faults_need_the_sensor(self) -> BenchmarkDefinition:
        """A pose fault class needs the pose sensor on every draw (``sensors.pose_fix_sigma``)."""
        drawn = drawn_classes()
        for kind, p in self.fault.classes.items():
            if kind != "none" and p > 0 and "pose" in drawn[kind].targets and self.sensors.pose_fix_sigma is None:
                raise ValueError(f"fault.classes.{kind}: a pose fault needs the pose sensor (sensors.pose_fix_sigma)")
        return self

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


def load_definition(version: str = CURRENT_VERSION) -> BenchmarkDefinition:
    """The definition of ``version``: a shipped version's name, or the path of a definition file (``*.toml``);
    read once per process."""
    if version not in _CACHE:
        if version.endswith(".toml"):
            path = existing_file(version, "--benchmark")
            _CACHE[version] = parse_definition(read_toml(path, "benchmark"), f"benchmark {path.name}")
            return _CACHE[version]
        path = definition_path(version)
        d = parse_definition(read_toml(path, "benchmark"), f"benchmark {path.name}")
        if d.version != version:
            raise BadInput(f"benchmark {path.name}: version: {d.version!r} does not match the file name")
        _CACHE[version] = d
    return _CACHE[version]
