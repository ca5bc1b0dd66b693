"""Study files: a base scenario plus axes to sweep, expanded to a plan. A study is a TOML file or
the name of a built-in study (``ftc_mj/data/studies/*.toml``: ``observability``, ``severity``, …).

A study file names a base scenario (built-in name or TOML path, relative paths resolved against
the study file's folder), base overrides, the axes to sweep and the Monte-Carlo seeds::

    name = "observability"
    scenario = "scenario2"
    seeds = 5                            # or a list: [0, 3, 7]

    [base]                               # dotted keys or nested tables
    duration = 30.0
    "estimator.kind" = "ukf"

    [[axes]]                             # a grid axis over one dotted key
    key = "estimator.kind"
    values = ["ekf", "ukf"]

    [[axes]]                             # a preset axis: each value sets several keys
    name = "sensors"
    labels = ["speed", "speed+yaw"]
    values = [{}, { "sensors.yaw_rate_sigma" = 0.01 }]

    [[axes]]                             # seeded random draws
    key = "plant.tyre_friction"
    kind = "random"
    dist = "uniform"                     # uniform (low, high) | normal (mean, std) | choice (choices)
    low = 0.6
    high = 1.2
    n = 4
    seed = 1

Combination rules: every axis belongs to a *group*; axes of one group are zipped (equal lengths
required), groups are crossed (Cartesian product). By default each ``grid`` axis is its own group,
all ``list`` axes form the group ``"list"`` and all ``random`` axes the group ``"random"``; set
``group = "..."`` to zip axes explicitly. The Monte-Carlo seeds are crossed with everything.

Placeholders: an axis without ``key`` whose values are scalars is a *label axis*; it sets nothing
itself but its value replaces the placeholder ``"{name}"`` wherever that string appears as a whole
key segment or a whole string value in ``base`` or in preset values, e.g.
``"faults.{wheel}" = [[10.0, 2.0], [10.0, "{fault_radius}"]]``. Nothing is ever evaluated.
``labels`` (any scalars) give the column value recorded for each axis value (default: the value
itself, or ``p0``, ``p1`` … for presets).

Every key is checked against :class:`~ftc_mj.config.RunConfig` and every run's resolved config is
validated before anything runs; all problems are :class:`~ftc_mj.errors.BadInput` with a one-line
message naming the study field.
"""

from __future__ import annotations

import itertools
import json
import math
import re
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from ..config import (
    RunConfig,
    SafeName,
    existing_file,
    one_line,
    read_toml,
    scenario_path,
    set_dotted,
    validate_config,
)
from ..errors import BadInput
from ..identity import canonical_hash, run_digest
from ..resources import builtin_studies, study_file

Scalar = str | int | float | bool
PLACEHOLDER = re.compile(r"^\{([A-Za-z_][A-Za-z0-9_]*)\}$")
RESERVED_COLUMNS = frozenset({"run_key", "run_index", "seed", "status", "error", "invocation"})
MAX_RUNS = 10_000
"""Largest plan (runs, seeds included) a study may expand to: planning validates every run's config
(about 0.5 ms each) and a run takes seconds, so beyond this a study is a typing slip; split it."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class AxisSpec(_Strict):
    """One sweep axis (see the module docstring)."""

    name: str | None = None
    """Column name in the results; default: ``key``."""
    key: str | None = None
    """Dotted config key the axis sets; absent for preset and label axes."""
    kind: Literal["grid", "list", "random"] = "grid"
    values: list[Any] | None = None
    labels: list[Scalar] | None = None
    group: str | None = None
    dist: Literal["uniform", "normal", "choice"] | None = None
    low: float | None = None
    high: float | None = None
    mean: float | None = None
    std: Annotated[float, Field(gt=0)] | None = None
    choices: list[Any] | None = None
    n: Annotated[int, Field(ge=1, le=100_000)] | None = None
    seed: Annotated[int, Field(ge=0)] = 0
    decimals: Annotated[int, Field(ge=0, le=15)] | None = 6
    """Random draws are rounded to this many decimals (stable keys, readable columns)."""

    @model_validator(mode="after")
    def _shape(self) -> AxisSpec:
        if self.kind == "random":
            if self.values is not None:
                raise ValueError("values: not allowed for a random axis (use dist/n)")
            if self.key is None:
                raise ValueError("key: a random axis needs a key")
            if self.n is None:
                raise ValueError("n: a random axis needs the number of draws n")
            if self.dist is None:
                raise ValueError("dist: a random axis needs dist = uniform | normal | choice")
            need = {"uniform": ("low", "high"), "normal": ("mean", "std"), "choice": ("choices",)}[self.dist]
            for f in need:
                if getattr(self, f) is None:
                    raise ValueError(f"{f}: required for dist = {self.dist}")
            if self.dist == "uniform" and not (self.low is not None and self.high is not None and self.low < self.high):
                raise ValueError("low: must be below high")
            if self.dist == "choice" and not self.choices:
                raise ValueError("choices: empty")
        else:
            if self.values is None:
                raise ValueError("values: required")
            if len(self.values) == 0:
                raise ValueError("values: empty axis")
            if self.n is not None or self.dist is not None:
                raise ValueError("dist: only a random axis has dist/n")
        if self.labels is not None and len(self.labels) != self.size:
            raise ValueError(f"labels: {len(self.labels)} labels for {self.size} values")
        if self.labels is not None and len({json.dumps(x) for x in self.labels}) != len(self.labels):
            raise ValueError("labels: duplicate labels")
        if self.key is None and self.name is None:
            raise ValueError("name: an axis without key needs a name")
        return self

    @property
    def size(self) -> int:
        """Number of values on this axis."""
        return self.n if self.kind == "random" else len(self.values or [])

    @property
    def column(self) -> str:
        """Result column holding this axis' labels."""
        return self.name or str(self.key)

    @property
    def default_group(self) -> str:
        if self.group is not None:
            return self.group
        if self.kind == "grid":
            return f"grid:{self.column}"
        return self.kind


class StudySpec(_Strict):
    """A whole study file."""

    name: SafeName
    """Names the default output folder (runs/out/studies/<name>): one plain file-name component."""
    description: str = ""
    scenario: str
    """Base scenario: built-in name (``scenario1`` …) or a TOML path (relative to the study file)."""
    base: dict[str, Any] = Field(default_factory=dict)
    """Base overrides applied to the scenario (dotted keys or nested tables)."""
    axes: list[AxisSpec] = Field(default_factory=list)
    seeds: Annotated[int, Field(ge=1, le=100_000)] | list[Annotated[int, Field(ge=0)]] | None = None
    """Monte-Carlo seeds: a count (seeds 0 … n-1) or an explicit list; unset = the base seed."""
    analysis: AnalysisSpec = Field(default_factory=lambda: AnalysisSpec())

    @model_validator(mode="after")
    def _names(self) -> StudySpec:
        seen: set[str] = set()
        for i, ax in enumerate(self.axes):
            col = ax.column
            if col in seen:
                raise ValueError(f"axes[{i}].name: duplicate axis name {col!r}")
            if col in RESERVED_COLUMNS:
                raise ValueError(f"axes[{i}].name: {col!r} is reserved")
            seen.add(col)
        if isinstance(self.seeds, list):
            if not self.seeds:
                raise ValueError("seeds: empty list")
            if len(set(self.seeds)) != len(self.seeds):
                raise ValueError("seeds: duplicate seeds")
        for i, f in enumerate(self.analysis.findings):
            for what, ax in (("axis", f.axis), ("by", f.by)):
                if ax is not None and ax not in seen:
                    raise ValueError(f"analysis.findings[{i}].{what}: no axis named {ax!r}")
        return self


class FindingSpec(_Strict):
    """A finding stated in ``summary.md``: ``metric`` compared across the values of ``axis``
    (optionally separately for each value of ``by``), with means and 95 % confidence intervals."""

    metric: str
    axis: str
    by: str | None = None
    baseline: Scalar | None = None
    """Label of ``axis`` that other values are compared with (default: the first value)."""
    title: str = ""
    unit: str = ""
    where: dict[str, Scalar] = Field(default_factory=dict)
    """Restrict to rows whose axis columns equal these labels."""
    paired: bool = False
    """Also compare run by run: each value of ``axis`` against ``baseline`` with every other axis and
    the seed equal, counting the pairs where it is worse by more than ``tolerance`` ("never worse
    than" claims need this; means can hide one bad seed)."""
    tolerance: Annotated[float, Field(ge=0)] = 0.0
    """Difference (metric units) within which a paired comparison counts as "not worse"."""


class AnalysisSpec(_Strict):
    """What ``summary.md`` emphasises."""

    findings: list[FindingSpec] = Field(default_factory=list)
    confusion_by: list[str] = Field(default_factory=list)
    """Axes for which a confusion matrix (true wheel × isolated wheel) is drawn per value."""
    timeseries_rate: Annotated[float, Field(gt=0, le=100)] = 2.0
    """Rate (Hz) of the compact time series kept per run for over-time figures."""


StudySpec.model_rebuild()


# ---------------------------------------------------------------------------- keys
def flatten_dotted(data: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"a": {"b": 1}, "c.d": 2}`` → ``{"a.b": 1, "c.d": 2}`` (RunConfig has no dict leaves)."""
    out: dict[str, Any] = {}
    for k, v in data.items():
        key = f"{prefix}.{k}" if prefix else str(k)
        if isinstance(v, dict):
            out.update(flatten_dotted(v, key))
        else:
            out[key] = v
    return out


def key_error(key: str) -> str | None:
    """Why ``key`` is not a settable leaf of RunConfig (None if it is)."""
    if key == "feedback":  # the paper's switch, an alias of reconfiguration.policy (none/direct)
        return None
    model: type[BaseModel] = RunConfig
    parts = key.split(".")
    for i, part in enumerate(parts):
        fields = model.model_fields
        if part not in fields:
            where = ".".join(parts[:i]) or "the config"
            return f"unknown key {part!r} in {where}"
        ann = fields[part].annotation
        sub = ann if isinstance(ann, type) and issubclass(ann, BaseModel) else None
        if typing.get_origin(ann) is typing.Annotated:
            ann = typing.get_args(ann)[0]
        if typing.get_origin(ann) is dict:  # a component's options: its own settings check the keys
            return None
        if i < len(parts) - 1:
            if sub is None:
                return f"{'.'.join(parts[: i + 1])} is not a table"
            model = sub
        elif sub is not None:
            return f"{key} is a table, not a value (set its keys)"
    return None


def _subst(obj: Any, env: dict[str, Any]) -> Any:
    """Replace whole-string placeholders ``"{name}"`` by ``env[name]`` (recursively)."""
    if isinstance(obj, str):
        m = PLACEHOLDER.match(obj)
        if m and m.group(1) in env:
            return env[m.group(1)]
        return obj
    if isinstance(obj, list):
        return [_subst(x, env) for x in obj]
    if isinstance(obj, dict):
        return {_subst_key(k, env): _subst(v, env) for k, v in obj.items()}
    return obj


def _subst_key(key: str, env: dict[str, Any]) -> str:
    parts = []
    for part in key.split("."):
        m = PLACEHOLDER.match(part)
        parts.append(str(env[m.group(1)]) if m and m.group(1) in env else part)
    return ".".join(parts)


def _placeholders(obj: Any) -> set[str]:
    found: set[str] = set()
    if isinstance(obj, str):
        for part in obj.split("."):
            m = PLACEHOLDER.match(part)
            if m:
                found.add(m.group(1))
    elif isinstance(obj, list):
        for x in obj:
            found |= _placeholders(x)
    elif isinstance(obj, dict):
        for k, v in obj.items():
            found |= _placeholders(k) | _placeholders(v)
    return found


# ---------------------------------------------------------------------------- plan
@dataclass(frozen=True)
class AxisValue:
    """One value of one axis: the overrides it applies and the label recorded in the results."""

    label: Scalar
    overrides: dict[str, Any]
    raw: Any = None
    """For label axes, the value substituted into placeholders."""


@dataclass
class PlannedRun:
    """One run of the plan: its stable key, axis labels, seed and fully resolved config."""

    index: int
    key: str
    labels: dict[str, Scalar]
    seed: int
    config: dict[str, Any]
    """Resolved config as plain data (``RunConfig.model_dump(mode="json")``), sent to workers."""


@dataclass
class StudyPlan:
    """A validated study expanded to its runs."""

    spec: StudySpec
    path: Path
    study_hash: str
    runs: list[PlannedRun]
    axis_columns: list[str]
    extra_overrides: dict[str, Any] = field(default_factory=dict)
    identity: dict[str, Any] = field(default_factory=dict)
    """What ``study_hash`` hashes: the spec (without description and findings), the ``--set``
    overrides and the base scenario's data."""

    def to_json(self) -> dict[str, Any]:
        """Plain-data form stored as ``plan.json`` in the output folder."""
        return {
            "study": self.spec.name,
            "study_hash": self.study_hash,
            "study_file": str(self.path),
            "extra_overrides": self.extra_overrides,
            "identity": self.identity,
            "axis_columns": self.axis_columns,
            "runs": [{"index": r.index, "key": r.key, "labels": r.labels, "seed": r.seed} for r in self.runs],
        }


def _round(x: float, decimals: int | None) -> float:
    return float(round(x, decimals)) if decimals is not None else float(x)


def _axis_values(i: int, ax: AxisSpec) -> list[AxisValue]:
    """Expand one axis to its values (random draws are seeded per axis)."""
    if ax.kind == "random":
        rng = np.random.default_rng([ax.seed, 1729])
        assert ax.n is not None and ax.key is not None
        if ax.dist == "uniform":
            raw: list[Any] = [_round(v, ax.decimals) for v in rng.uniform(ax.low, ax.high, ax.n)]
        elif ax.dist == "normal":
            raw = [_round(v, ax.decimals) for v in rng.normal(ax.mean, ax.std, ax.n)]
        else:
            assert ax.choices is not None
            raw = [ax.choices[j] for j in rng.integers(0, len(ax.choices), ax.n)]
        vals = raw
    else:
        vals = list(ax.values or [])
    out: list[AxisValue] = []
    for j, v in enumerate(vals):
        if ax.key is not None:
            if isinstance(v, dict):
                raise BadInput(f"axes[{i}].values[{j}]: a keyed axis takes plain values, not tables")
            lab = ax.labels[j] if ax.labels is not None else _label_of(v)
            out.append(AxisValue(lab, {ax.key: v}, v))
        elif isinstance(v, dict):
            lab = ax.labels[j] if ax.labels is not None else f"p{j}"
            out.append(AxisValue(lab, flatten_dotted(v), None))
        else:
            if isinstance(v, list):
                raise BadInput(f"axes[{i}].values[{j}]: a label axis takes scalars (or give a key)")
            lab = ax.labels[j] if ax.labels is not None else v
            out.append(AxisValue(lab, {}, v))
    labels = [json.dumps(a.label) for a in out]
    if ax.kind != "random" and len(set(labels)) != len(labels):
        raise BadInput(f"axes[{i}] ({ax.column}): duplicate values; give distinct labels")
    return out


def _label_of(v: Any) -> Scalar:
    if isinstance(v, (str, int, float, bool)):
        return v
    return json.dumps(v)


def run_key(cfg: RunConfig) -> str:
    """Stable key of a resolved run config: 16 hex digits of :func:`ftc_mj.identity.run_digest` (the
    config without output settings, the model named by its contents), the same from any location."""
    return run_digest(cfg, 16)


def study_path(name_or_path: str | Path) -> Path:
    """The file of a built-in study name (:func:`~ftc_mj.resources.builtin_studies`) or of a study path
    (:class:`BadInput` naming ``STUDY_FILE`` if there is none)."""
    s = str(name_or_path)
    if s in builtin_studies():
        return study_file(s)
    return existing_file(s, "STUDY_FILE", "no such built-in study or file")


def load_study(
    path: Path | str,
    *,
    extra_overrides: dict[str, Any] | None = None,
    seeds: int | None = None,
) -> StudyPlan:
    """Read, validate and expand a study file.

    ``extra_overrides`` (dotted keys) are applied on top of the study's base (e.g. shorter
    durations for a quick look); ``seeds`` replaces the study's seed count. Both are part of the
    study's identity (``study_hash``).
    """
    path = study_path(path)
    raw = read_toml(path, "study")
    try:
        spec = StudySpec.model_validate(raw)
    except ValidationError as err:
        raise BadInput(f"study {path}: {one_line(err)}") from None
    if seeds is not None:
        if seeds < 1:
            raise BadInput("--seeds: must be >= 1")
        spec = spec.model_copy(update={"seeds": seeds})
    extra = dict(extra_overrides or {})

    # ---- base scenario + base overrides
    scen = spec.scenario
    if scen.endswith(".toml") and not Path(scen).is_absolute():
        cand = path.parent / scen
        scen = str(cand if cand.is_file() else Path(scen))
    try:
        spath = scenario_path(scen)
    except BadInput as err:
        raise BadInput(f"study {path}: scenario: {err}") from None
    base_data = read_toml(spath, "scenario")
    base_data.setdefault("name", spath.stem)
    base_ov = flatten_dotted(spec.base)
    for k, v in extra.items():
        base_ov[k] = v

    # ---- axes
    axis_vals: list[list[AxisValue]] = []
    label_axes = {ax.column for ax in spec.axes if ax.key is None and ax.values and not isinstance(ax.values[0], dict)}
    used_placeholders = _placeholders(base_ov)
    for i, ax in enumerate(spec.axes):
        vals = _axis_values(i, ax)
        for v in vals:
            used_placeholders |= _placeholders(v.overrides)
        axis_vals.append(vals)
    for name in sorted(used_placeholders):
        if name not in label_axes:
            raise BadInput(f"study {path}: placeholder {{{name}}} names no label axis")
    for i, ax in enumerate(spec.axes):
        if ax.column in label_axes and ax.column not in used_placeholders:
            raise BadInput(f"study {path}: axes[{i}] ({ax.column}): sets no key and no placeholder uses it")
    # keys: each axis key (and each base key) must be a RunConfig leaf
    # keys with placeholders are checked with each label axis at its first value
    label_env_all = {ax.column: (ax.values or [None])[0] for ax in spec.axes if ax.column in label_axes}
    for k in base_ov:
        err = key_error(_subst_key(k, {n: _first_str(v) for n, v in label_env_all.items()}))
        if err:
            raise BadInput(f"study {path}: base.{k}: {err}")
    for i, (ax, vals) in enumerate(zip(spec.axes, axis_vals, strict=True)):
        for v in vals:
            for k in v.overrides:
                err = key_error(_subst_key(k, {n: _first_str(x) for n, x in label_env_all.items()}))
                if err:
                    what = f"axes[{i}].key ({k})" if ax.key is not None else f"axes[{i}] ({ax.column}) preset key {k}"
                    raise BadInput(f"study {path}: {what}: {err}")

    # ---- combine: zip within groups, cross groups
    groups: dict[str, list[int]] = {}
    for i, ax in enumerate(spec.axes):
        groups.setdefault(ax.default_group, []).append(i)
    group_rows: list[list[dict[int, AxisValue]]] = []
    for gname, idxs in groups.items():
        sizes = {len(axis_vals[i]) for i in idxs}
        if len(sizes) != 1:
            cols = ", ".join(f"{spec.axes[i].column}={len(axis_vals[i])}" for i in idxs)
            raise BadInput(f"study {path}: axes zipped in group {gname!r} differ in length ({cols})")
        n = sizes.pop()
        group_rows.append([{i: axis_vals[i][j] for i in idxs} for j in range(n)])
    if isinstance(spec.seeds, list):
        seed_list = list(spec.seeds)
    elif isinstance(spec.seeds, int):
        seed_list = list(range(spec.seeds))
    else:
        seed_list = [None]  # the base seed
    size = math.prod(len(g) for g in group_rows) * len(seed_list)
    if size > MAX_RUNS:
        shape = " × ".join([str(len(g)) for g in group_rows] + [f"{len(seed_list)} seeds"])
        raise BadInput(f"study {path}: the plan has {size} runs ({shape}); at most {MAX_RUNS} — split the study "
                       "or use fewer values")

    runs: list[PlannedRun] = []
    keys: dict[str, int] = {}
    combos = list(itertools.product(*group_rows)) if group_rows else [()]
    for combo in combos:
        chosen: dict[int, AxisValue] = {}
        for part in combo:
            chosen.update(part)
        env = {spec.axes[i].column: v.raw for i, v in chosen.items() if spec.axes[i].column in label_axes}
        labels = {spec.axes[i].column: chosen[i].label for i in range(len(spec.axes))}
        for seed in seed_list:
            data = json.loads(json.dumps(base_data))
            ov: dict[str, Any] = {}
            ov.update(_subst(base_ov, env))
            for i in range(len(spec.axes)):
                ov.update(_subst(chosen[i].overrides, env))
            if seed is not None:
                ov["seed"] = seed
            for k, v in ov.items():
                try:
                    set_dotted(data, k, v)
                except BadInput as err:
                    raise BadInput(f"study {path}: run {_describe(labels, seed)}: {err}") from None
            try:
                cfg = validate_config(data)
            except BadInput as err:
                raise BadInput(f"study {path}: run {_describe(labels, seed)}: {err}") from None
            key = run_key(cfg)
            if key in keys:
                other = runs[keys[key]]
                raise BadInput(f"study {path}: runs {_describe(other.labels, other.seed)} and "
                               f"{_describe(labels, seed)} resolve to the same config")
            keys[key] = len(runs)
            runs.append(PlannedRun(len(runs), key, labels, cfg.seed, cfg.model_dump(mode="json")))
    # [analysis] findings/confusion_by only shape the summary: editing them must not orphan results
    ident_spec = spec.model_dump(mode="json")
    ident_spec["analysis"] = {"timeseries_rate": spec.analysis.timeseries_rate}
    ident_spec.pop("description", None)
    identity = {"spec": ident_spec, "extra": extra, "base": base_data}
    return StudyPlan(spec, path, canonical_hash(identity), runs, [ax.column for ax in spec.axes], extra,
                     json.loads(json.dumps(identity, default=str)))


def identity_diff(old: dict[str, Any], new: dict[str, Any]) -> list[str]:
    """``"key: old → new"`` for every leaf that differs between two plan identities, named as the user
    wrote them (``seeds``, ``base.duration``, ``axes[0].values``, ``--set duration``, ``scenario.faults.left``)."""
    def flat(d: Any, prefix: str = "") -> dict[str, Any]:
        if isinstance(d, dict):
            out: dict[str, Any] = {}
            for k, v in d.items():
                out.update(flat(v, f"{prefix}.{k}" if prefix else str(k)))
            return out
        if isinstance(d, list) and d and all(isinstance(x, dict) for x in d):
            out = {}
            for i, v in enumerate(d):
                out.update(flat(v, f"{prefix}[{i}]"))
            return out
        return {prefix: d}

    def name(key: str) -> str:
        for pre, shown in (("spec.", ""), ("extra.", "--set "), ("base.", "scenario.")):
            if key.startswith(pre):
                return shown + key[len(pre):]
        return key

    a, b = flat(old), flat(new)
    missing = "(unset)"
    return [f"{name(k)}: {json.dumps(a.get(k, missing), default=str)} → {json.dumps(b.get(k, missing), default=str)}"
            for k in sorted(set(a) | set(b)) if a.get(k, missing) != b.get(k, missing)]


def _first_str(v: Any) -> str:
    """A label value as it appears in a key segment."""
    return v if isinstance(v, str) else str(v)


def _describe(labels: dict[str, Scalar], seed: int | None) -> str:
    parts = [f"{k}={v}" for k, v in labels.items()]
    if seed is not None:
        parts.append(f"seed={seed}")
    return "(" + ", ".join(parts) + ")" if parts else "(base)"
