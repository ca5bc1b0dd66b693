"""Study files: a base scenario plus axes to sweep, expanded to a plan. A study is a TOML file or
the name of a built-in study (``ftc_mj/data/studies/*.toml``: ``observability``, ``severity``, …).

A study file names a base scenario (built-in name or TOML path, relative paths resolved against
the study file's folder), base overrides, the axes to sweep and the Monte-Carlo seeds::

    name = "observability"
    scenario = "scenario2"
    seeds = 5                            # or a list: [0, 3, 7]
    tuning = false                       # true: a tuning study; held-out seeds (>= 1000) are refused

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
validated before anything runs (:func:`ftc_mj.study.plan.plan_study`); all problems are
:class:`~ftc_mj.errors.BadInput` with a one-line message naming the study field.

This module is the file's schema (pydantic models, read with a one-line error naming the field, the
check of a dotted key against the run configuration); :mod:`.plan` expands a file into runs.
"""

from __future__ import annotations

import json
import typing
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from ..config import RunConfig, SafeName, one_line, read_toml
from ..errors import BadInput
from ..suggest import section_fields, submodels, suggest_key

Scalar = str | int | float | bool
HELD_OUT_START = 1000
"""The seed policy: seeds 0–999 are development seeds (tune and explore there), seeds from 1000 on are
held out (judged on, never tuned on); the benchmark's test split draws its run seeds there too."""
RESERVED_COLUMNS = frozenset({"run_key", "run_index", "seed", "status", "error", "invocation"})


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
    tuning: bool = False
    """A tuning study (something is chosen on its results): it may run development seeds only (below
    :data:`HELD_OUT_START`); planning one with a held-out seed is refused (:func:`check_tuning_seeds`)."""

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


class TraceStatSpec(_Strict):
    """A statistic of one trace column over a time window, computed in the worker from the full trace
    (the results keep only down-sampled series) and stored as the results column ``name``."""

    name: str
    column: str
    """Trace column (``R_L_hat``, ``cross_track_error``, ``yaw_rate`` …)."""
    stat: Literal["mean", "std", "max_abs"]
    """``mean``, ``std`` (population, ddof 0) or ``max_abs`` (largest absolute value), in the column's unit."""
    start: float = 0.0
    """Window start (s, inclusive)."""
    end: float | None = None
    """Window end (s; unset: the end of the run)."""
    end_inclusive: bool = True
    """Whether a sample at ``end`` belongs to the window."""


class AnalysisSpec(_Strict):
    """What ``summary.md`` emphasises, and the trace statistics the runs add to their rows."""

    findings: list[FindingSpec] = Field(default_factory=list)
    confusion_by: list[str] = Field(default_factory=list)
    """Axes for which a confusion matrix (true wheel × isolated wheel) is drawn per value."""
    figures: bool = True
    """Draw the summary's figures (``figures/*.png``: metrics by axis value, over time, confusion);
    ``false`` writes the tables alone (drawing is most of an analysis's time: seconds per axis)."""
    timeseries_rate: Annotated[float, Field(gt=0, le=100)] = 2.0
    """Rate (Hz) of the compact time series kept per run for over-time figures; the trace has one row per
    estimator step, so ``estimator.rate`` (100 Hz by default) keeps every row."""
    timeseries_columns: list[Annotated[str, Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$")]] = Field(
        default_factory=list)
    """Trace columns kept in the compact time series besides :data:`~ftc_mj.study.worker.TS_COLUMNS`
    (``v``, ``yaw_rate``, ``plant_flags`` …, stored as ``ts_<column>``; a column a run's trace lacks is
    left out of its row). Part of the study's identity when set."""
    trace_stats: list[TraceStatSpec] = Field(default_factory=list)
    """Statistics of the full trace added to each run's row (part of the study's identity)."""
    extras: list[Literal["pcrb_split"]] = Field(default_factory=list)
    """Per-run computations on the full trace (:mod:`ftc_mj.study.extras`) added to each run's row (part of
    the study's identity)."""

    @model_validator(mode="after")
    def _distinct_columns(self) -> AnalysisSpec:
        seen: set[str] = set()
        for i, c in enumerate(self.timeseries_columns):
            if c in seen:
                raise ValueError(f"timeseries_columns[{i}]: duplicate column {c!r}")
            seen.add(c)
        return self


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
    models: list[type] = [RunConfig]  # a section discriminated by kind: every kind's model
    parts = key.split(".")
    for i, part in enumerate(parts):
        fields = section_fields(models)
        if part not in fields:
            where = ".".join(parts[:i]) or "the config"
            near = suggest_key(RunConfig, parts, i)
            return f"unknown key {part!r} in {where}" + (f" (did you mean {near}?)" if near else "")
        ann = fields[part].annotation
        subs = submodels(ann)  # a section discriminated by kind: every member
        if typing.get_origin(ann) is typing.Annotated:
            ann = typing.get_args(ann)[0]
        if typing.get_origin(ann) is dict:  # a component's options: its own settings check the keys
            return None
        if i < len(parts) - 1:
            if not subs:
                return f"{'.'.join(parts[: i + 1])} is not a table"
            models = subs
        elif subs:
            return f"{key} is a table, not a value (set its keys)"
    return None


def check_tuning_seeds(spec: StudySpec, path: Path, seeds: list[int]) -> None:
    """Refuse (:class:`BadInput`, one line) a tuning study whose plan holds a held-out seed: the sealed
    seeds are never tuned on."""
    held = sorted(s for s in seeds if s >= HELD_OUT_START)
    if spec.tuning and held:
        raise BadInput(f"study {path}: seeds: a tuning study (tuning = true) runs development seeds only "
                       f"(0-{HELD_OUT_START - 1}); got held-out seed {held[0]} — tune on dev, judge on held-out")


def read_study_spec(path: Path, seeds: int | None = None) -> StudySpec:
    """The validated :class:`StudySpec` of a study file, its seed count replaced by ``seeds`` if given
    (:class:`BadInput` naming the field otherwise)."""
    raw = read_toml(path, "study")
    try:
        spec = StudySpec.model_validate(raw)
    except ValidationError as err:
        raise BadInput(f"study {path}: {one_line(err)}") from None
    if seeds is not None:
        if seeds < 1:
            raise BadInput("--seeds: must be >= 1")
        spec = spec.model_copy(update={"seeds": seeds})
    return spec
