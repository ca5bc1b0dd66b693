"""The methods a benchmark scores: built-in names or a small TOML file of settings.

A method is a named combination of estimator, decision rule, reconfiguration policy and controller —
the run-config keys of those sections (:data:`METHOD_SECTIONS`) and nothing the draw sets (faults,
plant, sensors, path, duration, seed). A method file::

    name = "my-ukf-safe"
    description = "..."
    plugins = ["my_policy"]            # optional: modules registering plug-in components, found in
                                       # the method file's folder (or installed)
    [settings]                         # dotted keys or nested tables
    "estimator.kind" = "ukf"
    "reconfiguration.policy" = "safe"

Its *digest* hashes its resolved settings (those sections after validation, defaults filled in, plus
the plug-in modules) and its code (:func:`code_identity`: the ftc-mj version and source revision, and the
contents of each plug-in module): a test-split result records it, so a leaderboard entry names exactly what
was run, and a changed method — settings or code — is a new entry, never a silent replacement.
``examples/blend_policy.toml`` is one, and ``docs/tutorial-benchmark.md`` scores it step by step.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

from pydantic import Field, ValidationError

from ..config import RunConfig, SafeName, existing_file, one_line, read_toml, set_dotted, validate_config
from ..errors import BadInput
from ..fields import StrictModel
from ..identity import canonical_hash
from ..registry import plugin_folder_on_path
from ..study.spec import flatten_dotted, key_error
from ..suggest import did_you_mean

METHOD_SECTIONS = ("estimator", "controller", "reconfiguration", "model")
"""The run-config sections a method may set (what it is); the draw sets the rest (what it faces)."""

ACTIVE = {"estimator.kind": "ukf", "controller.rate_penalty": 1.0}
ACCOMMODATE_ALL = {"reconfiguration.accommodation.mode": "all"}
"""The diagnoser's declarations in force reach the controller per mode (:mod:`ftc_mj.reconfiguration.accommodation`);
the oracle row is the path-following method given the truth instead, so the gap between them is the diagnosis's."""
BUILTIN: dict[str, tuple[str, dict[str, Any]]] = {
    "paper": ("the paper's loop: UKF, NMPC with the paper's cost, feedback on (policy direct)",
              {"estimator.kind": "ukf", "controller.kind": "nmpc", "reconfiguration.policy": "direct",
               "controller.rate_penalty": 0.0}),
    "safe": ("UKF, NMPC with the actuation-rate term, the safe policy (the default loop), every diagnosed mode "
             "accommodated (a safe stop where the path is out of reach)",
             {**ACTIVE, "controller.kind": "nmpc", "reconfiguration.policy": "safe", **ACCOMMODATE_ALL}),
    "pathfollow": ("UKF, the path-following NMPC (pf-nmpc) with the actuation-rate term, the safe policy, every "
                   "diagnosed mode accommodated (a safe stop where the path is out of reach)",
                   {**ACTIVE, "controller.kind": "pf-nmpc", "reconfiguration.policy": "safe", **ACCOMMODATE_ALL}),
    "hybrid": ("UKF, the robust multi-stage NMPC re-weighted by the filter's posterior (hybrid FTC)",
               {**ACTIVE, "controller.kind": "robust-nmpc", "controller.robust.weighting": "posterior",
                "reconfiguration.policy": "none"}),
    "passive": ("UKF (FDI scored), the robust multi-stage NMPC with fixed weights (passive FTC)",
                {**ACTIVE, "controller.kind": "robust-nmpc", "reconfiguration.policy": "none"}),
    "feedback-off": ("UKF (FDI scored), the nominal NMPC with the actuation-rate term, never reconfigured",
                     {**ACTIVE, "controller.kind": "nmpc", "reconfiguration.policy": "none"}),
}
"""Built-in methods: name → (description, settings). ``feedback-off`` is also the healthy-path check's
nominal NMPC."""
REFERENCE_ROWS: dict[str, tuple[str, dict[str, Any]]] = {
    "oracle": ("a ceiling, not a method: the path-following NMPC told the truth (the run flag oracle = true: the "
               "true pose, the truth policy's true radii from each onset, the drawn plant's limits, every fault as "
               "its diagnosis from its onset, accommodated — a safe stop where the path is out of reach), no "
               "estimator",
               {**ACTIVE, "estimator.kind": "none", "controller.kind": "pf-nmpc", "reconfiguration.policy": "truth",
                **ACCOMMODATE_ALL, "oracle": True}),
    "standstill": ("a floor, not a method: zero wheel-rate command throughout (the open loop at 0 rad/s), no "
                   "estimator", {"estimator.kind": "none", "controller.kind": "open-loop",
                                 "controller.open_loop_omega": [0.0, 0.0], "reconfiguration.policy": "none"}),
}
"""Built-in reference rows, scored like methods but not methods (the information rule does not bind them; a method
file cannot set ``oracle``): name → (description, settings). The page reports every method's success as a fraction
of the oracle's and lists the trackable draws the oracle fails."""


class MethodFile(StrictModel):
    """A method file (module docstring)."""

    name: SafeName
    description: Annotated[str, Field(max_length=2000)] = ""
    plugins: Annotated[list[str], Field(max_length=50)] = Field(default_factory=list)
    settings: dict[str, Any] = Field(default_factory=dict)


@dataclass(frozen=True)
class Method:
    """A method: its name, description, settings (dotted keys) and plug-in modules."""

    name: str
    description: str
    settings: dict[str, Any]
    plugins: tuple[str, ...] = ()
    source: str = "built-in"
    digest: str = field(default="", compare=False)
    code: dict[str, Any] = field(default_factory=dict, compare=False)
    """:func:`code_identity` (recorded in ``bench.json``)."""

    @property
    def argument(self) -> str:
        """How ``ftc-mj bench`` names this method: the built-in's name, else the method file's absolute path
        (a replay command works from any folder)."""
        return self.name if self.source == "built-in" else self.source

    def apply(self, scenario: dict[str, Any]) -> RunConfig:
        """The run config of a draw's ``scenario`` run by this method (validated; :class:`BadInput`); its
        ``plugins``: the draw's (the benchmark's fault classes), then the method's."""
        plugins = [*scenario.get("plugins", []), *(p for p in self.plugins if p not in scenario.get("plugins", []))]
        data = {**scenario, "plugins": plugins} if plugins else dict(scenario)
        data = {k: (dict(v) if isinstance(v, dict) else v) for k, v in data.items()}
        for k, v in self.settings.items():
            set_dotted(data, k, v)
        try:
            return validate_config(data)
        except BadInput as err:
            raise BadInput(f"method {self.name}: {err}") from None


def check_settings(settings: dict[str, Any], where: str) -> dict[str, Any]:
    """``settings`` flattened to dotted keys, each a run-config key inside :data:`METHOD_SECTIONS`."""
    flat = flatten_dotted(settings)
    for k in flat:
        err = key_error(k)
        if err:
            raise BadInput(f"{where}: settings.{k}: {err}")
        if k.split(".")[0] not in METHOD_SECTIONS:
            raise BadInput(f"{where}: settings.{k}: a method sets only {', '.join(METHOD_SECTIONS)}; the draw sets "
                           "the faults, plant, sensors, path, duration and seed")
    return flat


def module_digest(name: str) -> str:
    """16 hex digits of the SHA-256 of an imported plug-in module's source: its file, or for a package every
    ``.py`` file below it (relative path and bytes); :class:`BadInput` naming ``plugins`` if it has no source
    file."""
    import hashlib
    import importlib.util
    import sys

    mod = sys.modules.get(name)
    origin = getattr(mod, "__file__", None)
    if origin is None:
        spec = importlib.util.find_spec(name)
        origin = spec.origin if spec is not None else None
    if origin is None or not Path(origin).is_file():
        raise BadInput(f"plugins: {name!r} has no source file to identify the method's code by")
    path = Path(origin)
    files = sorted(path.parent.rglob("*.py")) if path.name == "__init__.py" else [path]
    h = hashlib.sha256()
    for f in files:
        h.update(str(f.relative_to(path.parent)).encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()[:16]


def code_identity(method: Method) -> dict[str, Any]:
    """The code a method runs: the ftc-mj version and source (:func:`~ftc_mj.identity.source_identity`: the git
    revision of a clean checkout, else a hash of the package's sources) — every method runs built-in
    components — and the content hash of each of its plug-in modules (imported by then: the digest validates
    the method's config first)."""
    from .. import __version__
    from ..identity import source_identity

    return {"ftc_mj": __version__, "source": source_identity(),
            "plugins": {p: module_digest(p) for p in method.plugins}}


def resolved_digest(method: Method) -> str:
    """16 hex digits of the method's resolved settings (:data:`METHOD_SECTIONS` of a validated config with its
    settings, defaults filled in), plug-in modules and code (:func:`code_identity`)."""
    cfg = method.apply({"name": "digest"})
    dump = cfg.model_dump(mode="json")
    told = {"oracle": True} if dump.get("oracle") else {}  # a reference row told the truth (never a method file)
    return canonical_hash({"sections": {s: dump[s] for s in METHOD_SECTIONS}, "plugins": list(method.plugins),
                           "code": code_identity(method), **told})[:16]


def load_method(spec: str) -> Method:
    """A built-in method name or a method file path, validated (:class:`BadInput` naming the field)."""
    if spec in BUILTIN or spec in REFERENCE_ROWS:
        desc, settings = {**BUILTIN, **REFERENCE_ROWS}[spec]
        m = Method(spec, desc, dict(settings))
    else:
        path = existing_file(spec, "METHOD", f"no such built-in method ({', '.join([*BUILTIN, *REFERENCE_ROWS])}) "
                             "or file", did_you_mean(spec, [*BUILTIN, *REFERENCE_ROWS]))
        try:
            f = MethodFile.model_validate(read_toml(path, "method"))
        except ValidationError as err:
            raise BadInput(f"method {path}: {one_line(err)}") from None
        if f.plugins:  # the plug-in modules beside the method file, wherever ftc-mj is run from
            plugin_folder_on_path(str(Path(path).resolve().parent))
        m = Method(f.name, f.description, check_settings(f.settings, f"method {path}"), tuple(f.plugins),
                   str(Path(path).resolve()))
    return Method(m.name, m.description, m.settings, m.plugins, m.source, resolved_digest(m), code_identity(m))


def load_methods(specs: list[str]) -> list[Method]:
    """Every method of the command line, with distinct names."""
    if not specs:
        raise BadInput(f"METHOD: name at least one method (built-in: {', '.join(BUILTIN)}, or a method file)")
    methods = [load_method(s) for s in specs]
    names = [m.name for m in methods]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise BadInput(f"METHOD: {dup[0]!r} given twice (methods need distinct names)")
    return methods
