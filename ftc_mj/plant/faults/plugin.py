"""The configuration table of a fault of a plug-in class (``[[faults.plugin]]``): the class's registered
name, its target, onset, size and duration, and its own ``options`` (validated by the model the class was
registered with). The built-in classes have their own tables (``right``/``left``, ``actuator``, ``sensor``).
"""

from __future__ import annotations

from pydantic import Field, model_validator

from ... import registry
from ...fields import FiniteFloat, Options, StrictModel, component, options_of, ranged
from .base import fault_class
from .servo import FaultTime


class PluginFaultSettings(StrictModel):
    """One fault of a registered plug-in class (``[[faults.plugin]]``)."""

    fault_class: component("fault_classes")
    """A fault class registered by a plug-in module (:data:`ftc_mj.registry.fault_classes`)."""
    target: str
    """What it hits (one of the class's ``targets``)."""
    onset: FaultTime
    size: FiniteFloat = 0.0
    """Its size in the class's unit, within the range of its first parameter."""
    duration: ranged(0.0, 1.0e9, lo_open=True, unit="s") = 1.0e9
    """How long a sensor fault lasts (s); the default outlasts any run."""
    options: Options = Field(default_factory=dict, validate_default=True)
    """The class's own settings (its registered settings model)."""

    _options = options_of("fault_classes", "fault_class")

    @model_validator(mode="after")
    def _fits_class(self) -> PluginFaultSettings:
        """A plug-in class (a built-in one has its own table), one of its targets, a size in its range."""
        entry = registry.fault_classes.get(self.fault_class)
        if entry.origin == registry.BUILTIN:
            raise ValueError(f"fault_class: {self.fault_class!r} is built in; configure it in its own table "
                             "([faults] right/left, [[faults.actuator]], [[faults.sensor]])")
        cls = fault_class(self.fault_class)
        if self.target not in cls.targets:
            raise ValueError(f"target: {self.fault_class} hits {', '.join(cls.targets)}, not {self.target!r}")
        size = next(iter(cls.params.values()))
        if not size.contains(self.size):
            raise ValueError(f"size: must lie in {size.interval()} {size.unit}".rstrip() + f", got {self.size:g}")
        return self
