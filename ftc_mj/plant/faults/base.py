"""What a fault class is: :class:`FaultClass` (its name, component, targets, mode, unit, parameters'
ranges, truth columns and the measurements that can observe it), with the two kinds of physics a fault
can have — on the plant (:class:`PlantFault`, acting through an :class:`Effect`) or on a sensor's readings
(:class:`SensorFault`) — and how a benchmark draws it (:meth:`FaultClass.draw`, :meth:`FaultClass.add_to`).

Every fault class is registered in :data:`ftc_mj.registry.fault_classes` under its :attr:`~FaultClass.name`;
the registry's factory is the class itself, which builds one fault from its configuration table. A class
is the one home of its strings: the configuration, the plant, the sensors, the benchmark's definition,
draws and scorer, ``ftc-mj components`` and the docs read its attributes.
"""

from __future__ import annotations

import math
import sys
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

from pydantic import BaseModel

from ... import registry

NEVER = sys.maxsize
"""The physics step of a change that never comes."""
WHEELS = ("right", "left")
"""The wheels a tyre or servo fault can hit (right first, the plant's order)."""


def onset_step(onset: float, dt: float) -> int:
    """The first physics step ``k`` whose time ``k dt`` (s) is at or after ``onset`` (s), to 1 ns."""
    return max(0, math.ceil((onset - 1e-9) / dt))


@dataclass(frozen=True)
class Param:
    """One parameter of a fault class: its unit (``""``: a fraction), the interval it may take
    (``low``/``high``, open ends as flagged) and what it means."""

    unit: str
    low: float
    high: float
    doc: str
    low_open: bool = False
    high_open: bool = False

    def contains(self, v: float) -> bool:
        """Whether ``v`` lies in the parameter's interval."""
        above = v > self.low if self.low_open else v >= self.low
        return above and (v < self.high if self.high_open else v <= self.high)

    def interval(self) -> str:
        """The interval as written in messages and tables: ``(0, 1]``."""
        return f"{'(' if self.low_open else '['}{self.low:g}, {self.high:g}{')' if self.high_open else ']'}"


Sample = Callable[[str], float]
"""A benchmark's sampler: a value drawn uniformly from the definition's range of that name."""


class FaultClass(ABC):
    """One fault class: a (component, mode) pair with its physics. An instance is one configured fault.

    Args:
        settings: the fault's configuration table (the class's :attr:`Settings` model).
    """

    name: ClassVar[str]
    """The registered name (``actuator_loss``): the ``fault_class`` of its records and draws."""
    component: ClassVar[str]
    """What fails: ``tyre``, ``servo``, ``speed sensor``, ``gyro`` …"""
    mode: ClassVar[str]
    """How it fails: ``puncture``, ``loss``, ``lock``, ``unresponsive``, ``bias``, ``drift``, ``dropout`` …"""
    targets: ClassVar[tuple[str, ...]]
    """What a fault of the class can hit: ``right``/``left`` wheel, ``speed``/``yaw_rate`` sensor."""
    unit: ClassVar[str]
    """Unit of the fault's :attr:`size` (``""``: a fraction)."""
    params: ClassVar[Mapping[str, Param]]
    """Its parameters and their ranges (the size's meaning first)."""
    observed_by: ClassVar[tuple[str, ...]]
    """The measurements that can observe it (``speed``, ``yaw_rate``, ``position``, ``wheel_rates``): what a
    diagnosis may hope to isolate it with (a gyro bias is observed by the gyro alone)."""
    radius_fault: ClassVar[bool] = False
    """The fault is a change of a wheel's radius (the one the filters' radius model isolates as a wheel)."""
    drawn_as: ClassVar[Mapping[str, tuple[str, ...]]] = {}
    """The names a benchmark draws it under, each with the ranges of the definition's ``[fault]`` table it
    reads (a puncture is drawn as ``puncture_step`` or ``puncture_ramp``); empty = never drawn."""
    Settings: ClassVar[type]
    """Its configuration table's model (declared beside the class)."""
    config: ClassVar[str] = "[[faults.plugin]]"
    """Where a run config sets one (the table and its selecting key)."""

    def __init__(self, settings: BaseModel) -> None:
        self.settings = settings

    # ---------------------------------------------------------------- the configured fault
    @property
    def target(self) -> str:
        """What the fault hits (one of :attr:`targets`)."""
        return str(self.settings.target)

    @property
    def onset(self) -> float:
        """Time (s) from which it acts."""
        return float(self.settings.onset)

    @property
    def size(self) -> float:
        """Its size in :attr:`unit` (what a scorer reports)."""
        return float(self.settings.size)

    @classmethod
    def columns(cls, target: str) -> tuple[str, ...]:
        """Its truth columns in a trace when it hits ``target``."""
        return ()

    # ---------------------------------------------------------------- the benchmark
    @classmethod
    def draw(cls, kind: str, sample: Sample, sign: float) -> dict[str, float]:
        """The drawn ``size`` (and ``rate`` m/s, ``duration`` s where they apply) of a fault drawn as
        ``kind``: by default the size uniform in the definition's range named ``kind``, of random sign."""
        return {"size": round(sign * sample(kind), 5)}

    @classmethod
    def add_to(cls, faults: dict[str, Any], kind: str, target: str, onset: float, drawn: Mapping[str, float],
               nominal: float) -> None:
        """Add a drawn fault to the ``[faults]`` section ``faults`` (radius ``nominal`` in m): by default a
        ``[[faults.plugin]]`` table."""
        table: dict[str, Any] = {"fault_class": cls.name, "target": target, "onset": onset, "size": drawn["size"]}
        if drawn.get("duration"):
            table["duration"] = drawn["duration"]
        faults.setdefault("plugin", []).append(table)

    @classmethod
    def check_range(cls, name: str, low: float, high: float) -> None:
        """``ValueError`` if a benchmark range ``name`` of the class (``[low, high]``) leaves the parameter
        it draws; by default the size's (magnitudes: drawn with a random sign)."""
        size = next(iter(cls.params.values()))
        for v in (low, high):
            if not size.contains(abs(v) if size.low >= 0 else v):
                raise ValueError(f"{name}: {v:g} outside the {cls.name} size's {size.interval()} {size.unit}".rstrip())

    @classmethod
    def describe(cls) -> str:
        """One line: mode, component, targets, the size's unit, parameters' ranges, truth columns, observed by."""
        params = ", ".join(f"{k} {p.interval()}{' ' + p.unit if p.unit else ''}" for k, p in cls.params.items())
        columns = ", ".join(c for t in cls.targets for c in cls.columns(t)) or "none"
        return (f"{cls.name}: {cls.mode} of the {cls.component} (targets {'/'.join(cls.targets)}; size in "
                f"{cls.unit or 'fraction'}; {params}; truth columns {columns}; observed by "
                f"{', '.join(cls.observed_by)})")


def markdown_table(classes: list[type[FaultClass]]) -> str:
    """The classes as a Markdown table (the one in docs/scenarios.md): what each changes (the first line of
    its docstring), where it is configured, its size's unit, its parameters' ranges, truth columns and the
    measurements that observe it."""
    lines = ["| class | what it changes | config | size (unit) | parameters | trace truth | observed by |",
             "|---|---|---|---|---|---|---|"]
    for c in classes:
        doc = (c.__doc__ or "").strip().splitlines()[0].rstrip(".")
        params = "; ".join(f"{k} {p.interval()}{' ' + p.unit if p.unit else ''}" for k, p in c.params.items())
        columns = ", ".join(f"`{col}`" for t in c.targets for col in c.columns(t)) or "—"
        cells = [f"`{c.name}`", doc, c.config.replace("|", "\\|"), c.unit or "fraction", params, columns,
                 ", ".join(c.observed_by)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


class Effect(ABC):
    """What the plant faults of one kind do together to the plant: a state combining the active faults
    (:meth:`healthy`, then :meth:`PlantFault.combine` of each in configuration order), put in force by
    :meth:`apply` and recorded by :meth:`truth`. A new kind of plant fault is a new effect beside its
    class; the plants only call these four methods (:class:`~ftc_mj.plant.faults.plant.PlantFaults`)."""

    columns: ClassVar[tuple[str, ...]] = ()
    """Its trace columns (written while a run has a fault of it)."""

    def prepare(self, plant: Any) -> None:  # noqa: B027 - most effects restore nothing
        """Remember what :meth:`apply` restores (the healthy model) before any fault acts."""

    @abstractmethod
    def healthy(self) -> Any:
        """The state without an active fault."""

    @abstractmethod
    def apply(self, plant: Any, state: Any) -> None:
        """Put ``state`` in force on ``plant`` (a :class:`~ftc_mj.plant.robot.Plant` or
        :class:`~ftc_mj.plant.kinematic.KinematicPlant`, by its ``kind``)."""

    def truth(self, state: Any) -> dict[str, float]:
        """The trace values (:attr:`columns`) of ``state``."""
        return {}


class PlantFault(FaultClass):
    """A fault acting on the plant through its :attr:`effect` from its onset step on."""

    effect: ClassVar[Effect]
    """The effect its faults share (one object per effect)."""
    plants: ClassVar[tuple[str, ...]] = ("mujoco", "kinematic")
    """The plant kinds it can act on."""

    @abstractmethod
    def combine(self, state: Any) -> None:
        """Add this (active) fault to its effect's ``state``."""


class SensorFault(FaultClass):
    """A fault acting on one sensor's reading from ``onset`` for ``duration`` seconds."""

    @property
    def duration(self) -> float:
        """How long it lasts (s)."""
        return float(self.settings.duration)

    @abstractmethod
    def reading(self, elapsed: float) -> tuple[float, bool]:
        """The offset (the sensor's unit) it adds ``elapsed`` seconds after its onset, and whether the sample
        is missing."""

    @classmethod
    def offset_profile(cls, size: float, elapsed: Any) -> Any:
        """The offsets of a fault of ``size`` at the times ``elapsed`` (s, an array) after its onset, for a
        scorer's information bound; ``None`` when it carries no information (a dropout)."""
        return None


fault_classes = registry.fault_classes


def fault_class(name: str) -> type[FaultClass]:
    """The registered class ``name`` (``KeyError`` naming the registered ones)."""
    return fault_classes.get(name).factory  # type: ignore[no-any-return]


def all_classes() -> list[type[FaultClass]]:
    """Every registered fault class, by name."""
    return [fault_class(n) for n in fault_classes.names()]


def drawn_classes() -> dict[str, type[FaultClass]]:
    """Every name a benchmark can draw, with its class."""
    return {kind: c for c in all_classes() for kind in c.drawn_as}
