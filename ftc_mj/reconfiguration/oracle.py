"""The truth as a diagnosis: the configured faults as :class:`~ftc_mj.model.diagnosis.Diagnosis` records from
their onsets on — the benchmark's oracle.

Handed to the accommodation (:mod:`.accommodation`) in place of a diagnoser, it makes "the same controller
given the truth": the gap between a method and its oracle is then the diagnosis's alone. A run may use it
only when its config says ``oracle = true`` (the wiring checks; nothing a method may know comes from here
otherwise).

Each fault is declared at its onset (``onset = declared``, σ 0, no test statistic: ``statistic`` and
``threshold`` are NaN) and stays declared while it acts; its size is the truth at the time asked, in the
units of :mod:`ftc_mj.model.diagnosis`: a tyre's remaining radius over nominal (a ramp's current value), a
servo's remaining effectiveness (0 for a lock or an unresponsive servo), a sensor's offset (bias), its growth
rate (drift, per s) or the dropout's duration so far (s); a pose bias or jump also carries its displacement
``(dx, dy)`` (m, along the fault library's diagonal) as the record's offset, σ 0. A tyre's size is at most 1
(a schedule above the nominal radius is no puncture; the record holds sizes in (0, 1]). A sensor fault that ends
is withdrawn at its end.
A plug-in fault class whose (component, target, mode) is not in the shared vocabulary is not declared.
"""

from __future__ import annotations

import math

from ..model.diagnosis import COMPONENT_MODES, COMPONENT_TARGETS, OFFSET_MODES, Diagnosis
from ..plant.faults import FaultClass, FaultSettings, faults_of, wheel_index, wheel_schedules
from ..plant.faults.sensor import POSE_DIRECTION

NAN = float("nan")


class TruthDiagnoses:
    """The configured faults (``[faults]``) around the plant's ``nominal_radius`` (m) as diagnoses
    (module docstring); :meth:`diagnoses` at any time ``t`` (s)."""

    def __init__(self, faults: FaultSettings, nominal_radius: float) -> None:
        self.nominal = float(nominal_radius)
        self.schedules = wheel_schedules(faults, self.nominal)
        self.faults: list[FaultClass] = [f for f in faults_of(faults, self.nominal) if _in_vocabulary(f)]

    def diagnoses(self, t: float) -> tuple[Diagnosis, ...]:
        """The faults acting at ``t`` (s), each as the diagnosis a perfect diagnoser would declare."""
        out = []
        for f in self.faults:
            if t + 1e-9 < f.onset or t + 1e-9 >= f.onset + _duration(f):
                continue
            size = self.size(f, t)
            vector = {}
            if (f.component, f.mode) in OFFSET_MODES:
                vector = {"offset": (size * POSE_DIRECTION[0], size * POSE_DIRECTION[1]), "offset_sigma": (0.0, 0.0)}
            out.append(Diagnosis(component=f.component, target=f.target, mode=f.mode, size=size,
                                 sigma=0.0, onset=f.onset, declared=f.onset, statistic=NAN, threshold=NAN, **vector))
        return tuple(out)

    def size(self, f: FaultClass, t: float) -> float:
        """The size of fault ``f`` at ``t`` (s) in the diagnosis's unit (module docstring)."""
        if f.component == "tyre":
            return min(self.schedules[wheel_index(f.target)].value(t) / self.nominal, 1.0)
        if f.component == "servo":
            return float(f.settings.effectiveness) if f.mode == "loss" else 0.0
        if f.mode == "dropout":
            return t - f.onset
        return float(f.size)


def _duration(f: FaultClass) -> float:
    """How long fault ``f`` acts (s): its ``duration`` if its table has one, else for ever."""
    d = getattr(f.settings, "duration", None)
    return math.inf if d is None else float(d)


def _in_vocabulary(f: FaultClass) -> bool:
    """Whether ``f``'s (component, target, mode) is one a :class:`Diagnosis` may name."""
    return f.mode in COMPONENT_MODES.get(f.component, ()) and f.target in COMPONENT_TARGETS.get(f.component, ())
