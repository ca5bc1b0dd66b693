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
from ..estimation.calibration import tyre_change_offset
from ..estimation.diagnosis import (
    Diagnoser,
    NoDiagnoserSettings,
    ResidualDiagnoser,
    ResidualDiagnoserSettings,
)
from ..estimation.diagnosis.change import TyreChangeAlarm
from ..estimation.setup import FilterSetup
from ..registry import BUILTIN, diagnosers
from .decision import build_change_detectors, calibrated_threshold


def _none(settings: NoDiagnoserSettings, context: RunContext) -> None:
    """No diagnoser."""
    return None


diagnosers.register("residual", ResidualDiagnoser, origin=BUILTIN, section=ResidualDiagnoserSettings)
diagnosers.register("none", _none, origin=BUILTIN, section=NoDiagnoserSettings)


def build_diagnoser(cfg: RunConfig, setup: FilterSetup | None = None) -> Diagnoser | None:
    """The diagnoser ``cfg.diagnosis.kind`` names (``residual``: the built-in
    :class:`~ftc_mj.estimation.diagnosis.ResidualDiagnoser`, with its fast tyre detector when the run has a filter
    and ``diagnosis.tyre_change`` is on; ``none``: no diagnoser) or a plug-in's; ``setup``: the run's filter setup,
    if the caller has it (the run record's)."""
    builtin = diagnosers.get(cfg.diagnosis.kind).origin == BUILTIN
    extra = ({"change": tyre_change_alarm(cfg, setup)}
             if builtin and isinstance(cfg.diagnosis, ResidualDiagnoserSettings) else {})
    return diagnosers.create(cfg.diagnosis.kind, cfg.diagnosis, run_context(cfg), run_config=cfg, **extra)


def tyre_change_alarm(cfg: RunConfig, setup: FilterSetup | None = None) -> TyreChangeAlarm | None:
    """The built-in diagnoser's fast tyre detector (:mod:`~ftc_mj.estimation.diagnosis.change`): the run's change
    detectors and their calibrated CUSUM threshold plus its offset under the benchmark's drawn conditions
    (:func:`~ftc_mj.estimation.calibration.tyre_change_offset`); ``None`` without a filter (nothing to match a
    model to) or with ``diagnosis.tyre_change`` off."""
    if not cfg.diagnosis.tyre_change or cfg.estimator.kind == "none":
        return None
    threshold = calibrated_threshold(cfg, "cusum", setup) + tyre_change_offset(cfg.sensors.yaw_rate_sigma is not None)
    return TyreChangeAlarm(build_change_detectors(cfg, setup, glr=False), threshold)
