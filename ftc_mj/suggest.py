""""Did you mean": the closest known name to one the user mistyped (a scenario, a study, a component,
a config key), and for an unknown config key the key it most likely stands for — a close spelling
at the same level, or the same key at another level of the config (``decision.rule`` →
``estimator.decision.rule``).

Only the standard library (:mod:`difflib`); the config schema is passed in as a pydantic model, so
this module imports nothing of the package.
"""

from __future__ import annotations

import difflib
import types
import typing
from collections.abc import Iterable
from typing import Any

CUTOFF = 0.6
"""Least :class:`difflib.SequenceMatcher` ratio of a suggestion (difflib's default)."""


def close_match(word: str, candidates: Iterable[str]) -> str | None:
    """The candidate closest to ``word`` (ratio at least :data:`CUTOFF`), or ``None``."""
    found = difflib.get_close_matches(str(word), list(candidates), n=1, cutoff=CUTOFF)
    return found[0] if found else None


def did_you_mean(word: str, candidates: Iterable[str]) -> str:
    """``" (did you mean 'x'?)"`` for the closest candidate, ``""`` if none is close."""
    match = close_match(word, candidates)
    return f" (did you mean {match!r}?)" if match else ""


def submodels(annotation: Any) -> list[type]:
    """The pydantic models a field annotation holds (through ``Annotated`` and ``X | None``; every member of a
    union of models, as a section discriminated by ``kind``), else ``[]``."""
    if typing.get_origin(annotation) is typing.Annotated:
        annotation = typing.get_args(annotation)[0]
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        return [m for a in typing.get_args(annotation) for m in submodels(a)]
    return [annotation] if isinstance(annotation, type) and hasattr(annotation, "model_fields") else []


def section_fields(models: list[type]) -> dict[str, Any]:
    """The fields of ``models`` (a section's union members) by name, the first model's declaration of each."""
    out: dict[str, Any] = {}
    for m in models:
        for name, field in m.model_fields.items():  # type: ignore[attr-defined]
            out.setdefault(name, field)
    return out


def config_keys(model: type, prefix: str = "") -> list[str]:
    """Every dotted key of the pydantic ``model``: its tables and its values (``estimator``,
    ``estimator.decision``, ``estimator.decision.rule``, …; a section discriminated by ``kind``: every kind's)."""
    return _keys([model], prefix)


def _keys(models: list[type], prefix: str) -> list[str]:
    out = []
    for name, field in section_fields(models).items():
        key = f"{prefix}{name}"
        out.append(key)
        subs = submodels(field.annotation)
        if subs:
            out.extend(_keys(subs, key + "."))
    return out


def _fields_at(model: type, parts: list[str]) -> list[str]:
    """The field names of the table ``parts`` of ``model`` (``[]`` if it is not a table)."""
    models = [model]
    for part in parts:
        field = section_fields(models).get(part)
        models = submodels(field.annotation) if field is not None else []
        if not models:
            return []
    return list(section_fields(models))


def first_leaf(value: Any) -> list[str]:
    """The key path of the first value inside a (nested) table the user wrote, ``[]`` for a value."""
    if isinstance(value, dict) and value:
        key = next(iter(value))
        return [str(key), *first_leaf(value[key])]
    return []


def suggest_key(model: type, parts: list[str], unknown: int) -> str | None:
    """The config key the user most likely meant by the dotted key ``parts``, whose part ``unknown``
    is not in ``model``'s schema: the one key ending in the user's whole key (a key at the wrong
    level), else a close spelling of the unknown part at its level (its subkeys kept), else the
    closest key overall; ``None`` if nothing is close."""
    keys = config_keys(model)
    user = ".".join(parts)
    tail = ".".join(parts[unknown:])
    for suffix in (user, tail):
        ends = [k for k in keys if k.endswith("." + suffix)]
        if len(ends) == 1:
            return ends[0]
    near = close_match(parts[unknown], _fields_at(model, parts[:unknown]))
    if near is not None:
        return ".".join([*parts[:unknown], near, *parts[unknown + 1:]])
    return close_match(user, keys)
