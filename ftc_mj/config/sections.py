"""The sections of a run config (``robot``, ``plant``, ``model``, ``faults``, ``sensors``,
``estimator``, ``diagnosis``, ``controller``, ``reconfiguration``, ``reference``, ``output``): one pydantic model
each, with the paper's values as defaults. SI units and radians throughout; the only
degree-valued fields end in ``_deg``.

A component's factory receives its own section (``estimator``, ``controller``, …) as its settings. The
estimation and reconfiguration sections are composed of the settings models declared beside their
components (:mod:`ftc_mj.estimation.setup`, :mod:`~ftc_mj.estimation.imm`,
:mod:`~ftc_mj.estimation.rule_statistics`, :mod:`ftc_mj.reconfiguration.policies`,
:mod:`~ftc_mj.reconfiguration.degraded`, :mod:`ftc_mj.control.excitation`); nothing here re-declares them. The
plant's sections (``robot``, ``plant``, ``model``, ``faults``) are declared beside the plant
(:mod:`ftc_mj.plant.settings`, the fault classes' tables in :mod:`ftc_mj.plant.faults`) and composed here. The
Control settings are declared beside their components and only composed here: ``controller`` is the union of
the controller kinds' models discriminated by ``kind`` (:data:`ControllerConfig`), ``reference`` the reference
path's model.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Union

from pydantic import (
    BaseModel,
    BeforeValidator,
    Discriminator,
    Field,
    SerializerFunctionWrapHandler,
    Tag,
    TypeAdapter,
    ValidationError,
    model_serializer,
)

from ..control.base import ControllerSettings
from ..control.excitation import ExcitationSettings
from ..control.lmpc import LinearMPCSettings
from ..control.nmpc import NMPCSettings
from ..control.open_loop import OpenLoopSettings
from ..control.pathfollow import PathFollowingNMPCSettings
from ..control.robust import RobustNMPCSettings
from ..control.spec import PluginControllerSettings
from ..estimation.diagnosis import DIAGNOSER_KINDS, PluginDiagnoserSettings
from ..estimation.kinds import BUILTIN_ESTIMATORS
from ..estimation.settings import EstimatorSettings, PluginEstimatorSettings
from ..fields import (
    Flag,
    PathText,
    StrictModel,
)
from ..plant.settings import FaultSettings as FaultSettings  # the plant's sections, composed by RunConfig
from ..plant.settings import ModelSettings as ModelSettings
from ..plant.settings import PlantSettings as PlantSettings
from ..plant.settings import RobotSettings as RobotSettings
from ..reconfiguration.accommodation import AccommodationSettings
from ..reconfiguration.degraded import DegradedSettings
from ..reconfiguration.policies import ReconfigurationSettings

ESTIMATOR_KINDS: dict[str, type[EstimatorSettings]] = {k: kind.settings for k, kind in BUILTIN_ESTIMATORS.items()}
"""The built-in estimator kinds and their settings models (each declared beside its filter; the one table of
built-in kinds is :data:`~ftc_mj.estimation.kinds.BUILTIN_ESTIMATORS`)."""

CONTROLLER_KINDS: dict[str, type[ControllerSettings]] = {
    "nmpc": NMPCSettings, "lmpc": LinearMPCSettings, "pf-nmpc": PathFollowingNMPCSettings,
    "robust-nmpc": RobustNMPCSettings, "open-loop": OpenLoopSettings}
"""The built-in controller kinds and their settings models (each declared beside its controller)."""


def _kind_tag(kinds: dict[str, type[BaseModel]], default: str) -> Any:
    """The union member of a section's table: its ``kind``'s model (``default`` when not given), a plug-in's
    for any other name (checked against the registry there). Tags are not identifiers, so error messages name
    the field as the user wrote it (``controller.nodes``)."""
    def tag(value: Any) -> str:
        kind = value.get("kind", default) if isinstance(value, dict) else getattr(value, "kind", None)
        return f"kind={kind}" if isinstance(kind, str) and kind in kinds else "kind=plug-in"

    return tag


def _is_default(model: type[BaseModel], key: str, value: Any) -> bool:
    """Whether ``value`` is ``model``'s default of its setting ``key`` (as validated by the field)."""
    f = model.model_fields[key]
    field_type = Annotated[(f.annotation, *f.metadata)] if f.metadata else f.annotation
    try:
        given = TypeAdapter(field_type).validate_python(value)
    except ValidationError:
        return False
    return bool(given == f.get_default(call_default_factory=True))


def _other_kinds_keys(section: str, kinds: dict[str, type[BaseModel]], plugin: type[BaseModel], default: str) -> Any:
    """A section's table (of a built-in kind, or a plug-in's: ``plugin``) holding a key of another kind only: a
    one-line error naming the key and the kinds that have it (``controller.nodes: not a setting of controller
    'open-loop' …``). Such a key at that kind's default is dropped: a resolved config written when the section
    was one flat table (every kind's settings, the others' at their defaults) still reads as the run it was."""
    def drop(value: Any) -> Any:
        if not isinstance(value, dict):
            return value
        kind = value.get("kind", default)
        model = kinds.get(kind, plugin) if isinstance(kind, str) else None
        out = dict(value)
        for key in value if model is not None else ():
            owners = [m for m in kinds.values() if key in m.model_fields]
            if key in model.model_fields or not owners:
                continue
            if not _is_default(owners[0], key, value[key]):
                names = ", ".join(k for k, m in kinds.items() if m in owners)
                raise ValueError(f"{key}: not a setting of {section} {kind!r} (a setting of {names})")
            del out[key]
        return out

    return drop


def kind_union(section: str, kinds: dict[str, type[BaseModel]], plugin: type[BaseModel], default: str) -> Any:
    """The type of a section discriminated by ``kind``: the built-in ``kinds``' models or the ``plugin`` model
    for any other registered name; a table without ``kind`` is ``default``'s."""
    members = [Annotated[m, Tag(f"kind={k}")] for k, m in [*kinds.items(), ("plug-in", plugin)]]
    return Annotated[Union[tuple(members)], Discriminator(_kind_tag(kinds, default)),  # noqa: UP007
                     BeforeValidator(_other_kinds_keys(section, kinds, plugin, default))]


EstimatorConfig = kind_union("estimator", ESTIMATOR_KINDS, PluginEstimatorSettings, "ukf")
"""The FDI filter (paper §3), discriminated by ``kind``: the built-in kinds' models (:data:`ESTIMATOR_KINDS`:
the filter model's settings, a UKF's sigma points, an IMM bank's, the fault decision) or a plug-in's (its
``options``). Defaults are exactly the paper's values."""

ControllerConfig = kind_union("controller", CONTROLLER_KINDS, PluginControllerSettings, "nmpc")
"""The trajectory-tracking controller (paper §3), discriminated by ``kind``: the built-in kinds' models
(:data:`CONTROLLER_KINDS`) or a plug-in's (its ``options``)."""


DiagnosisConfig = kind_union("diagnosis", DIAGNOSER_KINDS, PluginDiagnoserSettings, "residual")
"""The diagnoser (which component failed, how, how much, since when: :mod:`ftc_mj.estimation.diagnosis`),
discriminated by ``kind``: the built-in ``residual`` and ``none`` (:data:`DIAGNOSER_KINDS`) or a plug-in's
(its ``options``)."""


class ReconfigurationConfig(ReconfigurationSettings):
    """The ``[reconfiguration]`` section: the policy's settings
    (:class:`~ftc_mj.reconfiguration.policies.ReconfigurationSettings`), the excitation, the degraded mode and
    the accommodation of the diagnosed modes (:mod:`ftc_mj.reconfiguration.accommodation`)."""

    excitation: ExcitationSettings = Field(default_factory=ExcitationSettings)
    degraded: DegradedSettings = Field(default_factory=DegradedSettings)
    accommodation: AccommodationSettings = Field(default_factory=AccommodationSettings)

    @model_serializer(mode="wrap")
    def _omit_default_accommodation(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        """The fields, without ``accommodation`` at its defaults: a run that does not use it keeps the identity
        (run id, study key) it had before it existed."""
        data = handler(self)
        if self.accommodation == AccommodationSettings():
            data.pop("accommodation", None)
        return data




class OutputConfig(StrictModel):
    dir: PathText = Path("runs/out")
    rrd: Flag = True
    progress: Flag = True

