"""Diagnosis of every fault the library injects: which component, which mode, how large, since when.

:mod:`.base` holds what a diagnoser is handed and returns and the trace columns of its declarations and
alarms; :mod:`.residual` the built-in structured-residual diagnoser, :mod:`.history` its running sums,
:mod:`.shape` its bias/drift test, :mod:`.pose` its pose-sensor channel, :mod:`.servo` its servo load test,
:mod:`.settings` the ``[diagnosis]`` section's models. The vocabulary and the
:class:`~ftc_mj.model.diagnosis.Diagnosis` record are :mod:`ftc_mj.model.diagnosis`'s.
"""

from __future__ import annotations

from .base import (
    CHANNELS,
    DIAGNOSIS_COLUMNS,
    DIAGNOSIS_INTEGER_COLUMNS,
    Diagnoser,
    DiagnosisInput,
    DiagnosisStep,
    diagnoses_from_trace,
)
from .residual import ResidualDiagnoser
from .settings import (
    DIAGNOSER_KINDS,
    DiagnosisSettings,
    NoDiagnoserSettings,
    PluginDiagnoserSettings,
    ResidualDiagnoserSettings,
)

__all__ = ["CHANNELS", "DIAGNOSER_KINDS", "DIAGNOSIS_COLUMNS", "DIAGNOSIS_INTEGER_COLUMNS", "Diagnoser",
           "DiagnosisInput", "DiagnosisSettings", "DiagnosisStep", "NoDiagnoserSettings", "PluginDiagnoserSettings",
           "ResidualDiagnoser", "ResidualDiagnoserSettings", "diagnoses_from_trace"]
