"""The built-in diagnosers, registered by name (:data:`ftc_mj.registry.diagnosers`), and the diagnoser of a run
from the application config.

A registered factory takes the ``[diagnosis]`` section (the model of its ``kind``:
:data:`~ftc_mj.estimation.diagnosis.DIAGNOSER_KINDS`, or a plug-in's
:class:`~ftc_mj.estimation.diagnosis.PluginDiagnoserSettings`) and the :class:`~ftc_mj.context.RunContext`, and
returns a :class:`~ftc_mj.estimation.diagnosis.Diagnoser` (``None`` for ``none``). A plug-in registered under
``residual`` with ``replace=True`` replaces the built-in one.
"""

from __future__ import annotations

from ..config import RunConfig, run_context
from ..context import RunContext
from ..estimation.diagnosis import (
    Diagnoser,
    NoDiagnoserSettings,
    ResidualDiagnoser,
    ResidualDiagnoserSettings,
)
from ..registry import BUILTIN, diagnosers


def _none(settings: NoDiagnoserSettings, context: RunContext) -> None:
    """No diagnoser."""
    return None


diagnosers.register("residual", ResidualDiagnoser, origin=BUILTIN, section=ResidualDiagnoserSettings)
diagnosers.register("none", _none, origin=BUILTIN, section=NoDiagnoserSettings)


def build_diagnoser(cfg: RunConfig) -> Diagnoser | None:
    """The diagnoser ``cfg.diagnosis.kind`` names (``residual``: the built-in
    :class:`~ftc_mj.estimation.diagnosis.ResidualDiagnoser`; ``none``: no diagnoser) or a plug-in's."""
    return diagnosers.create(cfg.diagnosis.kind, cfg.diagnosis, run_context(cfg), run_config=cfg)
