"""The resolved record of one run: :class:`RunRecord`, the facts derived from its config once.

The loop's wiring (:func:`ftc_mj.sim.record.build_record`) resolves them when it builds the run — the
filter setup the filter was built with, the run context, the reference's rates and path curvature, the
scheduled fault onsets, the decision's bounds settings — and the run's metrics, the benchmark's scorer
and the studies read them here instead of recomputing them from the application config. The record is
written beside ``metrics.json`` as ``record.json`` (:meth:`RunRecord.to_json`) and read back with
:meth:`RunRecord.from_json`: floats pass through JSON unchanged (shortest round-trip repr), so a record
read back gives the same metrics bit for bit.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..context import RunContext
from ..estimation.setup import FilterSetup
from ..model.kinematics import KinematicModel
from ..model.sensors import SensorSettings

RECORD_VERSION = 1
"""Version of the ``record.json`` layout (:meth:`RunRecord.to_json`)."""
_ARRAYS = ("x0", "P0", "Q")
"""The :class:`FilterSetup` fields that are numpy arrays."""


@dataclass(frozen=True)
class RunRecord:
    """The resolved facts of one run (SI units, radians), derived once from its config."""

    run_id: str
    """The run's folder name."""
    context: RunContext
    """The run context every component was built with (rates, nominal geometry, seed, sensors)."""
    setup: FilterSetup
    """The filter setup of the run (the filter's own when it exposes one): the inputs of the posterior
    Cramér–Rao bound and of the fault's Kullback–Leibler information (:mod:`ftc_mj.metrics.fdi`)."""
    estimator: str
    """The estimator's kind (``none``: the run has no filter)."""
    onsets: dict[str, float | None]
    """First time (s) each wheel's scheduled radius departs from nominal (``right``, ``left``; None: no fault)."""
    reference_rates: tuple[float, float]
    """The reference's steady speed (m/s) and yaw rate (rad/s), as the decision's calibration takes them."""
    reference_speed: float
    """The desired speed of the reference (m/s)."""
    path_curvatures: tuple[float, ...]
    """The distinct curvatures (1/m) of the reference path, sampled every 0.5 m over one period or 400 m:
    what the speed the robot can still reach depends on (:func:`ftc_mj.metrics.path.feasible_speed`)."""
    plant_half_track: float
    """The true robot's half track (m)."""
    omega_rate_max: float | None
    """The controller's bound on the wheel-rate change (rad/s per s); ``None`` for a controller without one
    (the open loop)."""
    max_split_sigma: float
    """The sigma rule's isolation limit on the radius split σ (m)."""
    arl0: float
    """The decision's mean time between false alarms (s), for Lorden's delay bound."""

    @property
    def first_onset(self) -> float | None:
        """The earliest scheduled tyre fault onset (s), None without one."""
        return min((o for o in self.onsets.values() if o is not None), default=None)

    def to_json(self) -> dict[str, Any]:
        """The record as plain JSON data (arrays as nested lists)."""
        s = self.setup
        setup = {f.name: getattr(s, f.name) for f in dataclasses.fields(s) if f.name != "model"}
        setup.update({k: np.asarray(setup[k]).tolist() for k in _ARRAYS}, b=s.model.b, model_dt=s.model.dt)
        context = dataclasses.asdict(dataclasses.replace(self.context, sensors=None))
        context["sensors"] = self.context.sensors.model_dump() if self.context.sensors is not None else None
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out.update(version=RECORD_VERSION, context=context, setup=setup)
        return out

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> RunRecord:
        """The record :meth:`to_json` wrote (``ValueError`` naming the version for another layout)."""
        if data.get("version") != RECORD_VERSION:
            raise ValueError(f"record.json: version {data.get('version')!r}, expected {RECORD_VERSION}")
        s = dict(data["setup"])
        model = KinematicModel(b=s.pop("b"), dt=s.pop("model_dt"))
        setup = FilterSetup(model=model, **{k: (np.asarray(v, float) if k in _ARRAYS else v) for k, v in s.items()})
        c = dict(data["context"])
        tuples = ("nominal_radii", "initial_pose")
        context = RunContext(**{k: (tuple(v) if k in tuples else v) for k, v in c.items() if k != "sensors"},
                             sensors=None if c["sensors"] is None else SensorSettings.model_validate(c["sensors"]))
        fields = {f.name for f in dataclasses.fields(cls)} - {"context", "setup"}
        rest = {k: data[k] for k in fields}
        rest["reference_rates"] = tuple(rest["reference_rates"])
        rest["path_curvatures"] = tuple(rest["path_curvatures"])
        return cls(context=context, setup=setup, **rest)
