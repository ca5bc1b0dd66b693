"""Which run an episode of :class:`~ftc_mj.envs.DiffDriveEnv` is: the run config from ``reset``'s options.

- ``{"split": "dev"|"test", "index": i}``: the benchmark draw ``ftc_mj.benchmark.draws.draw(split, i)``
  (its scenario, including its sensor-noise seed: a draw is the same run for every method);
- ``{"scenario": NAME_OR_PATH}``: a built-in scenario or a scenario TOML file, as ``ftc-mj run`` reads it;
- no options: the environment's own scenario.

``{"overrides": {...}}`` (dotted keys as ``--set``) applies on top of either, after the environment's
own overrides. ``reset``'s ``seed`` is the run's sensor-noise seed for a scenario (as ``--seed``); a draw
keeps its own.
"""

from __future__ import annotations

import copy
import importlib
from collections.abc import Mapping
from typing import Any

from ..config import RunConfig, load_config, set_dotted, validate_config
from ..errors import BadInput

OPTION_KEYS = frozenset({"split", "index", "scenario", "overrides"})
SPLITS = ("dev", "test")


def episode_config(scenario: str, overrides: Mapping[str, Any], options: Mapping[str, Any] | None,
                   seed: int | None) -> RunConfig:
    """The resolved run config of an episode (module docstring); :class:`BadInput` naming the option."""
    opts = dict(options or {})
    unknown = sorted(set(opts) - OPTION_KEYS)
    if unknown:
        raise BadInput(f"options.{unknown[0]}: not an option (options: {', '.join(sorted(OPTION_KEYS))})")
    extra = opts.get("overrides") or {}
    if not isinstance(extra, Mapping):
        raise BadInput(f"options.overrides: expected a table of dotted keys, got {type(extra).__name__}")
    merged = {**overrides, **extra}
    if "split" in opts or "index" in opts:
        if "scenario" in opts:
            raise BadInput("options.scenario: give either a scenario or a benchmark draw (split, index)")
        return _apply(draw_scenario(opts.get("split"), opts.get("index")), merged)
    if seed is not None:
        merged = {**merged, "seed": int(seed)}
    return load_config(str(opts.get("scenario", scenario)), merged)


def draw_scenario(split: Any, index: Any) -> dict[str, Any]:
    """The scenario table of the benchmark draw ``(split, index)``."""
    if split not in SPLITS:
        raise BadInput(f"options.split: must be one of {', '.join(SPLITS)}, got {split!r}")
    if isinstance(index, bool) or not isinstance(index, int) or index < 0:
        raise BadInput(f"options.index: must be an integer ≥ 0, got {index!r}")
    try:
        draws = importlib.import_module("ftc_mj.benchmark.draws")
    except ModuleNotFoundError:
        raise BadInput("options.split: this installation has no benchmark draws (ftc_mj.benchmark.draws); "
                       "use options={'scenario': NAME}") from None
    return draws.draw(split, index).scenario()


def _apply(data: Mapping[str, Any], overrides: Mapping[str, Any]) -> RunConfig:
    """``data`` (a scenario table) with dotted ``overrides``, validated."""
    table = copy.deepcopy(dict(data))
    for key, value in overrides.items():
        set_dotted(table, key, value)
    return validate_config(table)
