"""The diagnosis vocabulary shared by the fault library, the diagnosers, the accommodation and the scorer.

A fault is named by *(component, target, mode)* — the same triple the fault classes
(:mod:`ftc_mj.plant.faults`) declare for the truth and a diagnoser declares for its belief — so a scorer
compares them without a translation table:

=================  ======================  ==================================================================
component          target                  modes
=================  ======================  ==================================================================
``tyre``           ``left`` / ``right``    ``puncture`` (radius lost, as a step or a ramp)
``servo``          ``left`` / ``right``    ``loss`` (gain and torque scaled), ``lock``, ``unresponsive``
``speed sensor``   ``speed``               ``bias``, ``drift``, ``dropout``
``gyro``           ``yaw_rate``            ``bias``, ``drift``, ``dropout``
``pose sensor``    ``pose``                ``bias``, ``jump``, ``dropout``
=================  ======================  ==================================================================

:class:`Diagnosis` is one declaration: what a diagnoser believes failed, how much, since when, on what
evidence. Sizes are in the mode's unit: a *fraction of the nominal* quantity for tyres (remaining radius
/ nominal radius) and servos (remaining gain / nominal gain; 0 for a lock or an unresponsive servo), so
a rescaled robot is diagnosed the same; the sensor's unit for a sensor offset (m/s, rad/s, m) or its
growth rate (per s); the duration so far (s) for a dropout.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import asdict, dataclass
from typing import Any

COMPONENT_MODES: dict[str, tuple[str, ...]] = {
    "tyre": ("puncture",),
    "servo": ("loss", "lock", "unresponsive"),
    "speed sensor": ("bias", "drift", "dropout"),
    "gyro": ("bias", "drift", "dropout"),
    "pose sensor": ("bias", "jump", "dropout"),
}
"""Every component a diagnosis may name, with its modes."""

COMPONENT_TARGETS: dict[str, tuple[str, ...]] = {
    "tyre": ("left", "right"), "servo": ("left", "right"), "speed sensor": ("speed",), "gyro": ("yaw_rate",),
    "pose sensor": ("pose",),
}
"""The targets of each component (a wheel side or the sensor's reading)."""


@dataclass(frozen=True)
class Diagnosis:
    """One declaration of a fault (module docstring for the vocabulary and the units).

    Attributes:
        component: what failed (a key of :data:`COMPONENT_MODES`).
        target: which one (a value of :data:`COMPONENT_TARGETS` for the component).
        mode: how it failed (one of the component's modes).
        size: how much, in the mode's unit (fraction of nominal for tyres and servos).
        sigma: the size's standard deviation (same unit; ``nan`` when the diagnoser has none).
        onset: estimated onset time (s).
        declared: declaration time (s).
        statistic: the test statistic that crossed its threshold (its own unit, e.g. a log-likelihood ratio).
        threshold: that threshold (same unit).
    """

    component: str
    target: str
    mode: str
    size: float
    sigma: float
    onset: float
    declared: float
    statistic: float
    threshold: float

    def __post_init__(self) -> None:
        modes = COMPONENT_MODES.get(self.component)
        if modes is None:
            raise ValueError(f"diagnosis component {self.component!r}: not one of {', '.join(COMPONENT_MODES)}")
        if self.mode not in modes:
            raise ValueError(f"diagnosis mode {self.mode!r}: not a mode of {self.component} ({', '.join(modes)})")
        if self.target not in COMPONENT_TARGETS[self.component]:
            raise ValueError(f"diagnosis target {self.target!r}: not a target of {self.component} "
                             f"({', '.join(COMPONENT_TARGETS[self.component])})")

    @property
    def key(self) -> tuple[str, str, str]:
        """``(component, target, mode)``: what a confusion matrix compares."""
        return self.component, self.target, self.mode

    def as_dict(self) -> dict[str, Any]:
        """The record as a flat dict (events, the run summary, JSON)."""
        return asdict(self)


def in_force(declared: Iterable[Diagnosis]) -> tuple[Diagnosis, ...]:
    """The declarations in force among ``declared`` (in declaration order): the latest per *(component,
    target)* — a diagnoser re-declares a fault as it learns more (a settling puncture's size, a bias found to
    drift, a loss found unresponsive), and the latest word replaces the earlier ones."""
    latest: dict[tuple[str, str], Diagnosis] = {}
    for d in declared:
        latest.pop((d.component, d.target), None)
        latest[(d.component, d.target)] = d
    return tuple(latest.values())
