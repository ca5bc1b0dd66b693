"""The sections of a run config (``robot``, ``plant``, ``model``, ``faults``, ``sensors``,
``estimator``, ``controller``, ``reconfiguration``, ``reference``, ``output``): one pydantic model
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
    BeforeValidator,
    Discriminator,
    Field,
    Tag,
    TypeAdapter,
    ValidationError,
)

from ..control.base import ControllerSettings
from ..control.excitation import ExcitationSettings
from ..control.lmpc import LinearMPCSettings
from ..control.nmpc import NMPCSettings
from ..control.open_loop import OpenLoopSettings
from ..control.pathfollow import PathFollowingNMPCSettings
from ..control.reference import ReferenceSettings
from ..control.robust import RobustNMPCSettings
from ..control.spec import PluginControllerSettings
from ..estimation.imm import HypothesisSettings, IMMSettings
from ..estimation.rule_statistics import DecisionSettings
from ..fields import (
    Flag,
    Options,
    PathText,
    StrictModel,
    component,
    options_of,
)
from ..plant.settings import FaultSettings as FaultSettings  # the plant's sections, composed by RunConfig
from ..plant.settings import ModelSettings as ModelSettings
from ..plant.settings import PlantSettings as PlantSettings
from ..plant.settings import RobotSettings as RobotSettings
from ..reconfiguration.degraded import DegradedSettings
from ..reconfiguration.policies import ReconfigurationSettings

DecisionConfig = DecisionSettings
"""The ``[estimator.decision]`` section: :class:`~ftc_mj.estimation.rule_statistics.DecisionSettings`."""
HypothesisConfig = HypothesisSettings
"""One member of ``estimator.imm_bank``: :class:`~ftc_mj.estimation.imm.HypothesisSettings`."""
DegradedConfig = DegradedSettings
"""``[reconfiguration.degraded]``: :class:`~ftc_mj.reconfiguration.degraded.DegradedSettings`."""
ExcitationConfig = ExcitationSettings
"""``[reconfiguration.excitation]``: :class:`~ftc_mj.control.excitation.ExcitationSettings`."""


class EstimatorConfig(IMMSettings):
    """The ``[estimator]`` section: the FDI filter (paper §3) named by ``kind``, with the settings of the filters
    (:class:`~ftc_mj.estimation.setup.FilterSettings`) and of an IMM bank
    (:class:`~ftc_mj.estimation.imm.IMMSettings`), and the fault decision. Defaults are exactly the paper's
    values."""

    kind: component("estimators") = "ukf"
    """A registered estimator (:data:`ftc_mj.registry.estimators`). Built-in: ``ekf``, ``ukf``,
    ``imm-ekf``, ``imm-ukf`` (IMM banks of EKF/UKF members), ``none`` (no filter)."""
    decision: DecisionSettings = Field(default_factory=DecisionSettings)
    options: Options = Field(default_factory=dict, validate_default=True)
    """Settings of a plug-in estimator (its registered settings model); built-in estimators take none."""

    _options = options_of("estimators", "kind")


CONTROLLER_KINDS: dict[str, type[ControllerSettings]] = {
    "nmpc": NMPCSettings, "lmpc": LinearMPCSettings, "pf-nmpc": PathFollowingNMPCSettings,
    "robust-nmpc": RobustNMPCSettings, "open-loop": OpenLoopSettings}
"""The built-in controller kinds and their settings models (each declared beside its controller)."""


def _controller_tag(value: Any) -> str:
    """The union member of a ``[controller]`` table: its ``kind``'s model (``nmpc`` when not given), a plug-in's
    for any other name (checked against the registry there). Tags are not identifiers, so error messages name
    the field as the user wrote it (``controller.nodes``)."""
    kind = value.get("kind", "nmpc") if isinstance(value, dict) else getattr(value, "kind", None)
    return f"kind={kind}" if isinstance(kind, str) and kind in CONTROLLER_KINDS else "kind=plug-in"


def _is_default(model: type[ControllerSettings], key: str, value: Any) -> bool:
    """Whether ``value`` is ``model``'s default of its setting ``key`` (as validated by the field)."""
    f = model.model_fields[key]
    field_type = Annotated[(f.annotation, *f.metadata)] if f.metadata else f.annotation
    try:
        given = TypeAdapter(field_type).validate_python(value)
    except ValidationError:
        return False
    return bool(given == f.get_default(call_default_factory=True))


def _other_kinds_keys(value: Any) -> Any:
    """A ``[controller]`` table of a built-in kind holding a key of another kind only: a one-line error naming the
    key and the kinds that have it (``controller.nodes: not a setting of controller 'open-loop' …``). Such a key
    at that kind's default is dropped: a resolved config written when the section was one flat table (every
    kind's settings, the others' at their defaults) still reads as the run it was."""
    if not isinstance(value, dict):
        return value
    kind = value.get("kind", "nmpc")
    model = CONTROLLER_KINDS.get(kind) if isinstance(kind, str) else None
    out = dict(value)
    for key in value if model is not None else ():
        owners = [m for m in CONTROLLER_KINDS.values() if key in m.model_fields]
        if key in model.model_fields or not owners:
            continue
        if not _is_default(owners[0], key, value[key]):
            names = ", ".join(k for k, m in CONTROLLER_KINDS.items() if m in owners)
            raise ValueError(f"{key}: not a setting of controller {kind!r} (a setting of {names})")
        del out[key]
    return out


ControllerConfig = Annotated[
    Union[tuple(Annotated[m, Tag(f"kind={k}")] for k, m in  # noqa: UP007 - built from the table of kinds
                [*CONTROLLER_KINDS.items(), ("plug-in", PluginControllerSettings)])],
    Discriminator(_controller_tag), BeforeValidator(_other_kinds_keys)]
"""The trajectory-tracking controller (paper §3), discriminated by ``kind``: the built-in kinds' models
(:data:`CONTROLLER_KINDS`) or a plug-in's (its ``options``)."""


class ReconfigurationConfig(ReconfigurationSettings):
    """The ``[reconfiguration]`` section: the policy's settings
    (:class:`~ftc_mj.reconfiguration.policies.ReconfigurationSettings`), the excitation and the degraded mode."""

    excitation: ExcitationSettings = Field(default_factory=ExcitationSettings)
    degraded: DegradedSettings = Field(default_factory=DegradedSettings)


ReferenceConfig = ReferenceSettings
"""The reference path and its time law (:class:`~ftc_mj.control.reference.ReferenceSettings`)."""


class OutputConfig(StrictModel):
    dir: PathText = Path("runs/out")
    rrd: Flag = True
    progress: Flag = True

