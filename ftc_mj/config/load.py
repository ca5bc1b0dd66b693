"""Loading a run config: a scenario (built-in name or TOML path), ``--set dotted.key=value``
overrides, validation into a :class:`~ftc_mj.config.schema.RunConfig` with a one-line
:class:`~ftc_mj.errors.BadInput` naming the field, single sections for components built on their
own, and the resolved config as TOML data.
"""

from __future__ import annotations

import tomllib
import types
import typing
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from ..errors import BadInput
from ..fields import NAME_RE
from ..suggest import first_leaf, suggest_key
from ..validation import one_line, section
from .files import read_toml, scenario_path
from .schema import RunConfig


def validate_config(data: dict[str, Any]) -> RunConfig:
    """Validate a raw dict into a :class:`RunConfig`; :class:`BadInput` names the field."""
    try:
        return RunConfig.model_validate(data)
    except ValidationError as err:
        raise BadInput(one_line(err) + unknown_key_hint(err)) from None
    except RecursionError:
        raise BadInput("config: values nested too deeply") from None


def unknown_key_hint(err: ValidationError) -> str:
    """``"; did you mean estimator.decision.rule?"`` when the first error of ``err`` is a key the run config
    does not have and a close or a wrong-level key exists, else ``""``."""
    e = err.errors()[0]
    loc = [p for p in e["loc"] if isinstance(p, str)]
    if e["type"] != "extra_forbidden" or len(loc) != len(e["loc"]):
        return ""
    loc = [p for i, p in enumerate(loc) if p.isidentifier() or i == len(loc) - 1]  # union tags left out
    parts = [*loc, *first_leaf(e.get("input"))]
    key = suggest_key(RunConfig, parts, len(loc) - 1)
    return f"; did you mean {key}?" if key else ""


def _is_section(annotation: Any) -> bool:
    """Whether a :class:`RunConfig` field holds a section: a settings model, or a union of settings models
    discriminated by ``kind`` (each member ``Annotated`` with its tag)."""
    if isinstance(annotation, type):
        return issubclass(annotation, BaseModel)
    if typing.get_origin(annotation) is typing.Annotated:
        return _is_section(typing.get_args(annotation)[0])
    members = typing.get_args(annotation) if typing.get_origin(annotation) in (typing.Union, types.UnionType) else ()
    return bool(members) and all(_is_section(m) for m in members)


def from_sections(**sections: Any) -> RunConfig:
    """A run config holding the given sections (instances, plain tables or ``None``; the rest the
    defaults), for a component built from its own settings: ``from_sections(plant={"kind":
    "kinematic"}, robot=None)``. :class:`BadInput` naming ``<section>.<field>``."""
    models = {name: typing.Annotated[(f.annotation, *f.metadata)] if f.metadata else f.annotation
              for name, f in RunConfig.model_fields.items() if _is_section(f.annotation)}
    data = {}
    for name, value in sections.items():
        if name not in models:
            raise BadInput(f"{name}: not a config section (sections: {', '.join(models)})")
        data[name] = section(models[name], value, name)
    return RunConfig.model_validate(data)



def parse_override(item: str) -> tuple[str, Any]:
    """Parse ``dotted.key=value``; the value is read as a TOML value, else taken as a string."""
    if "=" not in item:
        raise BadInput(f"--set {item}: expected dotted.key=value")
    key, raw = item.split("=", 1)
    key = key.strip()
    if not key or any(not part for part in key.split(".")):
        raise BadInput(f"--set {item}: empty key")
    if "\n" in raw or "\r" in raw or "\0" in raw:
        raise BadInput(f"--set {key}: the value must be one line of text without NUL bytes")
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    except RecursionError:
        raise BadInput(f"--set {key}: value nested too deeply") from None
    return key, value


def set_dotted(data: dict[str, Any], key: str, value: Any) -> None:
    """Set ``data[a][b][c] = value`` for ``key = "a.b.c"``, creating tables as needed."""
    parts = key.split(".")
    node = data
    for part in parts[:-1]:
        nxt = node.setdefault(part, {})
        if not isinstance(nxt, dict):
            raise BadInput(f"{key}: {part} is not a table")
        node = nxt
    node[parts[-1]] = value


def load_config(scenario: str | Path, overrides: Mapping[str, Any] | None = None, *,
                plugins: Iterable[str] = ()) -> RunConfig:
    """Load a scenario (built-in name or TOML path), apply dotted overrides, add the plug-in modules
    ``plugins`` to its ``plugins`` list (``--plugin``), validate."""
    path = scenario_path(scenario)
    data = read_toml(path, "scenario")
    if "name" not in data:
        if not NAME_RE.match(path.stem):
            raise BadInput(f"name: the scenario file's stem {path.stem[:40]!r} is not a plain file name "
                           "(letters, digits, '_', '-', '.', '+'); set name = \"...\" in the file")
        data["name"] = path.stem
    for key, value in (overrides or {}).items():
        set_dotted(data, key, value)
    extra = list(plugins)
    if extra:
        given = data.get("plugins", [])
        data["plugins"] = list(dict.fromkeys([*(given if isinstance(given, list) else [given]), *extra]))
    return validate_config(data)


def config_to_toml_dict(cfg: RunConfig) -> dict[str, Any]:
    """The fully resolved config as plain TOML-serialisable data (None values dropped)."""
    def clean(v: Any) -> Any:
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items() if x is not None}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        if isinstance(v, Path):
            return str(v)
        return v

    return clean(cfg.model_dump(mode="python"))
