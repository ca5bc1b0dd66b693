"""Bad values generated from the configuration schema: every leaf of :class:`RunConfig`, per type
(non-finite and out-of-range numbers, booleans for numbers, strings for booleans, …), as ``--set``
overrides and as scenario files. Judged in-process by ``tests/config/test_bad_values.py``; a
representative few also through the command line (``tests/cli/test_bad_input.py``)."""

from __future__ import annotations

import types
import typing
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from ftc_mj.config import RunConfig


def _base(ann: Any) -> Any:
    """The leaf type of an annotation: Optional and Annotated stripped (a union of several types keeps its
    members, each stripped)."""
    if typing.get_origin(ann) in (typing.Union, types.UnionType):
        members = [_base(a) for a in typing.get_args(ann) if a is not type(None)]
        return members[0] if len(members) == 1 else typing.Union[tuple(members)]  # noqa: UP007
    if typing.get_origin(ann) is typing.Annotated:
        ann = typing.get_args(ann)[0]
    return ann


def _members(ann: Any) -> list[type[BaseModel]]:
    """The settings models of a section discriminated by ``kind`` (a union of models), else ``[]``."""
    args = typing.get_args(ann) if typing.get_origin(ann) in (typing.Union, types.UnionType) else ()
    models = [_base(a) for a in args]
    return models if models and all(isinstance(m, type) and issubclass(m, BaseModel) for m in models) else []


def _walk(model: type[BaseModel] = RunConfig, prefix: str = "") -> list[tuple[str, Any, str | None]]:
    """``(dotted key, leaf type, kind)`` of every settable config value; ``kind``: the ``kind`` a section
    discriminated by kind must be given for the key to exist (``None``: the default kind has it)."""
    out = []
    for name, f in model.model_fields.items():
        t = _base(f.annotation)
        key = f"{prefix}{name}"
        members = _members(f.annotation)
        if members:
            default = type(f.get_default(call_default_factory=True))
            seen: dict[str, tuple[Any, str | None]] = {}
            for m in [default, *(m for m in members if m is not default)]:
                own = m.model_fields["kind"].default if m is not default else None
                for k, lt, _ in _walk(m, key + "."):
                    plugin_only = own is PydanticUndefined  # a plug-in's `options`: a built-in refuses it by name
                    seen.setdefault(k, (lt, None if plugin_only else own))
            out += [(k, lt, kind) for k, (lt, kind) in seen.items()]
        elif isinstance(t, type) and issubclass(t, BaseModel):
            out += _walk(t, key + ".")
        else:
            out.append((key, t, None))
    return out


def leaves(model: type[BaseModel] = RunConfig, prefix: str = "") -> list[tuple[str, Any]]:
    """``(dotted key, leaf type)`` of every settable config value (every kind's, for a section discriminated
    by ``kind``)."""
    return [(k, t) for k, t, _ in _walk(model, prefix)]


def _inline(parts: list[str], value: str) -> str:
    """``a = { b = value }`` for ``parts`` ``["a", "b"]``: a TOML inline table holding ``value``."""
    return f"{parts[0]} = {value}" if len(parts) == 1 else f"{parts[0]} = {{ {_inline(parts[1:], value)} }}"


def _set_item(key: str, value: str, kind: str | None) -> str:
    """The ``--set`` of ``key = value``; for a key of a kind other than the section's default, the whole section
    as an inline table naming that kind."""
    if kind is None:
        return f"{key}={value}"
    sec, *rest = key.split(".")
    return f'{sec}={{ kind = "{kind}", {_inline(rest, value)} }}'


def _file_body(key: str, value: str, kind: str | None) -> str:
    """A scenario file setting ``key = value`` (and the section's ``kind`` when the key belongs to another)."""
    *sec, leaf = key.split(".")
    head = f'[{sec[0]}]\nkind = "{kind}"\n' if kind is not None else ""
    if kind is not None and len(sec) == 1:
        return head + f"{leaf} = {value}\n"
    return head + (f"[{'.'.join(sec)}]\n" if sec else "") + f"{leaf} = {value}\n"


def kind_of(t: Any) -> str:
    """The kind of a leaf type, the key of :data:`BAD_VALUES`."""
    origin = typing.get_origin(t)
    if origin is typing.Union and {typing.get_origin(a) or a for a in typing.get_args(t)} == {Literal, bool}:
        return "literal_or_bool"  # e.g. "auto" | true | false
    if origin is Literal:
        return "literal"
    if origin is tuple:
        return "tuple"
    if origin is list:
        return "list"
    if t is bool:
        return "bool"
    if t is int:
        return "int"
    if t is float:
        return "float"
    if t is str:
        return "str"
    if origin is dict:
        return "dict"
    if isinstance(t, type) and issubclass(t, Path):
        return "path"
    raise AssertionError(f"untested config type {t!r}")


BAD_VALUES: dict[str, list[str]] = {
    "float": ["inf", "-inf", "nan", "1e308", "true", '"abc"'],
    "int": ["1.5", "true", '"3"', "1e308"],
    "bool": ['"yes"', "1", "0.0"],
    "literal": ['"bogus"', "3", "true"],
    "literal_or_bool": ['"bogus"', "3", '"yes"', "0.0"],
    "tuple": ["[1.0]", '"x"', "[inf, inf, inf, inf, inf]", "[true, true, true, true, true]"],
    "list": ["3", "[[1.0]]", '[["a", 1.0]]', "[[inf, 1.0]]"],
    "path": ['""', "true", '"no/such/file.xml"'],
    "str": ["1", "true"],
    "dict": ["3", '"x"', "{ a = 1 }"],
}
"""TOML literals that no leaf of each kind may accept."""


def schema_cases() -> list[tuple[str, str, str]]:
    """``(case id, "key=value" of a --set, the key the error must name)`` for every leaf and bad value."""
    cases = []
    for key, t, ctx in _walk():
        kind = kind_of(t)
        values = list(BAD_VALUES[kind])
        if key == "output.dir":
            values = ['""', "true"]  # any non-empty path is a folder name
        if key == "description":
            values = ["1", "true", '"' + "d" * 2001 + '"']
        if key.endswith((".kind", ".rule", ".policy")) and kind == "str":
            values.append('"bogus"')  # a component name no registry knows
        if key == "plugins":
            values += ['["no_such_module_xyz"]', '["1bad"]']
        if key == "name":
            values = ['"../../../x"', '"/abs/x"', '".hidden"', '"a/b"', '""', '"' + "n" * 101 + '"', "1",
                      '"a\\u0000b"']
        for v in values:
            cases.append((f"set:{key}={v[:30]}", _set_item(key, v, ctx), key))
    return cases


def file_cases() -> list[tuple[str, str, str]]:
    """``(case id, scenario file body, the key the error must name)``: the same values through a
    scenario file (a table per section), two per leaf."""
    out = []
    for key, t, ctx in _walk():
        kind = kind_of(t)
        values = BAD_VALUES[kind][:2] if key not in ("output.dir", "name", "description") else ["true"]
        for v in values:
            out.append((f"file:{key}={v[:20]}", _file_body(key, v, ctx), key))
    return out
