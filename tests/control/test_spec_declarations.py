"""Each control setting is declared once: in its settings model beside the controller.

The walk covers every module of :mod:`ftc_mj.control`, the wiring that builds the controllers
(:mod:`ftc_mj.wiring.control`) and the robust NMPC's scenario weighting
(:mod:`ftc_mj.reconfiguration.scenario_weights`). It collects the settings models (pydantic models) defined
there and fails when a problem spec or other dataclass re-declares a setting's field with a default of its own
(the spec must be built from the model: ``tracking_problem``, ``path_following_problem``), or when a
``Protocol`` mirrors a settings model (two or more of its data attributes are one model's fields, or one
carries a default). The interface Protocols (``Controller``, ``Path``, ``Reference``) declare behaviour and
at most one setting (``Path.speed``, what a path-following controller reads of its path), so they pass.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import pkgutil
from collections.abc import Iterator

from pydantic import BaseModel

import ftc_mj.control

WALKED = ("ftc_mj.wiring.control", "ftc_mj.reconfiguration.scenario_weights")
"""Modules outside :mod:`ftc_mj.control` that hold control settings or their readers."""


def _modules() -> list[object]:
    names = [f"ftc_mj.control.{m.name}" for m in pkgutil.iter_modules(ftc_mj.control.__path__)]
    return [importlib.import_module(n) for n in ["ftc_mj.control", *names, *WALKED]]


def _classes() -> Iterator[type]:
    """Every class defined in (not imported into) the walked modules."""
    seen = set()
    for mod in _modules():
        for _, cls in inspect.getmembers(mod, inspect.isclass):
            if cls.__module__ == mod.__name__ and cls not in seen:
                seen.add(cls)
                yield cls


def settings_models() -> dict[type, set[str]]:
    """The settings models of the walked modules and their field names."""
    return {c: set(c.model_fields) for c in _classes() if issubclass(c, BaseModel)}


def _protocol_attributes(cls: type) -> dict[str, bool]:
    """The data attributes a Protocol declares itself: name -> carries a default."""
    notes = cls.__dict__.get("__annotations__", {})
    return {name: name in cls.__dict__ for name in notes}


def second_declarations(models: dict[type, set[str]], classes: list[type]) -> list[str]:
    """Where ``classes`` declare a setting of ``models`` a second time (module docstring)."""
    every = set().union(*models.values())
    found = []
    for cls in classes:
        if dataclasses.is_dataclass(cls):
            for f in dataclasses.fields(cls):
                has_default = f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING
                if has_default and f.name in every:
                    found.append(f"{cls.__name__}.{f.name}: a setting's default declared again")
        elif getattr(cls, "_is_protocol", False):
            attrs = _protocol_attributes(cls)
            for model, fields in models.items():
                shared = sorted(set(attrs) & fields)
                if len(shared) >= 2 or any(attrs[n] for n in shared):
                    found.append(f"{cls.__name__} mirrors {model.__name__} ({', '.join(shared)})")
    return found


def test_no_setting_is_declared_twice() -> None:
    models = settings_models()
    assert len(models) >= 9  # the controller kinds' models, the MPCs' base, path following, robust, reference
    assert second_declarations(models, list(_classes())) == []


def test_the_walk_finds_a_second_declaration() -> None:
    """The check itself can fail: a spec with a default for a setting, and a Protocol mirroring a model."""
    models = settings_models()

    @dataclasses.dataclass(frozen=True)
    class Spec:
        nodes: int = 50
        half_track: float = 1.0

    class Mirror:
        _is_protocol = True
        scenarios: list
        posterior_floor: float

    found = second_declarations(models, [Spec, Mirror])
    assert any(s.startswith("Spec.nodes") for s in found)
    assert any(s.startswith("Mirror mirrors RobustSettings") for s in found)
    assert not any("half_track" in s for s in found)  # a run-context number, not a setting
