"""Which run an episode of :class:`~ftc_mj.envs.DiffDriveEnv` is: the run config from ``reset``'s options.

- ``{"split": "dev"|"test", "index": i}`` (and optionally ``"version"``, default ``ftc-v2``): the benchmark
  draw ``ftc_mj.benchmark.draws.draw(split, i, version)`` (its scenario, including its sensor-noise seed:
  a draw is the same run for every method);
- ``{"scenario": NAME_OR_PATH}``: a built-in scenario or a scenario TOML file, as ``ftc-mj run`` reads it;
- no options: the environment's own scenario.

``{"overrides": {...}}`` (dotted keys as ``--set``) applies on top of either, after the environment's
own overrides. ``reset``'s ``seed`` is the run's sensor-noise seed for a scenario (as ``--seed``); a draw
keeps its own.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

from ..benchmark.definition import CURRENT_VERSION, SPLITS
from ..benchmark.draws import MAX_INDEX, Draw, draw
from ..config import RunConfig, load_config, set_dotted, validate_config
from ..errors import BadInput

OPTION_KEYS = frozenset({"split", "index", "version", "scenario", "overrides"})
DEFAULT_VERSION = CURRENT_VERSION
"""The benchmark version of a draw when the options name none."""


def episode_config(scenario: str, overrides: Mapping[str, Any], options: Mapping[str, Any] | None,
                   seed: int | None) -> tuple[RunConfig, Draw | None]:
    """The resolved run config of an episode (module docstring) and its benchmark draw (``None`` for a
    scenario); :class:`BadInput` naming the option."""
    opts = dict(options or {})
    unknown = sorted(set(opts) - OPTION_KEYS)
    if unknown:
        raise BadInput(f"options.{unknown[0]}: not an option (options: {', '.join(sorted(OPTION_KEYS))})")
    extra = opts.get("overrides") or {}
    if not isinstance(extra, Mapping):
        raise BadInput(f"options.overrides: expected a table of dotted keys, got {type(extra).__name__}")
    merged = {**overrides, **extra}
    if "split" in opts or "index" in opts or "version" in opts:
        if "scenario" in opts:
            raise BadInput("options.scenario: give either a scenario or a benchmark draw (split, index)")
        d = benchmark_draw(opts.get("split"), opts.get("index"), opts.get("version", DEFAULT_VERSION))
        return _apply(d.scenario(), merged), d
    if seed is not None:
        merged = {**merged, "seed": int(seed)}
    return load_config(str(opts.get("scenario", scenario)), merged), None


def benchmark_draw(split: Any, index: Any, version: Any = DEFAULT_VERSION) -> Draw:
    """The benchmark draw ``(split, index)`` of benchmark ``version``."""
    if split not in SPLITS:
        raise BadInput(f"options.split: must be one of {', '.join(SPLITS)}, got {split!r}")
    if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < MAX_INDEX:
        raise BadInput(f"options.index: must be an integer in [0, {MAX_INDEX}), got {index!r}")
    if not isinstance(version, str):
        raise BadInput(f"options.version: must be a benchmark version's name, got {version!r}")
    return draw(split, index, version)


def _apply(data: Mapping[str, Any], overrides: Mapping[str, Any]) -> RunConfig:
    """``data`` (a scenario table) with dotted ``overrides``, validated."""
    table = copy.deepcopy(dict(data))
    for key, value in overrides.items():
        set_dotted(table, key, value)
    return validate_config(table)
