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
growth rate (per s); the duration so far (s) for a dropout. A tyre's size lies in (0, 1] (a tyre neither
vanishes nor grows past its nominal radius): the record rejects any other, so no accommodation or stop law reads
a radius ≤ 0.

Where the mode displaces a reading that has more than one axis — a pose sensor's ``bias`` or ``jump`` moves the
fix's (x, y) — the record also carries that displacement as a vector, :attr:`Diagnosis.offset` (m, world frame),
with its σ per axis: the correction an accommodation subtracts from later fixes. Its scalar ``size`` stays the
fault library's (the displacement along the 45° diagonal), so a scorer compares it with the truth as before.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
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

OFFSET_MODES: frozenset[tuple[str, str]] = frozenset({("pose sensor", "bias"), ("pose sensor", "jump")})
"""The *(component, mode)* pairs whose record may carry :attr:`Diagnosis.offset`: a displacement of the pose
fix's (x, y)."""


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
        offset: the displacement ``(dx, dy)`` (m, world frame) of the sensor's readings now, for a mode of
            :data:`OFFSET_MODES` (``(0, 0)`` for a jump seen to return); ``None`` without one.
        offset_sigma: its σ per axis ``(σx, σy)`` (m); given with ``offset`` and only with it.
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
    offset: tuple[float, float] | None = None
    offset_sigma: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        modes = COMPONENT_MODES.get(self.component)
        if modes is None:
            raise ValueError(f"diagnosis component {self.component!r}: not one of {', '.join(COMPONENT_MODES)}")
        if self.mode not in modes:
            raise ValueError(f"diagnosis mode {self.mode!r}: not a mode of {self.component} ({', '.join(modes)})")
        if self.target not in COMPONENT_TARGETS[self.component]:
            raise ValueError(f"diagnosis target {self.target!r}: not a target of {self.component} "
                             f"({', '.join(COMPONENT_TARGETS[self.component])})")
        if self.component == "tyre" and not 0.0 < self.size <= 1.0:
            raise ValueError(f"diagnosis of the {self.target} tyre: size {self.size!r} outside (0, 1] (a fraction of "
                             "the nominal radius)")
        self._check_offset()

    def _check_offset(self) -> None:
        """``offset`` and ``offset_sigma``: both or neither, two finite numbers each (σ ≥ 0), only for a mode of
        :data:`OFFSET_MODES`; stored as tuples of floats (a JSON list round-trips)."""
        if self.offset is None and self.offset_sigma is None:
            return
        if (self.component, self.mode) not in OFFSET_MODES:
            raise ValueError(f"diagnosis {self.component} {self.mode}: no offset vector for this mode")
        if self.offset is None or self.offset_sigma is None:
            raise ValueError("diagnosis offset: give the offset and its sigma together")
        offset, sigma = _pair(self.offset, "offset"), _pair(self.offset_sigma, "offset_sigma")
        if min(sigma) < 0.0:
            raise ValueError(f"diagnosis offset_sigma {sigma}: negative")
        object.__setattr__(self, "offset", offset)
        object.__setattr__(self, "offset_sigma", sigma)

    @property
    def key(self) -> tuple[str, str, str]:
        """``(component, target, mode)``: what a confusion matrix compares."""
        return self.component, self.target, self.mode

    def as_dict(self) -> dict[str, Any]:
        """The record as a dict (events, the run summary, JSON); the offset and its σ as two-element lists or
        ``None``."""
        out = asdict(self)
        for key in ("offset", "offset_sigma"):
            out[key] = None if out[key] is None else list(out[key])
        return out

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Diagnosis:
        """The record of :meth:`as_dict`'s ``d`` (a summary's or a JSON file's; a record written before the
        offset fields has none)."""
        return cls(**{k: d[k] for k in cls.__dataclass_fields__ if k in d})


def _pair(v: Sequence[float], name: str) -> tuple[float, float]:
    """``v`` as two finite floats (a ``ValueError`` names ``name`` otherwise)."""
    out = tuple(float(x) for x in v)
    if len(out) != 2 or not all(math.isfinite(x) for x in out):
        raise ValueError(f"diagnosis {name} {v!r}: not two finite numbers")
    return out[0], out[1]


def in_force(declared: Iterable[Diagnosis]) -> tuple[Diagnosis, ...]:
    """The declarations in force among ``declared`` (in declaration order): the latest per *(component,
    target)* — a diagnoser re-declares a fault as it learns more (a settling puncture's size, a bias found to
    drift, a loss found unresponsive), and the latest word replaces the earlier ones."""
    latest: dict[tuple[str, str], Diagnosis] = {}
    for d in declared:
        latest.pop((d.component, d.target), None)
        latest[(d.component, d.target)] = d
    return tuple(latest.values())
