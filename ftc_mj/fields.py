"""The value types of the config schema: ranged floats and integers with units, names, paths, component
names checked against the registries, plug-in ``options`` tables, and the strict model base.

Every float without a tighter physical range is bounded by :data:`FLOAT_BOUND`; SI units and
radians throughout (the only degree-valued fields end in ``_deg``).
"""

from __future__ import annotations

import ast
import inspect
import math
import re
import textwrap
from pathlib import Path
from types import UnionType
from typing import Annotated, Any, Literal, Union, get_args, get_origin

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    Strict,
    ValidationError,
    field_validator,
)

from . import registry, resources
from .validation import one_line

DEFAULT_MODEL_FILE = resources.DEFAULT_MODEL
"""``plant.model_file`` default: the robot shipped in the package (``builtin:diffdrive.xml``)."""

OMEGA_MAX = math.radians(1000.0)  # rad/s, the paper's wheel-rate limit (±1000 deg/s)

FLOAT_BOUND = 1.0e6
"""Magnitude bound of every config float without a tighter physical range: finite numbers beyond it
(1e15 s, 1e308 kg) are typing slips, not experiments, and overflow the physics or the allocations."""


def _interval(lo: float, hi: float, lo_open: bool, hi_open: bool) -> str:
    """The interval as written in messages: ``(0, 3600]``."""
    return f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"


def ranged(lo: float, hi: float, *, lo_open: bool = False, hi_open: bool = False, unit: str = "") -> Any:
    """A strict float type: a finite number (an integer is accepted, a boolean or string is not) in
    the interval from ``lo`` to ``hi`` (open ends as flagged); the error names the interval and unit."""
    where = _interval(lo, hi, lo_open, hi_open) + (f" {unit}" if unit else "")

    def check(v: float) -> float:
        inside = (v > lo if lo_open else v >= lo) and (v < hi if hi_open else v <= hi)
        if not (math.isfinite(v) and inside):
            raise ValueError(f"must be a finite number in {where}, got {v!r}")
        return v

    check.interval = where  # type: ignore[attr-defined]  # read by describe_settings
    return Annotated[float, Strict(), AfterValidator(check)]


def _plain_int(v: Any) -> Any:
    """A numpy integer as a Python int (callers computing seeds or sizes with numpy); anything else as is."""
    return int(v) if hasattr(v, "dtype") and getattr(v.dtype, "kind", "") in "iu" and v.shape == () else v


def ranged_int(lo: int, hi: int) -> Any:
    """A strict integer type in ``[lo, hi]`` (a float or boolean is not an integer; a numpy integer is)."""
    return Annotated[int, BeforeValidator(_plain_int), Strict(), Field(ge=lo, le=hi)]


PosFloat = ranged(0.0, FLOAT_BOUND, lo_open=True)
"""A finite float in (0, 1e6]."""
NonNegFloat = ranged(0.0, FLOAT_BOUND)
"""A finite float in [0, 1e6]."""
FiniteFloat = ranged(-FLOAT_BOUND, FLOAT_BOUND)
"""A finite float in [-1e6, 1e6]."""
Fraction = ranged(0.0, 1.0, lo_open=True, hi_open=True)
"""A finite float in (0, 1)."""
Flag = Annotated[bool, Strict()]
"""``true`` or ``false`` only (not 1, "yes")."""
Rate = ranged(0.0, 1.0e4, lo_open=True, unit="Hz")
Length = ranged(1.0e-3, 100.0, unit="m")
"""A robot dimension (m)."""
AngleDeg = ranged(0.0, 180.0, lo_open=True, unit="deg")

NAME_RE = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.+-]{0,99}$")
"""A run or study name: one safe file-name component (it names the output folder)."""


def check_name(v: str) -> str:
    """``v`` if it is a plain file-name component (see :data:`NAME_RE`), else ``ValueError``."""
    if not NAME_RE.match(v):
        shown = v[:40].encode("unicode_escape").decode() + ("…" if len(v) > 40 else "")
        raise ValueError("must be a plain file name: letters, digits, '_', '-', '.', '+', starting with a "
                         f"letter, digit or '_', at most 100 characters (got '{shown}')")
    return v


SafeName = Annotated[str, Strict(), AfterValidator(check_name)]


def _path_text(v: Any) -> Any:
    """Reject an empty path or one with a NUL byte before it becomes a ``Path`` (``Path("")`` is ``.``)."""
    if isinstance(v, str) and (not v.strip() or "\0" in v):
        raise ValueError("must be a non-empty path without NUL bytes")
    return v


PathText = Annotated[Path, BeforeValidator(_path_text)]


def component(name: str) -> Any:
    """A strict string type naming a component registered in :data:`ftc_mj.registry.REGISTRIES` ``[name]``;
    the error of an unknown name lists the registered ones."""
    def check(v: str) -> str:
        return registry.REGISTRIES[name].check(v)

    check.interval = f"a registered {registry.REGISTRIES[name].kind}"  # type: ignore[attr-defined]
    return Annotated[str, Strict(), AfterValidator(check)]


Options = Annotated[dict[str, Any], Strict(), Field(max_length=100)]
"""A component's own settings (a TOML table), checked against the ``settings`` model the component was
registered with (:func:`ftc_mj.registry.check_options`); built-ins take none."""


def options_of(registry_name: str, kind_field: str) -> Any:
    """A field validator of ``options``: validated for the component named in ``kind_field`` (fields are
    validated in order, so the name is known), returned with the settings' defaults filled in."""
    def check(cls: type, v: dict[str, Any], info: Any) -> dict[str, Any]:
        kind = info.data.get(kind_field)
        if kind is None:
            return v
        try:
            return registry.check_options(registry.REGISTRIES[registry_name], kind, v)
        except ValidationError as err:  # a ValueError too: caught here before pydantic quotes it whole
            raise ValueError(one_line(err).removeprefix("<root>: ")) from None

    return field_validator("options")(classmethod(check))  # type: ignore[arg-type]


def drop_empty_options(model: type[BaseModel], data: Any, what: str) -> Any:
    """``data`` (a table for ``model``, a built-in ``what`` kind's settings) without plug-in ``options``: an
    empty table is dropped (an older resolved config wrote one for every kind), any other is an error naming
    ``options``; a model with an ``options`` field (a plug-in's) keeps it."""
    if not isinstance(data, dict) or "options" not in data or "options" in model.model_fields:
        return data
    data = dict(data)
    opts = data.pop("options")
    if opts != {}:
        kind = data.get("kind", model.model_fields["kind"].default if "kind" in model.model_fields else "?")
        got = ", ".join(map(str, opts)) if isinstance(opts, dict) else repr(opts)
        raise ValueError(f"options: {what} {kind!r} takes no options (got {got})")
    return data


class StrictModel(BaseModel):
    """Base: unknown keys are errors, assignments are validated."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True)



def _type_text(annotation: Any, metadata: list[Any]) -> str:
    """A settings field's type as a reader wants it: ``float in (0, 1e+06]``, ``"a" | "b"``, ``bool``,
    ``tuple[float in [0, 1e+06], …]``, ``… | none``."""
    for m in metadata:
        interval = getattr(getattr(m, "func", None), "interval", None)
        if interval is not None:
            return interval if interval.startswith("a registered") else f"float in {interval}"
    bounds = [f"{type(m).__name__.lower()} {getattr(m, type(m).__name__.lower())}" for m in metadata
              if type(m).__name__ in ("Ge", "Le")]
    origin, args = get_origin(annotation), get_args(annotation)
    if origin is Annotated:
        return _type_text(args[0], [*args[1:], *metadata])
    if origin is Literal:
        return " | ".join(repr(a) if isinstance(a, str) else str(a) for a in args)
    if origin in (Union, UnionType):
        return " | ".join("none" if a is type(None) else _type_text(a, []) for a in args)
    if origin in (tuple, list):
        items = [_type_text(a, []) for a in args if a is not Ellipsis]
        inner = f"{len(items)} × {items[0]}" if len(items) > 2 and len(set(items)) == 1 else ", ".join(items)
        return f"{origin.__name__}[{inner}]"
    name = getattr(annotation, "__name__", str(annotation))
    return f"{name} ({', '.join(bounds)})" if bounds else name


def _field_docs(model: type[BaseModel]) -> dict[str, str]:
    """The first line of each field's docstring (the string literal after its declaration), over the MRO."""
    docs: dict[str, str] = {}
    for cls in reversed(model.__mro__):
        if not (isinstance(cls, type) and issubclass(cls, BaseModel)) or cls.__module__.startswith("pydantic"):
            continue
        try:
            tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
        except (OSError, TypeError, SyntaxError):
            continue
        body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
        for stmt, nxt in zip(body, body[1:], strict=False):
            if (isinstance(stmt, ast.AnnAssign) and isinstance(stmt.target, ast.Name) and isinstance(nxt, ast.Expr)
                    and isinstance(nxt.value, ast.Constant) and isinstance(nxt.value.value, str)):
                line = " ".join(nxt.value.value.split(". ")[0].split()).rstrip(".") + "."
                docs[stmt.target.id] = line if len(line) <= 100 else line[:99] + "…"
    return docs


def describe_settings(model: type[BaseModel]) -> list[str]:
    """One line per field of the settings ``model``: ``name: type = default — first docstring line`` (the
    listing of ``ftc-mj components``, generated from the one declaration)."""
    docs = _field_docs(model)
    rows = []
    for name, f in model.model_fields.items():
        default = f.default_factory() if f.default_factory is not None else f.default  # type: ignore[call-arg]
        shown = "required" if f.is_required() else f"= {default!r}"
        doc = f" — {docs[name]}" if name in docs else ""
        rows.append(f"{name}: {_type_text(f.annotation, list(f.metadata))} {shown}{doc}")
    return rows
