"""Run configuration: a pydantic schema loaded from TOML, with the paper's values as defaults.

Everything a run depends on is in :class:`RunConfig`; a run is a pure function of the resolved
config (including ``seed``). SI units and radians throughout; the only degree-valued inputs are
fields whose name ends in ``_deg``.

Loading goes through :func:`load_config`, which accepts a built-in scenario name (``scenario1`` …
``scenario4``) or a TOML path, applies ``--set dotted.key=value`` overrides, validates, and raises
:class:`~ftc_mj.errors.BadInput` with a one-line message naming the offending field.

Modules: :mod:`.sections` (one model per section), :mod:`.schema` (:class:`RunConfig`,
:func:`run_context`), :mod:`.files` (scenario names, TOML files), :mod:`.load` (overrides, validation,
sections on their own). The value types and the strict base of every settings model live below the
components, in :mod:`ftc_mj.fields`; the one-line text of a validation error in :mod:`ftc_mj.validation`.
Only the wiring (:mod:`ftc_mj.wiring`) and the layers above it import this package.
"""

from ..fields import (
    DEFAULT_MODEL_FILE,
    FLOAT_BOUND,
    NAME_RE,
    OMEGA_MAX,
    FiniteFloat,
    Flag,
    Fraction,
    NonNegFloat,
    PosFloat,
    SafeName,
    ranged,
    ranged_int,
)
from ..model.sensors import SensorSettings
from ..validation import one_line, shown_value
from .files import BUILTIN_SCENARIOS, MAX_TOML_BYTES, existing_file, parse_toml, read_toml, scenario_path
from .load import (
    config_to_toml_dict,
    from_sections,
    load_config,
    parse_override,
    section,
    set_dotted,
    validate_config,
)
from .schema import RunConfig, run_context
from .sections import (
    ControllerConfig,
    DiagnosisConfig,
    EstimatorConfig,
    FaultSettings,
    ModelSettings,
    OutputConfig,
    PlantSettings,
    ReconfigurationConfig,
    RobotSettings,
)

__all__ = [
    "BUILTIN_SCENARIOS", "DEFAULT_MODEL_FILE", "FLOAT_BOUND", "MAX_TOML_BYTES", "NAME_RE", "OMEGA_MAX",
    "ControllerConfig", "DiagnosisConfig", "EstimatorConfig", "FaultSettings",
    "FiniteFloat",
    "Flag", "Fraction", "ModelSettings", "NonNegFloat", "OutputConfig",
    "PlantSettings", "PosFloat", "ReconfigurationConfig", "RobotSettings",
    "RunConfig", "SafeName", "SensorSettings", "config_to_toml_dict", "existing_file", "from_sections",
    "load_config", "one_line", "parse_override", "parse_toml", "ranged", "ranged_int", "read_toml",
    "run_context", "scenario_path", "section", "set_dotted", "shown_value", "validate_config",
]
