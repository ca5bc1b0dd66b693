"""Registries of the pluggable components: estimators, fault-decision rules, controllers,
reconfiguration policies, reference paths, fault classes and diagnosers.

A run config names each component by a string (``estimator.kind``, ``estimator.decision.rule``,
``controller.kind``, ``reconfiguration.policy``, ``reference.kind``); the simulation looks the name
up here and calls the registered *factory*. What each factory receives and what the object it
returns must do (inputs, outputs, units, what the loop calls when) is documented in
``docs/plugins.md``; the built-ins are the examples.

Where names come from, in this order, the first time a registry is asked for one:

1. the built-ins, which register themselves when their module is imported (the module is named
   here, as data, and imported on first use, so this module imports no component);
2. Python entry points of the registry's group (``ftc_mj.estimators``, ``ftc_mj.decision_rules``,
   ``ftc_mj.controllers``, ``ftc_mj.policies``, ``ftc_mj.references``) of installed packages:
   ``name = "module:factory"`` registers ``factory`` under ``name``;
3. calls of :meth:`Registry.register` (``ftc_mj.register_estimator("my-filter", factory)``), e.g.
   by the modules a config lists in ``plugins`` (:func:`load_plugins`), which every process that
   validates the config imports first — so Dask workers know the same components as the client.

A name is registered once: registering a taken name is an error unless ``replace=True``.
"""

from __future__ import annotations

import importlib
import inspect
import os
import re
import sys
import warnings
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from typing import Any

from .errors import BadInput
from .suggest import did_you_mean

NAME_RE = re.compile(r"^[a-z0-9][a-z0-9_.+-]{0,62}$")
"""A component name: lower-case letters, digits and ``_ . + -`` (it appears in run ids and file names)."""
BUILTIN = "built-in"
"""``origin`` of the components this package registers."""
MODULE_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")
"""An importable module name (``my_pkg.filters``)."""


@dataclass(frozen=True)
class Entry:
    """One registered component."""

    name: str
    factory: Callable[..., Any]
    """Builds the component (signature per registry: ``docs/plugins.md``)."""
    settings: type | None = None
    """A pydantic model validating the component's ``options`` table of the config, or ``None``
    (then ``options`` must be empty)."""
    meta: Mapping[str, Any] = field(default_factory=dict)
    """What the simulation needs to know about the component (per registry, e.g. ``reusable``)."""
    origin: str = ""
    """Who registered it: ``built-in``, ``entry point <value>`` or the registering module."""
    legacy: bool = False
    """The factory takes the whole run config (``factory(cfg, ...)``, the contract before 0.3) instead
    of its own settings and a :class:`~ftc_mj.context.RunContext`; still called, with a warning."""


class Registry:
    """Named factories of one kind of component (see the module docstring)."""

    def __init__(self, kind: str, group: str, builtins: str, config_key: str) -> None:
        self.kind = kind
        """What the components are (``estimator``), for messages."""
        self.group = group
        """Entry-point group of installed packages' components."""
        self.config_key = config_key
        """The config key naming a component of this registry (``estimator.kind``)."""
        self._builtins = builtins
        self._entries: dict[str, Entry] = {}
        self._state = "empty"  # empty -> loaded (the built-ins' module imported, entry points read)

    # ---------------------------------------------------------------- registration
    def register(self, name: str, factory: Callable[..., Any] | None = None, *, settings: type | None = None,
                 replace: bool = False, origin: str | None = None, **meta: Any) -> Any:
        """Register ``factory`` under ``name``; without ``factory``, a decorator. ``settings``: a pydantic
        model for the component's ``options``; ``meta``: flags the simulation reads (per registry).
        ``ValueError`` for a malformed or (unless ``replace``) taken name."""
        if factory is None:
            return lambda f: self.register(name, f, settings=settings, replace=replace, origin=origin, **meta) or f
        if not isinstance(name, str) or not NAME_RE.match(name):
            raise ValueError(f"{self.kind} name {name!r}: lower-case letters, digits and '_ . + -', at most 63")
        if not callable(factory):
            raise TypeError(f"{self.kind} {name!r}: the factory must be callable, got {type(factory).__name__}")
        if self._state == "empty" and origin != BUILTIN:
            self._load()  # a plug-in's name must not collide with a built-in loaded later
        if name in self._entries and not replace:
            raise ValueError(f"{self.kind} {name!r} is already registered ({self._entries[name].origin}); "
                             "pass replace=True to replace it")
        where = origin or str(getattr(factory, "__module__", "?"))
        self._entries[name] = Entry(name, factory, settings, dict(meta), where, takes_run_config(factory))
        return None

    def unregister(self, name: str) -> None:
        """Remove ``name`` (tests and notebooks that re-register)."""
        self._entries.pop(name, None)

    # ---------------------------------------------------------------- lookup
    def names(self) -> tuple[str, ...]:
        """Every registered name, sorted."""
        self._ensure()
        return tuple(sorted(self._entries))

    def get(self, name: str) -> Entry:
        """The entry of ``name``; ``KeyError`` with the message of :meth:`check`."""
        self._ensure()
        try:
            return self._entries[name]
        except KeyError:
            raise KeyError(self.unknown(name)) from None

    def peek(self, name: str) -> Entry | None:
        """The entry of ``name`` if it is registered already, without loading the registry."""
        return self._entries.get(name)

    @property
    def loaded(self) -> bool:
        """The built-ins and entry points have been loaded."""
        return self._state == "loaded"

    def check(self, name: str) -> str:
        """``name`` if it is registered, else ``ValueError`` listing the registered names."""
        self._ensure()
        if name not in self._entries:
            raise ValueError(self.unknown(name))
        return name

    def unknown(self, name: str) -> str:
        """The message for an unregistered ``name``."""
        names = self.names()
        return (f"unknown {self.kind} {name!r}{did_you_mean(name, names)}; registered: {', '.join(names)} "
                f"(register one with ftc_mj.register_{self.kind.replace(' ', '_')}, or name its module in "
                "plugins = [...])")

    def build(self, name: str, *args: Any, **kwargs: Any) -> Any:
        """``factory(*args, **kwargs)`` of ``name``."""
        return self.get(name).factory(*args, **kwargs)

    def create(self, name: str, settings: Any, context: Any, *extra: Any, run_config: Any = None,
               **kwargs: Any) -> Any:
        """The component ``name`` built by the contract: ``factory(settings, context, *extra, **kwargs)``
        (``settings``: the component's own config section; ``context``: the
        :class:`~ftc_mj.context.RunContext`). A factory of the old contract, ``factory(cfg, *extra)``,
        is called with ``run_config`` and a one-line :class:`DeprecationWarning` saying what to change."""
        entry = self.get(name)
        if not entry.legacy:
            return entry.factory(settings, context, *extra, **kwargs)
        if name not in _warned:
            _warned.add(name)
            warnings.warn(f"{self.kind} {name!r} ({entry.origin}): factory(cfg) is the old contract; take "
                          "(settings, context) instead (docs/plugins.md of the source repository)", DeprecationWarning,
                          stacklevel=2)
        return entry.factory(run_config, *extra, **kwargs)

    # ---------------------------------------------------------------- loading
    def _ensure(self) -> None:
        if self._state == "empty":
            self._load()

    def _load(self) -> None:
        importlib.import_module(self._builtins)
        self._state = "loaded"
        for ep in entry_points(group=self.group):
            if ep.name in self._entries:
                continue
            try:
                factory = ep.load()
            except Exception as err:  # noqa: BLE001 - an installed plug-in that cannot load is named, not hidden
                raise BadInput(f"entry point {self.group}:{ep.name} = {ep.value!r} cannot be loaded: "
                               f"{type(err).__name__}: {err}") from None
            if ep.name not in self._entries:  # importing may have registered it already
                self.register(ep.name, factory, origin=f"entry point {ep.value}")


estimators = Registry("estimator", "ftc_mj.estimators", "ftc_mj.wiring.estimation", "estimator.kind")
"""``factory(settings: EstimatorSettings, context: RunContext) -> Estimator | None`` (``settings``: the
``[estimator]`` section, the model of its ``kind`` — a plug-in's ``PluginEstimatorSettings``; ``None``: the run
has no filter); meta ``section``: a built-in's settings model."""
decision_rules = Registry("decision rule", "ftc_mj.decision_rules", "ftc_mj.wiring.decision",
                          "estimator.decision.rule")
"""``factory(settings: DecisionSettings, context: RunContext) -> DecisionRule`` (``settings``: the
``[estimator.decision]`` section); meta ``calibrate="cusum"|"glr"``: the factory is called with that
detector's calibrated threshold (LLR units) as a third argument; meta ``detectors=True``: and with the
run's :class:`~ftc_mj.estimation.residual.ChangeDetectors` (the no-fault residual generator with its
CUSUM and GLR) as a fourth."""
controllers = Registry("controller", "ftc_mj.controllers", "ftc_mj.wiring.control", "controller.kind")
"""``factory(settings, context: RunContext, reference: Reference) -> Controller`` (``settings``: the
``[controller]`` section, the settings model of its kind — a built-in's registered as meta ``section``);
meta ``reusable=True``: the controller has ``reset()`` and is cached per process and structure (MPC solvers);
``retargetable=True``: it also has ``set_reference(reference)`` and its built problem does not depend on the
reference (the cache then keeps it across references);
``rate_bounded=True``: its first input stays within ``controller.omega_rate_max / rate`` of the
command in force (the loop clips a dither to that bound)."""
policies = Registry("policy", "ftc_mj.policies", "ftc_mj.reconfiguration.policies", "reconfiguration.policy")
"""``factory(settings: ReconfigurationSettings, context: RunContext) -> ReconfigurationPolicy``
(``settings``: the ``[reconfiguration]`` section, a plug-in's ``options`` in ``settings.options``);
meta ``needs_estimator=False``: used even in runs without a filter (otherwise such runs use ``none``)."""
references = Registry("reference", "ftc_mj.references", "ftc_mj.wiring.control", "reference.kind")
"""``factory(settings: ReferenceSettings, context: RunContext) -> Reference`` (``settings``: the ``[reference]``
section; the path starts at ``context.initial_pose``)."""

fault_classes = Registry("fault class", "ftc_mj.fault_classes", "ftc_mj.plant.faults", "faults.plugin.fault_class")
"""``factory(settings) -> FaultClass``: the fault class itself (:class:`~ftc_mj.plant.faults.base.FaultClass`,
its name, targets, units, parameters' ranges, physics, truth columns and observing measurements as class
attributes), built from one configuration table; ``settings``: the model of a plug-in class's ``options``
(``[[faults.plugin]]``). A benchmark definition's ``plugins`` modules register the classes it draws."""

diagnosers = Registry("diagnoser", "ftc_mj.diagnosers", "ftc_mj.wiring.diagnosis", "diagnosis.kind")
"""``factory(settings, context: RunContext) -> Diagnoser | None`` (``settings``: the ``[diagnosis]`` section,
the model of its ``kind`` — a plug-in's ``PluginDiagnoserSettings`` with its ``options``; ``None``: the run has no
diagnoser); the object's ``step(DiagnosisInput) -> DiagnosisStep`` is called once per estimator step
(:mod:`ftc_mj.estimation.diagnosis.base`); meta ``section``: a built-in's settings model."""

REGISTRIES: dict[str, Registry] = {"estimators": estimators, "decision_rules": decision_rules,
                                   "controllers": controllers, "policies": policies, "references": references,
                                   "fault_classes": fault_classes, "diagnosers": diagnosers}
"""Every registry by its name."""

_loaded_plugins: set[str] = set()
_warned: set[str] = set()


def takes_run_config(factory: Callable[..., Any]) -> bool:
    """Whether ``factory`` follows the old contract: its first parameter is named ``cfg`` or ``config``
    (the whole run config) rather than ``settings``."""
    try:
        params = list(inspect.signature(factory).parameters.values())
    except (TypeError, ValueError):  # builtins without a signature: the new contract
        return False
    if inspect.isclass(factory) and params and params[0].name == "self":
        params = params[1:]
    return bool(params) and params[0].name in ("cfg", "config")


def current_directory_on_path() -> None:
    """Make modules in the current directory importable, as ``python -m`` does (``ftc-mj run --plugin
    my_components`` from the folder holding ``my_components.py``); the directory is appended, so an
    installed package of the same name still wins."""
    cwd = os.getcwd()
    if "" not in sys.path and cwd not in sys.path:
        sys.path.append(cwd)
        importlib.invalidate_caches()


def plugin_folder_on_path(folder: str) -> None:
    """Make the plug-in modules of ``folder`` (absolute; a method file's folder) importable here and in the
    local Dask workers started afterwards (appended to ``sys.path`` and to ``PYTHONPATH``, which those worker
    processes inherit); an installed package of the same name still wins."""
    if folder not in sys.path:
        sys.path.append(folder)
        importlib.invalidate_caches()
    parts = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    if folder not in parts:
        os.environ["PYTHONPATH"] = os.pathsep.join([*parts, folder])


def load_plugins(modules: Iterable[str]) -> None:
    """Import each plug-in module once (importing registers its components), the current directory
    searched too (:func:`current_directory_on_path`). :class:`BadInput` naming ``plugins`` if a name is
    malformed or the module cannot be imported (also when importing it calls ``sys.exit``)."""
    for name in modules:
        if not isinstance(name, str) or not MODULE_RE.match(name):
            raise BadInput(f"plugins: {name!r} is not a module name (e.g. \"my_pkg.filters\")")
        if name in _loaded_plugins:
            continue
        current_directory_on_path()
        try:
            importlib.import_module(name)
        except SystemExit as err:  # sys.exit() on import would end ftc-mj silently (exit 0, nothing written)
            raise BadInput(f"plugins: importing {name!r} called sys.exit({err.code!r}); a plug-in module must "
                           "only define and register its components") from None
        except Exception as err:  # noqa: BLE001 - whatever the plug-in raised, the user's module is named
            msg = str(err).splitlines()[0] if str(err) else ""
            raise BadInput(f"plugins: cannot import {name!r}: {type(err).__name__}: {msg[:200]}") from None
        _loaded_plugins.add(name)


def settings_listing(registry: Registry) -> list[str]:
    """The settings of every component of ``registry``, as ``ftc-mj components`` prints them: per component,
    the model a built-in was registered with (meta ``section``; components sharing one model are listed
    together) and a plug-in's ``options`` model, one indented line per field
    (:func:`ftc_mj.fields.describe_settings`, imported here on use: the fields module imports this one)."""
    describe = importlib.import_module("ftc_mj.fields").describe_settings
    groups: dict[tuple[type, str], list[str]] = {}
    for name in registry.names():
        entry = registry.get(name)
        for model, where in ((entry.meta.get("section"), registry.config_key.rsplit(".", 1)[0]),
                             (entry.settings, "options")):
            if model is not None:
                groups.setdefault((model, where), []).append(name)
    lines = []
    for (model, where), names in groups.items():
        lines.append(f"  {', '.join(names)} — [{where}] {model.__name__}:")
        lines.extend(f"    {row}" for row in describe(model))
    return lines


def load_plugins_of(data: Any) -> None:
    """Import the modules a table about to be validated names in ``plugins`` (a run config, a benchmark
    definition), so that the components it names are registered first; anything else is left to the
    validation to reject."""
    mods = data.get("plugins") if isinstance(data, dict) else None
    if isinstance(mods, list) and all(isinstance(m, str) for m in mods):
        load_plugins(mods)


def check_options(registry: Registry, name: str, options: Mapping[str, Any]) -> dict[str, Any]:
    """``options`` validated by the ``settings`` model ``name`` was registered with (as plain data, the
    settings' defaults filled in); ``ValueError`` if the component takes none, pydantic's
    ``ValidationError`` if they do not fit (the config words it in one line,
    :func:`ftc_mj.validation.one_line`)."""
    # empty options of a registry not loaded yet (a default config): nothing to fill in, and the
    # components' modules stay unimported (a given name has loaded the registry when it was checked)
    entry = registry.get(name) if options or registry.loaded else registry.peek(name)
    settings = entry.settings if entry is not None else None
    if settings is None:
        if options:
            raise ValueError(f"{registry.kind} {name!r} takes no options (got {', '.join(map(str, options))})")
        return {}
    return settings.model_validate(dict(options)).model_dump(mode="json")  # type: ignore[attr-defined]
