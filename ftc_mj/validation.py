"""The one-line text of a pydantic validation error: ``<dotted.field>: why[, got <value>]``.

The one home of this formatting: the run config (:mod:`ftc_mj.config.load`), the plug-in
``options`` tables (:func:`ftc_mj.fields.options_of`), the study files (:mod:`ftc_mj.study.spec`)
and the components built from plain tables without a run config (:func:`section`) all use
:func:`one_line`, so every bad input reads the same.
"""

from __future__ import annotations

import re
from typing import Any

from pydantic import BaseModel, TypeAdapter, ValidationError

from .errors import BadInput


def field_path(loc: tuple[Any, ...], unknown_key: bool = False, item: bool = False) -> str:
    """A pydantic error location as the dotted field the user wrote: ``axes[0].values``,
    ``estimator.p0_sigma``. An item's index is shown when a field of that item follows (or, with
    ``item``, when the item's own check names the field); a trailing index (a number inside a tuple
    or list) is left out, the field named. Union member tags (``constrained-int``, ``list[...]``)
    are left out; with ``unknown_key`` the last part is the user's key, kept whatever its spelling."""
    parts = list(loc)
    while parts and isinstance(parts[-1], int) and not item:
        parts.pop()
    out = ""
    for i, p in enumerate(parts):
        if isinstance(p, int):
            out += f"[{p}]"
        elif str(p).isidentifier() or (unknown_key and i == len(parts) - 1):
            out += ("." if out else "") + str(p)
    return out or "<root>"


def shown_value(v: Any, width: int = 40) -> str:
    """A value as the user wrote it in TOML (``true``, ``"yes"``, ``[1, 2]``), cut to ``width`` characters."""
    if isinstance(v, bool):
        text = "true" if v else "false"
    elif isinstance(v, str):
        text = '"' + v.encode("unicode_escape").decode() + '"'
    else:
        text = repr(v)
    return text if len(text) <= width else text[: width - 1] + "…"


_NAMED = re.compile(r"^([A-Za-z_][\w.\[\]]*): (.*)$")
"""A check that names its field itself: ``imm_bank: hypothesis names must differ``."""


def one_line(err: ValidationError) -> str:
    """The first error of ``err`` as ``<field>: why``: the value shown for type and range errors
    (``, got "yes"``), ``unknown key`` for a key the schema does not have, a check's own field name
    appended to its location, and ``(and N more)`` when there are further errors."""
    e = err.errors()[0]
    msg = "unknown key" if e["type"] == "extra_forbidden" else e["msg"].removeprefix("Value error, ")
    named = _NAMED.match(msg) if e["type"] == "value_error" else None
    loc = field_path(tuple(e["loc"]), unknown_key=e["type"] == "extra_forbidden", item=named is not None)
    if e["type"] not in ("value_error", "extra_forbidden", "missing") and "input" in e:
        msg += f", got {shown_value(e['input'])}"
    extra = f" (and {err.error_count() - 1} more)" if err.error_count() > 1 else ""
    if loc == "<root>" and ": " in msg:  # model-level checks name their field themselves
        return f"{msg}{extra}"
    if named:  # a section's check naming its field: estimator.imm_models
        return f"{loc}.{named.group(1)}: {named.group(2)}{extra}"
    return f"{loc}: {msg}{extra}"


def section(model: Any, value: Any, where: str) -> Any:
    """A settings model from an instance of ``model`` (a settings model or a section's union of them,
    discriminated by ``kind``), a plain table or ``None`` (the defaults), for components built without a run
    config; :class:`~ftc_mj.errors.BadInput` naming ``<where>.<field>``."""
    if isinstance(value, model if isinstance(model, type) else BaseModel):
        return value
    try:
        return TypeAdapter(model).validate_python({} if value is None else dict(value))
    except ValidationError as err:
        line = one_line(err)
        raise BadInput(f"{where}: {line.removeprefix('<root>: ')}" if line.startswith("<root>")
                       else f"{where}.{line}") from None
    except TypeError:
        raise BadInput(f"{where}: expected a table of settings, got {type(value).__name__}") from None
