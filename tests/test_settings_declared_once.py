"""Every setting of the estimation, decision and reconfiguration components is declared once: in its
settings model, beside its component (issue 39, acceptance 2).

The checks walk the settings models of ``ftc_mj.estimation``, ``ftc_mj.reconfiguration`` and
``ftc_mj.control.excitation`` and then every other declaration in those packages, in the wiring that
builds them and in the config sections that compose them:

- no function parameter, dataclass field or class attribute re-declares a setting's default (a
  parameter or field named like a setting whose default is that setting's default value);
- no ``Protocol`` mirrors settings (a Protocol of data attributes only; the interface Protocols
  ``Estimator`` and ``DecisionRule`` declare methods);
- no component or registered factory takes its ``settings`` as ``Any`` (or unannotated);
- the ``[reconfiguration]`` section adds no field of its own besides the composition (``excitation``,
  ``degraded``); ``[estimator]`` is the union of the estimator kinds' models, each declared in the
  estimation package;
- the components import neither the application config nor the wiring.

A planted duplicate shows that the first check finds one.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil
import typing
from pathlib import Path

import pytest
from pydantic import BaseModel

import ftc_mj
from ftc_mj.config import sections

ROOT = Path(ftc_mj.__file__).parent
PACKAGES = ("ftc_mj.estimation", "ftc_mj.reconfiguration")
EXTRA_MODULES = ("ftc_mj.control.excitation", "ftc_mj.wiring.estimation", "ftc_mj.wiring.decision",
                 "ftc_mj.wiring.reconfiguration", "ftc_mj.config.sections")
NOT_OURS = {"ftc_mj.reconfiguration.scenario_weights"}
"""Its ``WeightingSettings`` mirrors the robust controller's settings: the control side removes it."""
COMPOSITION = {"ReconfigurationConfig": {"excitation", "degraded", "accommodation"}}
"""The fields a config section may add to the component models it composes."""


def modules() -> list:
    """Every module of the packages and the extra modules (imported)."""
    out = []
    for name in PACKAGES:
        pkg = importlib.import_module(name)
        out.append(pkg)
        out += [importlib.import_module(m.name) for m in pkgutil.walk_packages(pkg.__path__, name + ".")]
    return [*out, *(importlib.import_module(m) for m in EXTRA_MODULES)]


def settings_models() -> list[type[BaseModel]]:
    """The settings models declared in the component modules (not in the config)."""
    return [o for mod in modules() if not mod.__name__.startswith("ftc_mj.config")
            for o in vars(mod).values()
            if isinstance(o, type) and issubclass(o, BaseModel) and o.__module__ == mod.__name__]


def setting_defaults() -> dict[str, list[object]]:
    """Each setting's name and its default values (over the models; ``None`` and factories left out)."""
    out: dict[str, list[object]] = {}
    for model in settings_models():
        for name, f in model.model_fields.items():
            if f.default_factory is None and f.default is not None:
                out.setdefault(name, []).append(f.default)
    return out


def _same(a: object, b: object) -> bool:
    return type(a) is type(b) and a == b or (isinstance(a, tuple | list) and list(a) == list(b))  # type: ignore[arg-type]


def redeclared_defaults(source: str, where: str, defaults: dict[str, list[object]],
                        models: set[str] = frozenset()) -> list[str]:
    """Parameters, dataclass fields and class attributes of ``source`` named like a setting and defaulting to
    its value (the settings models ``models`` themselves are the one declaration and are skipped)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        pairs: list[tuple[str, ast.expr]] = []
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            a = node.args
            positional = [*a.posonlyargs, *a.args]
            pairs += [(p.arg, d) for p, d in zip(positional[len(positional) - len(a.defaults):], a.defaults,
                                                 strict=True)]
            pairs += [(p.arg, d) for p, d in zip(a.kwonlyargs, a.kw_defaults, strict=True) if d is not None]
        elif isinstance(node, ast.ClassDef) and node.name not in models:
            pairs += [(s.target.id, s.value) for s in node.body if isinstance(s, ast.AnnAssign)
                      and isinstance(s.target, ast.Name) and s.value is not None]
        for name, value in pairs:
            try:
                literal = ast.literal_eval(value)
            except ValueError:
                continue
            if any(_same(literal, d) for d in defaults.get(name, ())):
                found.append(f"{where}:{value.lineno} {getattr(node, 'name', '?')}.{name} = {literal!r}")
    return found


def test_the_walk_sees_the_models() -> None:
    names = {m.__name__ for m in settings_models()}
    assert {"FilterSettings", "IMMSettings", "HypothesisSettings", "DecisionSettings", "ReconfigurationSettings",
            "DegradedSettings", "ExcitationSettings", "EKFSettings", "UKFSettings", "IMMEKFSettings",
            "IMMUKFSettings", "NoFilterSettings", "PluginEstimatorSettings"} <= names


def test_the_estimator_section_only_composes() -> None:
    """``[estimator]`` is the union of the kinds' models, each declared in the estimation package."""
    for model in (*sections.ESTIMATOR_KINDS.values(), sections.PluginEstimatorSettings):
        assert model.__module__.startswith("ftc_mj.estimation."), model


def test_no_default_is_declared_twice() -> None:
    defaults = setting_defaults()
    models = {m.__name__ for m in settings_models()}
    found = [hit for mod in modules() if mod.__name__ not in NOT_OURS
             for hit in redeclared_defaults(Path(mod.__file__).read_text(), mod.__name__, defaults, models)]
    assert not found, f"a setting's default declared again: {found}"


def test_the_check_finds_a_planted_duplicate() -> None:
    """A spec or function that copies a setting's default is found (and a different value is not)."""
    defaults = setting_defaults()
    planted = ("from dataclasses import dataclass\n@dataclass\nclass Spec:\n    dwell: float = 0.5\n"
               "def rule(min_drop: float = 0.1, *, ramp_rate=0.2): ...\n")
    found = redeclared_defaults(planted, "planted", defaults)
    assert found == ["planted:4 Spec.dwell = 0.5", "planted:5 rule.min_drop = 0.1"]


def test_no_protocol_mirrors_settings() -> None:
    mirrors = []
    for mod in modules():
        if mod.__name__ in NOT_OURS:
            continue
        for name, o in vars(mod).items():
            if isinstance(o, type) and o.__module__ == mod.__name__ and getattr(o, "_is_protocol", False):
                methods = [k for k, v in vars(o).items() if callable(v) and not k.startswith("__")]
                if not methods:
                    mirrors.append(f"{mod.__name__}.{name}")
    assert not mirrors, f"Protocols of data attributes only (settings mirrors): {mirrors}"


def _settings_parameters(mod) -> list[tuple[str, object]]:
    """``(where, annotation)`` of every parameter named ``settings`` of the module's classes and functions."""
    out = []
    for o in vars(mod).values():
        if getattr(o, "__module__", None) != mod.__name__:
            continue
        fns = [o] if inspect.isfunction(o) else []
        if inspect.isclass(o):
            fns = [getattr(v, "__func__", v) for v in vars(o).values()
                   if inspect.isfunction(getattr(v, "__func__", v))]
        for fn in fns:
            param = inspect.signature(fn).parameters.get("settings")
            if param is not None:
                out.append((f"{mod.__name__}.{fn.__qualname__}", param.annotation))
    return out


def test_no_component_takes_its_settings_as_any() -> None:
    params = [p for mod in modules() if mod.__name__ not in NOT_OURS for p in _settings_parameters(mod)]
    assert len(params) >= 10, params  # the filters, the IMM, the rules, the policies, the degraded mode …
    untyped = [where for where, ann in params
               if ann is inspect.Parameter.empty or ann is typing.Any or str(ann).split(" |")[0] in ("Any", "object")]
    assert not untyped, f"settings taken untyped or as Any: {untyped}"


@pytest.mark.parametrize("section", sorted(COMPOSITION))
def test_config_sections_only_compose(section: str) -> None:
    cls = getattr(sections, section)
    own = set(cls.__dict__.get("__annotations__", {}))
    assert own <= COMPOSITION[section], f"{section} declares {sorted(own - COMPOSITION[section])} itself"
    assert any(base.__module__ != sections.__name__ and issubclass(base, BaseModel) for base in cls.__mro__[1:])


def test_components_import_neither_the_config_nor_the_wiring() -> None:
    offenders = []
    for mod in modules():
        if not mod.__name__.startswith(PACKAGES):
            continue
        for node in ast.walk(ast.parse(Path(mod.__file__).read_text())):
            if isinstance(node, ast.ImportFrom):
                level = node.level - (1 if Path(mod.__file__).name == "__init__.py" else 0)  # parts to drop
                base = mod.__name__.split(".")[: len(mod.__name__.split(".")) - level] if node.level else []
                target = ".".join([*base, node.module or ""]) if node.level else node.module or ""
            elif isinstance(node, ast.Import):
                target = node.names[0].name
            else:
                continue
            if target.startswith(("ftc_mj.config", "ftc_mj.wiring")):
                offenders.append(f"{mod.__name__} imports {target}")
    assert not offenders, offenders
