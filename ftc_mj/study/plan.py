"""A study file expanded into its plan: every run's stable key, axis labels, seed and resolved config.

:func:`plan_study` reads a study file (:mod:`.spec`), resolves its base scenario and overrides,
expands each axis (:func:`expand_axis`), checks every key and placeholder, combines the axes (zipped
within a group, crossed between groups, crossed with the seeds) and validates every run's config;
the plan's ``study_hash`` identifies the results it may share an output folder with.
"""

from __future__ import annotations

import itertools
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..config import RunConfig, existing_file, read_toml, scenario_path, set_dotted, validate_config
from ..errors import BadInput
from ..identity import canonical_hash, run_digest
from ..resources import builtin_studies, study_file
from ..suggest import did_you_mean
from .spec import AxisSpec, Scalar, StudySpec, check_tuning_seeds, flatten_dotted, key_error, read_study_spec

PLACEHOLDER = re.compile(r"^\{([A-Za-z_][A-Za-z0-9_]*)\}$")
MAX_RUNS = 10_000
"""Largest plan (runs, seeds included) a study may expand to: planning validates every run's config
(about 0.5 ms each) and a run takes seconds, so beyond this a study is a typing slip; split it."""





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


def expand_axis(i: int, ax: AxisSpec) -> list[AxisValue]:
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
    return existing_file(s, "STUDY_FILE", "no such built-in study or file", did_you_mean(s, builtin_studies()))


def plan_study(
    path: Path | str,
    *,
    extra_overrides: dict[str, Any] | None = None,
    seeds: int | None = None,
) -> StudyPlan:
    """Read, validate and expand a study file (a path or a built-in study name).

    ``extra_overrides`` (dotted keys) are applied on top of the study's base (e.g. shorter
    durations for a quick look); ``seeds`` replaces the study's seed count. Both are part of the
    study's identity (``study_hash``).
    """
    path = study_path(path)
    spec = read_study_spec(path, seeds)
    extra = dict(extra_overrides or {})
    base_data, base_ov = _base(spec, path, extra)
    base_seed = base_ov.get("seed", base_data.get("seed", 0))
    check_tuning_seeds(spec, path, list(spec.seeds) if isinstance(spec.seeds, list) else list(range(spec.seeds))
                       if isinstance(spec.seeds, int) else [base_seed] if isinstance(base_seed, int) else [])
    axis_vals = [expand_axis(i, ax) for i, ax in enumerate(spec.axes)]
    label_axes = _check_placeholders(spec, path, base_ov, axis_vals)
    _check_keys(spec, path, base_ov, axis_vals, label_axes)
    group_rows, seed_list = _combinations(spec, path, axis_vals)
    runs = _expand(spec, path, base_data, base_ov, label_axes, group_rows, seed_list)
    # [analysis] findings/confusion_by only shape the summary: editing them must not orphan results
    ident_spec = spec.model_dump(mode="json")
    ident_spec["analysis"] = {"timeseries_rate": spec.analysis.timeseries_rate}
    if spec.analysis.trace_stats:  # they add columns to the rows (absent: the identity of older studies)
        ident_spec["analysis"]["trace_stats"] = [t.model_dump(mode="json") for t in spec.analysis.trace_stats]
    if spec.analysis.extras:
        ident_spec["analysis"]["extras"] = list(spec.analysis.extras)
    if spec.analysis.timeseries_columns:  # more series in the rows (absent: the identity of older studies)
        ident_spec["analysis"]["timeseries_columns"] = list(spec.analysis.timeseries_columns)
    ident_spec.pop("description", None)
    ident_spec.pop("tuning", None)  # a flag on how results may be used: the runs (and their folder) are the same
    identity = {"spec": ident_spec, "extra": extra, "base": base_data}
    return StudyPlan(spec, path, canonical_hash(identity), runs, [ax.column for ax in spec.axes], extra,
                     json.loads(json.dumps(identity, default=str)))


def _base(spec: StudySpec, path: Path, extra: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """The base scenario's data and the base overrides (the study's ``base``, then ``extra``)."""
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
    return base_data, base_ov


def _check_placeholders(spec: StudySpec, path: Path, base_ov: dict[str, Any],
                        axis_vals: list[list[AxisValue]]) -> set[str]:
    """Every placeholder names a label axis (no key, scalar values) and every label axis fills one;
    returns the label axes' columns."""
    label_axes = {ax.column for ax in spec.axes if ax.key is None and ax.values and not isinstance(ax.values[0], dict)}
    used = _placeholders(base_ov)
    for vals in axis_vals:
        for v in vals:
            used |= _placeholders(v.overrides)
    for name in sorted(used):
        if name not in label_axes:
            raise BadInput(f"study {path}: placeholder {{{name}}} names no label axis")
    for i, ax in enumerate(spec.axes):
        if ax.column in label_axes and ax.column not in used:
            raise BadInput(f"study {path}: axes[{i}] ({ax.column}): sets no key and no placeholder uses it")
    return label_axes


def _check_keys(spec: StudySpec, path: Path, base_ov: dict[str, Any], axis_vals: list[list[AxisValue]],
                label_axes: set[str]) -> None:
    """Each base and axis key is a RunConfig leaf (a key with placeholders is checked with each label
    axis at its first value)."""
    env = {ax.column: _first_str((ax.values or [None])[0]) for ax in spec.axes if ax.column in label_axes}
    for k in base_ov:
        err = key_error(_subst_key(k, env))
        if err:
            raise BadInput(f"study {path}: base.{k}: {err}")
    for i, (ax, vals) in enumerate(zip(spec.axes, axis_vals, strict=True)):
        for v in vals:
            for k in v.overrides:
                err = key_error(_subst_key(k, env))
                if err:
                    what = f"axes[{i}].key ({k})" if ax.key is not None else f"axes[{i}] ({ax.column}) preset key {k}"
                    raise BadInput(f"study {path}: {what}: {err}")


def _combinations(spec: StudySpec, path: Path,
                  axis_vals: list[list[AxisValue]]) -> tuple[list[list[dict[int, AxisValue]]], list[int | None]]:
    """The rows of each axis group (axes of a group zipped) and the seeds (``[None]``: the base seed);
    the plan they cross into must stay within :data:`MAX_RUNS`."""
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
    seed_list: list[int | None]
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
    return group_rows, seed_list


def outline_study(path: Path | str) -> StudyPlan:
    """A built-in study's runs as :func:`plan_study` lists them, without resolving a run: each run's config is
    the base scenario's data with its overrides (not validated, defaults not filled in) and its key its index —
    what ``ftc-mj studies`` needs (run count, durations, faults, logged statistics) at a small part of the cost
    of validating and hashing thousands of configs. Not for running: :func:`plan_study` checks every run."""
    path = study_path(path)
    spec = read_study_spec(path, None)
    base_data, base_ov = _base(spec, path, {})
    axis_vals = [expand_axis(i, ax) for i, ax in enumerate(spec.axes)]
    label_axes = _check_placeholders(spec, path, base_ov, axis_vals)
    group_rows, seed_list = _combinations(spec, path, axis_vals)
    runs = _expand(spec, path, base_data, base_ov, label_axes, group_rows, seed_list, resolve=False)
    return StudyPlan(spec, path, "", runs, [ax.column for ax in spec.axes])


def _outline_run(index: int, base_data: dict[str, Any], ov: dict[str, Any], labels: dict[str, Scalar]
                 ) -> PlannedRun:
    """One run of :func:`outline_study`: the base data with ``ov`` set (unvalidated), the default duration
    and seed where the data has none."""
    data = json.loads(json.dumps(base_data))
    for k, v in ov.items():
        set_dotted(data, k, v)
    for k in ("duration", "seed"):
        data.setdefault(k, RunConfig.model_fields[k].default)
    return PlannedRun(index, str(index), labels, int(data["seed"]), data)


def _expand(spec: StudySpec, path: Path, base_data: dict[str, Any], base_ov: dict[str, Any], label_axes: set[str],
            group_rows: list[list[dict[int, AxisValue]]], seed_list: list[int | None], resolve: bool = True
            ) -> list[PlannedRun]:
    """Every combination of the groups' rows and the seeds as a planned run (distinct configs required);
    ``resolve=False``: unvalidated outlines (:func:`outline_study`)."""
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
            ov: dict[str, Any] = {}
            ov.update(_subst(base_ov, env))
            for i in range(len(spec.axes)):
                ov.update(_subst(chosen[i].overrides, env))
            if seed is not None:
                ov["seed"] = seed
            if not resolve:
                runs.append(_outline_run(len(runs), base_data, ov, labels))
                continue
            cfg = _resolve(path, base_data, ov, labels, seed)
            key = run_key(cfg)
            if key in keys:
                other = runs[keys[key]]
                raise BadInput(f"study {path}: runs {_describe(other.labels, other.seed)} and "
                               f"{_describe(labels, seed)} resolve to the same config")
            keys[key] = len(runs)
            runs.append(PlannedRun(len(runs), key, labels, cfg.seed, cfg.model_dump(mode="json")))
    return runs


def _resolve(path: Path, base_data: dict[str, Any], ov: dict[str, Any], labels: dict[str, Scalar],
             seed: int | None) -> RunConfig:
    """The base scenario with one run's overrides applied, validated."""
    data = json.loads(json.dumps(base_data))
    for k, v in ov.items():
        try:
            set_dotted(data, k, v)
        except BadInput as err:
            raise BadInput(f"study {path}: run {_describe(labels, seed)}: {err}") from None
    try:
        return validate_config(data)
    except BadInput as err:
        raise BadInput(f"study {path}: run {_describe(labels, seed)}: {err}") from None


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
